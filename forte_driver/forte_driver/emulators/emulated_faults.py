"""Fault kinds of the emulated sensor board and their bookkeeping (pure Python).

Used by :mod:`forte_driver.emulators.emulated_sensor`: :class:`FaultPlan` (probability
per scan of each fault), :class:`FaultLog` (what was injected and its exact expected effect on the
host) and :func:`implausible_frame` (a CRC-valid frame with impossible content).
"""
from __future__ import annotations

import random
from dataclasses import dataclass, field

from forte_driver.serial import protocol
from forte_driver.serial.protocol import Sample

#: Faults understood by :meth:`EmulatedSensor.inject` and :class:`FaultPlan`.
FAULTS = ('garbage', 'random_garbage', 'truncate', 'bitflip', 'gap', 'burst',
          'duplicate', 'reorder', 'implausible', 'restart')
#: Faults that exist only in the binary protocol (ASCII lines carry no sequence or time).
BINARY_ONLY_FAULTS = ('duplicate', 'reorder', 'implausible', 'restart')
#: What an ``implausible`` frame gets wrong (its CRC is always valid): a value beyond
#: +-1024 counts, an undefined flag bit (3..7), a device time >= 2**58 us, or a fully
#: random payload (random sequence, time, values, flags).
IMPLAUSIBLE_KINDS = ('values', 'flags', 'time', 'random')


@dataclass
class FaultPlan:
    """Probability per transmitted scan of each fault (binary and ASCII modes).

    Attributes
    ----------
    garbage : float
        Binary: insert 1..40 random bytes without 0xA5, 0x5A, 0x01 before the scan (they
        can never complete a frame signature, so counts stay exact). ASCII: insert one
        line of random bytes (one corrupt line).
    random_garbage : float
        Insert 1..40 fully random bytes (may form false candidates: counts approximate).
    truncate : float
        Send only the first 1..n-2 bytes of the scan's frame (or line).
    bitflip : float
        Flip one random bit of the scan's frame (binary) / replace a key (ASCII).
    gap : float
        Do not send the scan at all.
    burst : float
        Hold the output for 20 ms, then send everything at once.
    duplicate : float
        Binary: send the scan's frame twice in a row.
    reorder : float
        Binary: send the scan's frame after the next scan's frame (adjacent swap).
    implausible : float
        Binary: replace the scan's frame by a CRC-valid frame with implausible content
        (one of :data:`IMPLAUSIBLE_KINDS`, drawn at random); the scan itself is lost.
    restart : float
        Binary: the device restarts after this scan without a host START (watchdog or
        brown-out reset): sequence back to 0, device clock back to 1 s after boot, the
        first scan flagged ``FLAG_SESSION_START``; it takes effect once the device ring
        is empty, so no scan is lost.
    """

    garbage: float = 0.0
    random_garbage: float = 0.0
    truncate: float = 0.0
    bitflip: float = 0.0
    gap: float = 0.0
    burst: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0
    implausible: float = 0.0
    restart: float = 0.0


@dataclass
class FaultLog:
    """Injected faults and their exact expected effect on the host decoder."""

    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(FAULTS, 0))
    dropped: int = 0      # scans the host can never receive (sequence gaps)
    corrupt: int = 0      # candidates/lines the host must reject (implausible included)
    exact: bool = True    # False once random_garbage made the corrupt count approximate
    implausible: int = 0  # CRC-valid frames with implausible content (also in corrupt)
    duplicate: int = 0    # frames sent a second time
    late: int = 0         # frames sent after their successor (reorder)
    restarts: int = 0     # device restarts without a host START


def implausible_frame(sample: Sample, kind: str | None, draw: random.Random) -> bytes:
    """A sample frame with a valid CRC whose content a host must reject.

    Parameters
    ----------
    sample : Sample
        The true scan the impostor replaces.
    kind : str or None
        One of :data:`IMPLAUSIBLE_KINDS`; None draws one.
    draw : random.Random
        Generator of the kind and the content.
    """
    kind = kind or draw.choice(IMPLAUSIBLE_KINDS)
    if kind == 'values':
        values = list(sample.values)
        values[draw.randrange(len(values))] = draw.choice((-1, 1)) * draw.randint(1025, 32767)
        sample = sample._replace(values=tuple(values))
    elif kind == 'flags':
        sample = sample._replace(flags=sample.flags | (1 << draw.randrange(3, 8)))
    elif kind == 'time':
        sample = sample._replace(time_us=draw.randint(1 << 58, (1 << 64) - 1))
    else:
        sample = Sample(draw.getrandbits(32), draw.getrandbits(64),
                        tuple(draw.randint(-32768, 32767) for _ in range(6)),
                        draw.getrandbits(16), draw.getrandbits(8), draw.getrandbits(8))
    return protocol.encode_sample(sample)
