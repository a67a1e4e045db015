#!/usr/bin/env python3
"""Write the FORTE protocol v1 test vectors shared by the C core tests and the Python tests.

This generator is deliberately independent of both decoders: frames are packed with
``struct`` and ``binascii.crc_hqx`` (CRC-16/CCITT-FALSE with initial value 0xFFFF), and
the expected decoder counters of each vector are written down by hand from the counting
rules in docs/firmware.md (the generator only asserts the assumptions those hand-derived
numbers rely on, e.g. that a truncated frame really fails its CRC).

Run from anywhere: ``python3 firmware/test_vectors/make_vectors.py``; it rewrites
``decoder_vectors.txt``, ``crc_vectors.txt`` and ``normalise_vectors.txt`` next to itself.
"""
from __future__ import annotations

import binascii
import struct
from pathlib import Path

HERE = Path(__file__).resolve().parent
SIGNATURE = bytes([0xA5, 0x5A, 0x01])
SAMPLE, COMMAND, ACK, INFO = 1, 2, 3, 4


def crc16(data: bytes) -> int:
    return binascii.crc_hqx(data, 0xFFFF)


def frame(frame_type: int, payload: bytes) -> bytes:
    body = bytes([0x01, frame_type, len(payload)]) + payload
    return bytes([0xA5, 0x5A]) + body + struct.pack('<H', crc16(body))


def sample(seq, time_us, values, overruns=0, flags=0, saturated=0):
    payload = struct.pack('<IQ6hHBB', seq, time_us, *values, overruns, flags, saturated)
    fields = (f'frame sample seq={seq} time_us={time_us} values={",".join(map(str, values))} '
              f'overruns={overruns} flags={flags} saturated={saturated}')
    return frame(SAMPLE, payload), fields


def ack(command, token, status, value):
    payload = struct.pack('<BBBBI', command, token, status, 0, value)
    text = f'frame ack command={command} token={token} status={status} value={value}'
    return frame(ACK, payload), text


def command(code, token, argument):
    payload = struct.pack('<BBH', code, token, argument)
    text = f'frame command command={code} token={token} argument={argument}'
    return frame(COMMAND, payload), text


def info(rate_hz, device_id):
    payload = struct.pack('<BBBBBBHHHQ', 1, 1, 0, 0, 6, 12, 1024, rate_hz, 512, device_id)
    return frame(INFO, payload), (f'frame info protocol_version=1 firmware=1.0.0 channels=6 '
                                  f'adc_bits=12 counts_per_full_scale=1024 rate_hz={rate_hz} '
                                  f'ring_capacity=512 device_id={device_id}')


def no_signature(data: bytes) -> bool:
    return SIGNATURE not in data


def flip(data: bytes, index: int, bit: int) -> bytes:
    out = bytearray(data)
    out[index] ^= 1 << bit
    return bytes(out)


#: One decoder vector: name, description, input bytes, expected frame lines, counters.
Vector = tuple[str, str, bytes, list[str], dict[str, int]]


def reference_frames() -> dict[str, tuple[bytes, str]]:
    """The frames the vectors are built from: ``{name: (bytes, expected frame line)}``."""
    frames = {
        's0': sample(0, 1_000_000, [0, 1, -1, 512, -512, 1024]),
        's1': sample(1, 1_000_500, [10, 20, 30, -40, -50, -60]),
        's2': sample(2, 1_001_000, [-1024, 1024, 0, 0, 1023, -1023], flags=1,
                     saturated=0b000011),
        'sw0': sample(0xFFFFFFFF, 2**40 + 123, [1, 2, 3, 4, 5, 6], overruns=65535, flags=2),
        'sw1': sample(0, 2**40 + 623, [6, 5, 4, 3, 2, 1], overruns=0, flags=4),
        'big': sample(7, 2**64 - 1, [-1, -2, -3, -4, -5, -6], overruns=3, flags=2),
        'a0': ack(1, 7, 0, 2000),
        'a1': ack(4, 8, 2, 2000),
        'c0': command(4, 9, 1000),
        'i0': info(2000, 0x0123456789ABCDEF),
    }
    for name in ('s0', 's1', 's2', 'sw0', 'sw1', 'big'):
        assert no_signature(frames[name][0][1:]), 'a payload must not contain the signature'
    return frames


