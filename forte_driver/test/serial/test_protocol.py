"""Known-answer tests of forte_driver.serial.protocol against the vectors shared with the C core."""
from __future__ import annotations

import random
import struct
from pathlib import Path

import numpy as np
import pytest

from forte_driver.serial import protocol
from forte_driver.serial.protocol import (
    Ack,
    AsciiLineDecoder,
    AsciiSample,
    CorruptFrame,
    FrameDecoder,
    Info,
    Sample,
)
from forte_driver.serial.stream import SequenceTracker, StreamAssembler

VECTORS = Path(__file__).resolve().parents[3] / 'firmware' / 'test_vectors'


def load_decoder_vectors() -> list[dict]:
    vectors, current = [], None
    for line in (VECTORS / 'decoder_vectors.txt').read_text().splitlines():
        if line.startswith('vector '):
            current = {'name': line[7:], 'frames': [], 'input': b''}
        elif current is None or line.startswith('#'):
            continue
        elif line.startswith('input'):
            current['input'] = bytes.fromhex(line[5:].strip())
        elif line.startswith('frame '):
            current['frames'].append(line)
        elif line.startswith('expect '):
            current['expect'] = {k: int(v) for k, v in
                                 (item.split('=') for item in line[7:].split())}
        elif line == 'end':
            vectors.append(current)
            current = None
    return vectors


def format_frame(frame) -> str:
    """Same text form as the vector file (and as test_core.c)."""
    if isinstance(frame, Sample):
        return (f'frame sample seq={frame.sequence} time_us={frame.time_us} '
                f'values={",".join(map(str, frame.values))} overruns={frame.overruns} '
                f'flags={frame.flags} saturated={frame.saturated}')
    if isinstance(frame, Ack):
        return (f'frame ack command={frame.command} token={frame.token} status={frame.status} '
                f'value={frame.value}')
    if isinstance(frame, protocol.CommandFrame):
        return (f'frame command command={frame.command} token={frame.token} '
                f'argument={frame.argument}')
    assert isinstance(frame, Info)
    return (f'frame info protocol_version={frame.protocol_version} '
            f'firmware={".".join(map(str, frame.firmware_version))} '
            f'channels={frame.channel_count} adc_bits={frame.adc_bits} '
            f'counts_per_full_scale={frame.counts_per_full_scale} rate_hz={frame.rate_hz} '
            f'ring_capacity={frame.ring_capacity} device_id={frame.device_id}')


DECODER_VECTORS = load_decoder_vectors()


def test_vector_file_covers_the_fault_cases():
    names = {vector['name'] for vector in DECODER_VECTORS}
    assert {'payload_bit_flip', 'truncated_20', 'hidden_frame', 'leading_garbage',
            'sequence_wrap', 'pending_tail', 'ack_info_command'} <= names


@pytest.mark.parametrize('chunk', [None, 1, 2, 3, 7, 35, 64])
@pytest.mark.parametrize('vector', DECODER_VECTORS, ids=lambda v: v['name'])
def test_decoder_vectors(vector, chunk):
    decoder = FrameDecoder()
    data = vector['input']
    step = len(data) or 1 if chunk is None else chunk
    items = []
    for offset in range(0, max(len(data), 1), step):
        items += decoder.feed(data[offset:offset + step])
    frames = [item for item in items if not isinstance(item, CorruptFrame)]
    assert [format_frame(frame) for frame in frames] == vector['frames']
    expect = vector['expect']
    assert decoder.frames == expect['frames']
    assert decoder.corrupt_frames == expect['corrupt']
    assert sum(isinstance(item, CorruptFrame) for item in items) == expect['corrupt']
    assert decoder.discarded_bytes == expect['discarded']
    assert decoder.pending_bytes == expect['pending']


CLEAN_VECTORS = [v for v in DECODER_VECTORS if not (
    v['expect']['corrupt'] or v['expect']['discarded'] or v['expect']['pending'])]


@pytest.mark.parametrize('vector', CLEAN_VECTORS, ids=lambda v: v['name'])
def test_clean_vectors_reencode_to_the_same_bytes(vector):
    frames = FrameDecoder().feed(vector['input'])
    encoders = {Sample: protocol.encode_sample, Ack: protocol.encode_ack,
                Info: protocol.encode_info,
                protocol.CommandFrame: lambda c: protocol.encode_command(c.command, c.token,
                                                                         c.argument)}
    assert b''.join(encoders[type(frame)](frame) for frame in frames) == vector['input']


def test_crc_vectors():
    count = 0
    for line in (VECTORS / 'crc_vectors.txt').read_text().splitlines():
        if not line.startswith('crc '):
            continue
        _, hex_input, hex_crc = line.split()
        data = b'' if hex_input == '-' else bytes.fromhex(hex_input)
        assert protocol.crc16(data) == int(hex_crc, 16)
        count += 1
    assert count >= 6
    assert protocol.crc16(b'123456789') == 0x29B1


def test_normalisation_vectors():
    count = 0
    for line in (VECTORS / 'normalise_vectors.txt').read_text().splitlines():
        if line.startswith('#') or not line.strip():
            continue
        code, zero, half, expected, clipped = map(int, line.split())
        assert protocol.normalise_adc_code(code, zero, half) == (expected, bool(clipped))
        count += 1
    assert count >= 20


def test_frame_sizes_match_the_documented_layout():
    sample = Sample(1, 2, (0,) * 6)
    assert len(protocol.encode_sample(sample)) == protocol.SAMPLE_FRAME_SIZE == 35
    assert len(protocol.encode_command(protocol.Command.START, 1)) == 11
    assert len(protocol.encode_ack(Ack(1, 1, 0, 2000))) == 15
    frame = protocol.encode_sample(Sample(0x01020304, 0x1122334455667788, (1, -1, 2, -2, 3, -3),
                                          7, 2, 5))
    assert frame[:5] == bytes([0xA5, 0x5A, 0x01, 0x01, 28])
    assert frame[5:9] == bytes([4, 3, 2, 1])            # sequence, little-endian
    assert struct.unpack_from('<Q', frame, 9)[0] == 0x1122334455667788
    assert struct.unpack_from('<6h', frame, 17) == (1, -1, 2, -2, 3, -3)
    assert frame[29:33] == bytes([7, 0, 2, 5])          # overruns, flags, saturated
    assert struct.unpack_from('<H', frame, 33)[0] == protocol.crc16(frame[2:33])


def random_stream(seed: int, frames: int):
    """Frames with random faults; returns bytes, intact samples, expected drops/corrupt."""
    rng = random.Random(seed)
    out, intact, dropped, corrupt = bytearray(), [], 0, 0
    allowed_garbage = [b for b in range(256) if b not in (0xA5, 0x5A, 0x01)]
    for sequence in range(frames):
        sample = Sample(sequence, 1000 + 500 * sequence,
                        tuple(rng.randint(-1024, 1024) for _ in range(6)))
        data = protocol.encode_sample(sample)
        if protocol.SIGNATURE in data[1:]:
            out += data
            intact.append(sample)
            continue
        fault = rng.choice(['none'] * 6 + ['garbage', 'flip', 'truncate', 'gap'])
        if sequence >= frames - 3:
            fault = 'none'  # end cleanly: a damaged last frame would stay pending
        if fault == 'garbage':
            out += bytes(rng.choice(allowed_garbage) for _ in range(rng.randint(1, 50)))
        if fault == 'flip':
            index = rng.randrange(len(data))
            flipped = bytearray(data)
            flipped[index] ^= 1 << rng.randrange(8)
            if protocol.SIGNATURE in flipped[1:]:
                continue  # would create a second candidate; count it as a plain gap
            out += flipped
            dropped += 1
            corrupt += index >= 3
        elif fault == 'truncate':
            cut = rng.randint(1, len(data) - 2)  # >= 2 bytes missing (see emulator)
            out += data[:cut]
            dropped += 1
            corrupt += cut >= 3
        elif fault == 'gap':
            dropped += 1
        else:
            out += data
            intact.append(sample)
    return bytes(out), intact, dropped, corrupt


@pytest.mark.parametrize('seed', range(8))
def test_random_faults_give_exact_counts_and_only_true_samples(seed):
    data, intact, dropped, corrupt = random_stream(seed, 3000)
    decoder, tracker = FrameDecoder(), SequenceTracker()
    rng = random.Random(seed + 100)
    received = []
    position = 0
    while position < len(data):
        size = rng.randint(1, 300)
        for item in decoder.feed(data[position:position + size]):
            if isinstance(item, Sample):
                received.append(item)
                tracker.update(item.sequence)
        position += size
    assert received == intact
    assert decoder.corrupt_frames == corrupt
    # drops between the first and the last received frame are visible as gaps
    first, last = intact[0].sequence, intact[-1].sequence
    assert tracker.dropped_frames == last - first + 1 - len(intact)
    assert last == 2999
    assert dropped == tracker.dropped_frames + first


def test_random_garbage_never_yields_a_frame_and_resynchronises():
    rng = random.Random(7)
    garbage = bytes(rng.randrange(256) for _ in range(200_000))
    good = [Sample(i, i, (i,) * 6) for i in range(10)]
    decoder = FrameDecoder()
    items = decoder.feed(garbage + b''.join(protocol.encode_sample(s) for s in good))
    samples = [item for item in items if isinstance(item, Sample)]
    # the last frames after the garbage are always found; garbage alone passes the
    # 3-byte signature, header and CRC-16 checks with probability ~ 3e-14 per byte
    assert samples == good
    assert decoder.discarded_bytes >= len(garbage) - protocol.SAMPLE_FRAME_SIZE