def clean_vectors(frames: dict[str, tuple[bytes, str]]) -> list[Vector]:
    """Streams of intact frames, with leading garbage, false or foreign signatures."""
    (s0, f0), (s1, f1), (s2, f2) = frames['s0'], frames['s1'], frames['s2']
    (sw0, fw0), (sw1, fw1), (big, fbig) = frames['sw0'], frames['sw1'], frames['big']
    (a0, fa0), (a1, fa1), (c0, fc0), (i0, fi0) = (frames['a0'], frames['a1'], frames['c0'],
                                                  frames['i0'])
    garbage, false_prefix = GARBAGE, FALSE_PREFIX
    wrong_version = bytes([0xA5, 0x5A, 0x02]) + s1[3:]
    return [
        vector('empty', 'no input at all', b'', [], 0, 0, 0),
        vector('single_sample', 'one sample frame', s0, [f0], 1, 0, 0),
        vector('three_samples', 'three consecutive sample frames', s0 + s1 + s2, [f0, f1, f2],
               3, 0, 0),
        vector('sequence_wrap', 'sequence 0xFFFFFFFF then 0, large timestamps', sw0 + sw1,
               [fw0, fw1], 2, 0, 0),
        vector('max_timestamp', 'time_us = 2^64-1 and negative readings', big, [fbig], 1, 0, 0),
        vector('leading_garbage', 'garbage bytes (no 0xA5) before a frame', garbage + s0, [f0],
               1, 0, 6),
        vector('false_sync', 'partial signatures (A5, A5 5A, A5 A5) before a frame',
               false_prefix + s0, [f0], 1, 0, 7),
        vector('wrong_version', 'a frame with version 2 is not a candidate: discarded, not '
               'corrupt', wrong_version + s0, [f0], 1, 0, len(wrong_version)),
        vector('ack_info_command', 'acknowledgement, identification and command frames',
               a0 + i0 + a1 + c0, [fa0, fi0, fa1, fc0], 4, 0, 0),
    ]


def damaged_vectors(frames: dict[str, tuple[bytes, str]]) -> list[Vector]:
    """Streams with flipped bits, wrong header fields, truncation and hidden frames."""
    (s0, f0), (s1, _), (s2, f2) = frames['s0'], frames['s1'], frames['s2']
    (a0, fa0) = frames['a0']
    bad_payload = flip(s1, 12, 3)
    assert no_signature(bad_payload[1:])
    bad_length = bytearray(s1)
    bad_length[4] = 27
    bad_type = bytearray(s1)
    bad_type[3] = 0x09
    truncated = s1[:20]
    assert crc16((truncated + s2)[2:33]) != struct.unpack_from('<H', truncated + s2, 33)[0]
    hidden = SIGNATURE + bytes([0x01, 28])
    return [
        vector('payload_bit_flip', 'one flipped payload bit between two good frames',
               s0 + bad_payload + s2, [f0, f2], 2, 1, len(s1)),
        vector('crc_bit_flip', 'one flipped CRC bit', s0 + flip(s1, len(s1) - 1, 0) + s2,
               [f0, f2], 2, 1, len(s1)),
        vector('bad_length', 'length byte wrong for the type', bytes(bad_length) + s2, [f2],
               1, 1, len(s1)),
        vector('unknown_type', 'unknown frame type', bytes(bad_type) + s2, [f2], 1, 1, len(s1)),
        vector('truncated_20', 'frame cut after 20 bytes, then a good frame',
               s0 + truncated + s2, [f0, f2], 2, 1, 20),
        vector('truncated_4', 'frame cut inside the header (4 bytes): bad length, corrupt',
               s1[:4] + s2, [f2], 1, 1, 4),
        vector('truncated_3', 'only the signature: the next bytes give an unknown type, '
               'corrupt', s1[:3] + s2, [f2], 1, 1, 3),
        vector('truncated_2', 'two sync bytes only: not a full signature, discarded',
               s1[:2] + s2, [f2], 1, 0, 2),
        vector('hidden_frame', 'a false candidate header swallows a good frame; the decoder '
               'finds it again by resuming one byte after the rejected candidate',
               hidden + s0, [f0], 1, 1, 5),
        vector('pending_tail', 'a good frame then the first 10 bytes of the next one (kept, '
               'pending)', s0 + s1[:10], [f0], 1, 0, 0, pending=10),
        vector('mixed_stream', 'samples and an ack interleaved with garbage and one flip',
               GARBAGE + s0 + a0 + flip(s1, 30, 7) + FALSE_PREFIX + s2, [f0, fa0, f2], 3, 1,
               len(GARBAGE) + len(s1) + len(FALSE_PREFIX)),
    ]


#: Bytes without 0xA5, and partial signatures, put before good frames.
GARBAGE = bytes([0x00, 0x11, 0xFF, 0x5A, 0x01, 0x42])
FALSE_PREFIX = bytes([0xA5, 0x00, 0xA5, 0x5A, 0x00, 0xA5, 0xA5])
#: The order of the vectors in decoder_vectors.txt.
VECTOR_ORDER = ('empty', 'single_sample', 'three_samples', 'sequence_wrap', 'max_timestamp',
                'leading_garbage', 'false_sync', 'wrong_version', 'payload_bit_flip',
                'crc_bit_flip', 'bad_length', 'unknown_type', 'truncated_20', 'truncated_4',
                'truncated_3', 'truncated_2', 'hidden_frame', 'pending_tail', 'ack_info_command',
                'mixed_stream')


def vector(name: str, description: str, data: bytes, frames: list[str], frames_n: int,
           corrupt: int, discarded: int, pending: int = 0) -> Vector:
    """One decoder vector with the counters a decoder must show after ``data``."""
    expect = dict(frames=frames_n, corrupt=corrupt, discarded=discarded, pending=pending)
    return name, description, data, frames, expect


def write_decoder_vectors(vectors: list[Vector]) -> None:
    lines = ['# FORTE protocol v1 decoder vectors. Generated by make_vectors.py; do not edit.',
             '# Per vector: input bytes (hex), the frames a decoder must output in order, and',
             '# the counters after feeding all bytes (frames, corrupt, discarded, pending).', '']
    for name, description, data, frames, expect in vectors:
        lines.append(f'vector {name}')
        lines.append(f'# {description}')
        lines.append(f'input {data.hex()}')
        lines.extend(frames)
        lines.append('expect ' + ' '.join(f'{k}={v}' for k, v in expect.items()))
        lines.append('end')
        lines.append('')
    (HERE / 'decoder_vectors.txt').write_text('\n'.join(lines))


def write_crc_vectors(sample_frame: bytes) -> None:
    crc_lines = ['# CRC-16/CCITT-FALSE vectors: input (hex; "-" = empty) and CRC (hex).']
    for data in (b'123456789', b'', b'\x00', b'\xff\xff', bytes(range(256)), sample_frame[2:-2]):
        crc_lines.append(f'crc {data.hex() or "-"} {crc16(data):04x}')
    (HERE / 'crc_vectors.txt').write_text('\n'.join(crc_lines) + '\n')


#: ADC code -> reading cases: (code, zero code, half-span code, expected, clipped).
NORMALISE_CASES = [
    (2048, 2048, 2048, 0, 0), (2049, 2048, 2048, 1, 0), (2047, 2048, 2048, -1, 0),
    (2050, 2048, 2048, 1, 0), (2051, 2048, 2048, 2, 0), (2045, 2048, 2048, -2, 0),
    (0, 2048, 2048, -1024, 0), (4095, 2048, 2048, 1024, 0), (4096, 2048, 2048, 1024, 0),
    (1000, 2000, 1000, -1024, 0), (3000, 2000, 1000, 1024, 0),
    (3001, 2000, 1000, 1024, 1), (999, 2000, 1000, -1024, 1),
    (2500, 2000, 1000, 512, 0), (2000, 2000, 1000, 0, 0),
    (2001, 2000, 3, 341, 0), (2002, 2000, 3, 683, 0), (1999, 2000, 3, -341, 0),
    (0, 4095, 100, -1024, 1), (4095, 0, 100, 1024, 1), (1861, 1861, 1241, 0, 0),
    (1862, 1861, 1241, 1, 0), (3102, 1861, 1241, 1024, 0),
]


def write_normalise_vectors() -> None:
    norm_lines = ['# ADC code -> reading: code zero_code half_span_code expected clipped(0/1)',
                  '# expected = round((code - zero) * 1024 / half_span), ties away from zero,',
                  '# clipped to [-1024, 1024].']
    for code, zero, half, expected, clipped in NORMALISE_CASES:
        exact = (code - zero) * 1024 / half
        rounded = int(abs(exact) + 0.5) * (1 if exact >= 0 else -1)
        assert max(-1024, min(1024, rounded)) == expected, (code, zero, half)
        assert clipped == int(abs(rounded) > 1024), (code, zero, half)
        norm_lines.append(f'{code} {zero} {half} {expected} {clipped}')
    (HERE / 'normalise_vectors.txt').write_text('\n'.join(norm_lines) + '\n')


def main() -> None:
    frames = reference_frames()
    by_name = {vector[0]: vector for vector in clean_vectors(frames) + damaged_vectors(frames)}
    write_decoder_vectors([by_name[name] for name in VECTOR_ORDER])
    write_crc_vectors(frames['s0'][0])
    write_normalise_vectors()


if __name__ == '__main__':
    main()