def test_sequence_tracker_wraps_counts_gaps_and_restarts_only_when_told():
    # changed with the stream rules (docs/serial_driver.md): a backwards sequence number
    # is no longer taken as a device restart (it is a late, duplicate or stale frame);
    # restarts come from evidence the caller has (START acknowledged, first-scan flag)
    tracker = SequenceTracker()
    assert tracker.update(0xFFFFFFFE) == (0xFFFFFFFE, 0, True)
    assert tracker.update(0xFFFFFFFF) == (0xFFFFFFFF, 0, False)
    assert tracker.update(0) == (0x100000000, 0, False)        # wrap, no gap
    assert tracker.update(5) == (0x100000005, 4, False)        # 1..4 lost
    assert tracker.dropped_frames == 4
    assert tracker.update(3) == (0x100000003, 0, False)        # backwards: not a restart
    assert (tracker.stale_frames, tracker.sequence_resets) == (1, 0)
    tracker.restart()                                           # evidence of a restart
    assert tracker.update(100) == (0x100000006, 0, True)       # new session: nothing counted
    assert tracker.sequence_resets == 1
    tracker.start_session()
    assert tracker.update(100) == (0x100000007, 0, True)
    assert tracker.dropped_frames == 4
    tracker.start_session(from_zero=True)                       # START acknowledged
    assert tracker.update(2) == (0x100000007 + 3, 2, True)     # scans 0 and 1 were lost
    assert tracker.dropped_frames == 6
    assert tracker.sessions == 4


def test_sequence_tracker_first_session_keeps_device_numbers():
    tracker = SequenceTracker()
    tracker.start_session(from_zero=True)
    assert tracker.update(3) == (3, 3, True)
    assert tracker.update(4) == (4, 0, False)


def test_assembler_never_spans_a_gap_and_never_invents():
    assembler = StreamAssembler(batch_size=4)
    sequences = [0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 14, 15]
    for sequence in sequences:
        assembler.add_sample(Sample(sequence, 500 * sequence, (sequence,) * 6))
    assembler.add_corrupt()
    assembler.add_sample(Sample(17, 500 * 17, (17,) * 6))
    assembler.flush()
    batches = assembler.take_batches()
    rows = [(b.first_sequence, len(b.values)) for b in batches]
    assert rows == [(0, 4), (4, 2), (9, 4), (13, 3), (17, 1)]
    for batch in batches:
        expected = np.arange(batch.first_sequence, batch.first_sequence + len(batch.values))
        assert np.array_equal(batch.values[:, 0] * 1024, expected)
        assert batch.device_time_us == 500 * batch.first_sequence
    assert assembler.dropped_frames == 3 + 1
    assert assembler.corrupt_frames == 1
    assert assembler.samples == len(sequences) + 1


def test_assembler_counts_device_overruns_modulo_16_bits():
    # changed with the stream rules: the first frame of a session is counted once a
    # second frame confirms it (a lone frame never anchors a session)
    assembler = StreamAssembler(batch_size=20)
    assembler.add_sample(Sample(0, 0, (0,) * 6, overruns=65530))
    assembler.add_sample(Sample(10, 0, (0,) * 6, overruns=3))   # 9 more, wrapped
    assert assembler.device_overruns == 65530 + 9
    assembler.start_session()
    assembler.add_sample(Sample(0, 0, (0,) * 6, overruns=2))
    assert assembler.device_overruns == 65530 + 9               # not confirmed yet
    assembler.add_sample(Sample(1, 0, (0,) * 6, overruns=2))
    assert assembler.device_overruns == 65530 + 9 + 2


def test_assembler_rejects_bad_batch_size():
    with pytest.raises(ValueError, match='batch_size'):
        StreamAssembler(0)


@pytest.mark.parametrize('line', [
    b'T1:0.1,T2:0.2,T3:0.3,T4:0.4,T5:0.5',                  # five fields
    b'T1:0.1,T2:0.2,T3:0.3,T4:0.4,T5:0.5,T6:0.6,T7:0.7',    # seven fields
    b'T1:0.1,T3:0.2,T2:0.3,T4:0.4,T5:0.5,T6:0.6',           # keys out of order
    b'T1:0.1,T2:0.2,T3:0.3,X4:0.4,T5:0.5,T6:0.6',           # wrong key
    b'T1:0.1,T2:0.2,T3:nan,T4:0.4,T5:0.5,T6:0.6',           # NaN
    b'T1:0.1,T2:0.2,T3:inf,T4:0.4,T5:0.5,T6:0.6',           # infinity
    b'T1:0.1,T2:0.2,T3:1.5,T4:0.4,T5:0.5,T6:0.6',           # out of range
    b'T1:0.1,T2:0.2,T3:,T4:0.4,T5:0.5,T6:0.6',              # empty value
    b'T1:0.1,T2:0.2,T3:0.3T4:0.4,T5:0.5,T6:0.6',            # missing comma
    b'',                                                    # empty line
])
def test_ascii_malformed_lines_are_corrupt_not_replaced(line):
    good = protocol.format_ascii_line([0.25, -0.5, 0.125, 1.0, -1.0, 0.0])
    decoder = AsciiLineDecoder()
    items = decoder.feed(good + line + b'\n' + good)
    assert items == [AsciiSample((0.25, -0.5, 0.125, 1.0, -1.0, 0.0)), protocol.CORRUPT_LINE,
                     AsciiSample((0.25, -0.5, 0.125, 1.0, -1.0, 0.0))]
    assert decoder.corrupt_lines == 1
    assert decoder.lines == 2


def test_ascii_first_partial_line_after_connect_is_dropped_silently():
    decoder = AsciiLineDecoder()
    line = protocol.format_ascii_line([0.5] * 6)
    items = decoder.feed(line[7:] + line + b'\r\n'.join([line[:-1]] * 2) + b'\n')
    assert items == [AsciiSample((0.5,) * 6)] * 3
    assert decoder.corrupt_lines == 0
    assert decoder.discarded_bytes == len(line) - 7


def test_ascii_overlong_line_is_corrupt_and_bounded():
    decoder = AsciiLineDecoder(max_line_bytes=100)
    line = protocol.format_ascii_line([0.5] * 6)
    items = decoder.feed(line)
    items += decoder.feed(b'x' * 1000)
    items += decoder.feed(b'yyy\n' + line)
    assert items == [AsciiSample((0.5,) * 6), protocol.CORRUPT_LINE, AsciiSample((0.5,) * 6)]
    assert decoder.corrupt_lines == 1


def test_ascii_format_round_trips_exactly():
    values = (0.0009765625, -0.123456789, 1.0, -1.0, 0.0, 1 / 3)
    assert AsciiLineDecoder.parse_line(protocol.format_ascii_line(values)[:-1]) == values


def ascii_stream(seed: int) -> bytes:
    """Valid, malformed and overlong lines; some overlong lines end in a valid line."""
    rng = random.Random(seed)
    good = [protocol.format_ascii_line([rng.uniform(-1, 1) for _ in range(6)])
            for _ in range(5)]
    parts = [good[0][9:]]  # starts mid-line, as after connecting
    for _ in range(60):
        kind = rng.randrange(5)
        if kind == 0:
            parts.append(rng.choice(good))
        elif kind == 1:
            parts.append(b'T1:0.1,T2:zz,T3:0.3\n')
        elif kind == 2:  # overlong, its valid tail must not be taken
            parts.append(b'x' * rng.randint(120, 500) + rng.choice(good))
        elif kind == 3:
            parts.append(rng.choice(good)[:-1] + b'\r\n')
        else:
            parts.append(b'y' * rng.randint(250, 262) + b'\n')  # around the limit
    return b''.join(parts)


def decode_split(data: bytes, cuts: list[int]) -> tuple[list, tuple[int, int, int]]:
    decoder = AsciiLineDecoder(max_line_bytes=256)
    items, previous = [], 0
    for cut in sorted(cuts) + [len(data)]:
        items += decoder.feed(data[previous:cut])
        previous = cut
    return items, (decoder.lines, decoder.corrupt_lines, decoder.discarded_bytes)


@pytest.mark.parametrize('seed', range(4))
def test_ascii_result_does_not_depend_on_where_reads_split_the_stream(seed):
    data = ascii_stream(seed)
    whole, counters = decode_split(data, [])
    assert counters[1] > 10 and counters[0] > 10
    rng = random.Random(seed)
    for _ in range(200):
        cuts = [rng.randrange(len(data)) for _ in range(rng.randint(1, 40))]
        assert decode_split(data, cuts) == (whole, counters)
    assert decode_split(data, list(range(len(data)))) == (whole, counters)  # byte by byte


def test_ascii_overlong_line_with_a_valid_tail_is_discarded_whole():
    line = protocol.format_ascii_line([0.5] * 6)
    data = line + b'x' * 300 + line + line
    for cut in (len(line) + 150, len(line) + 255, len(line) + 257, len(line) + 300):
        for cuts in ([], [cut]):
            items, counters = decode_split(data, cuts)
            assert items == [AsciiSample((0.5,) * 6), protocol.CORRUPT_LINE,
                             AsciiSample((0.5,) * 6)]
            assert counters == (2, 1, 300 + len(line))
