"""What a commissioning run recorded: readings, protocol phases, link counters (pure).

Saved as one ``.npz`` (``allow_pickle=False``):

================  =================  =====================================================
key               shape, dtype       meaning
================  =================  =====================================================
``frames``        (n, 6) float64     raw readings (normalised, not tared), contract order
``sequence``      (n,) int64         device sequence number of each row (gaps: lost rows)
``phase_names``   (p,) str           e.g. ``rest``, ``press_left_tip``, ``squeeze``
``phase_kinds``   (p,) str           ``rest``, ``press`` or ``squeeze``
``phase_fingers``  (p,) int64        pressed finger (0 left, 1 right), -1 otherwise
``phase_places``  (p,) str           ``tip`` / ``root`` for a press, empty otherwise
``phase_spans``   (p, 2) int64       ``[first, stop)`` sequence numbers of each phase
``link``          (7,) float64       :class:`LinkStatistics` fields in their order
``channel_names`` (6,) str           the contract's channel order
================  =================  =====================================================
"""
from __future__ import annotations

import math
import os
from dataclasses import astuple, dataclass, fields
from pathlib import Path

import numpy as np

from forte_ros.contract import CHANNEL_NAMES, N_CHANNELS

__all__ = ['PHASE_KINDS', 'PRESS_PLACES', 'CommissioningRecording', 'LinkStatistics',
           'Phase']

#: Kinds of protocol phase.
PHASE_KINDS = ('rest', 'press', 'squeeze')
#: Where a press goes on a finger.
PRESS_PLACES = ('tip', 'root')


@dataclass(frozen=True)
class Phase:
    """One phase of the protocol.

    Attributes
    ----------
    name : str
        Unique name, e.g. ``'press_left_tip'``.
    kind : str
        One of :data:`PHASE_KINDS`.
    start, stop : int
        ``[start, stop)`` device sequence numbers the phase covers.
    finger : int
        Pressed finger (0 = left, 1 = right) of a press; -1 otherwise.
    place : str
        ``'tip'`` or ``'root'`` for a press; ``''`` otherwise.
    """

    name: str
    kind: str
    start: int
    stop: int
    finger: int = -1
    place: str = ''

    def __post_init__(self) -> None:
        if self.kind not in PHASE_KINDS:
            raise ValueError(f'unknown phase kind {self.kind!r}; expected {PHASE_KINDS}')
        if self.stop <= self.start:
            raise ValueError(f'phase {self.name!r} is empty: [{self.start}, {self.stop})')
        if self.kind == 'press' and (self.finger not in (0, 1)
                                     or self.place not in PRESS_PLACES):
            raise ValueError(f'press phase {self.name!r} needs a finger 0/1 and a place '
                             f'in {PRESS_PLACES}')


@dataclass(frozen=True)
class LinkStatistics:
    """The sensor link over the run, from the driver's counters and the device clock.

    Attributes
    ----------
    received : int
        Rows recorded [count].
    first_sequence, last_sequence : int
        Device sequence numbers of the first and last recorded row.
    device_seconds : float
        Device time between the first and the last row [s] (device clock).
    dropped : int
        Frames the driver counted lost in transport during the run [count].
    corrupt : int
        Frames the driver rejected (CRC, parse) during the run [count].
    wall_seconds : float
        Host (wall) time over which the rows arrived [s]; NaN when unknown (offline).
    """

    received: int
    first_sequence: int
    last_sequence: int
    device_seconds: float
    dropped: int = 0
    corrupt: int = 0
    wall_seconds: float = math.nan

    @classmethod
    def from_sequence(cls, sequence: np.ndarray, sample_period: float, dropped: int = 0,
                      corrupt: int = 0, wall_seconds: float = math.nan) -> LinkStatistics:
        """Statistics of rows numbered ``sequence`` whose device time is ``sequence x
        sample_period`` (a source without its own clock, e.g. the simulator)."""
        first, last = int(sequence[0]), int(sequence[-1])
        return cls(len(sequence), first, last, (last - first) * sample_period, dropped,
                   corrupt, wall_seconds)


@dataclass
class CommissioningRecording:
    """Raw readings of one commissioning run and its protocol.

    Attributes
    ----------
    frames : numpy.ndarray, shape (n, 6)
        Raw readings, normalised, contract channel order.
    sequence : numpy.ndarray, shape (n,)
        Device sequence number of each row, increasing.
    phases : list of Phase
    link : LinkStatistics
    """

    frames: np.ndarray
    sequence: np.ndarray
    phases: list[Phase]
    link: LinkStatistics

    def __post_init__(self) -> None:
        self.frames = np.asarray(self.frames, dtype=np.float64)
        self.sequence = np.asarray(self.sequence, dtype=np.int64)
        if self.frames.ndim != 2 or self.frames.shape[1] != N_CHANNELS:
            raise ValueError(f'frames must be (n, {N_CHANNELS}), got {self.frames.shape}')
        if len(self.sequence) != len(self.frames):
            raise ValueError('one sequence number per row is needed')
        if len(self.sequence) > 1 and not np.all(np.diff(self.sequence) > 0):
            raise ValueError('sequence numbers must increase')

    def rows(self, start: int, stop: int) -> slice:
        """Row slice of the sequence numbers ``[start, stop)``."""
        return slice(int(np.searchsorted(self.sequence, start)),
                     int(np.searchsorted(self.sequence, stop)))

    def phase(self, name: str) -> Phase:
        """The phase called ``name`` (KeyError if absent)."""
        for phase in self.phases:
            if phase.name == name:
                return phase
        raise KeyError(name)

    def save(self, path: str | os.PathLike) -> Path:
        """Write the recording as ``.npz`` (temporary name, then renamed); returns the path."""
        path = Path(path)
        temporary = path.with_name(path.name + '.partial.npz')
        np.savez_compressed(
            temporary, frames=self.frames, sequence=self.sequence,
            phase_names=np.array([phase.name for phase in self.phases], dtype=str),
            phase_kinds=np.array([phase.kind for phase in self.phases], dtype=str),
            phase_fingers=np.array([phase.finger for phase in self.phases], dtype=np.int64),
            phase_places=np.array([phase.place for phase in self.phases], dtype=str),
            phase_spans=np.array([(phase.start, phase.stop) for phase in self.phases],
                                 dtype=np.int64).reshape(-1, 2),
            link=np.array(astuple(self.link), dtype=np.float64),
            channel_names=np.array(CHANNEL_NAMES, dtype=str))
        os.replace(temporary, path)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> CommissioningRecording:
        """Read a recording written by :meth:`save`."""
        with np.load(path, allow_pickle=False) as data:
            if tuple(data['channel_names']) != CHANNEL_NAMES:
                raise ValueError(f'{path}: channel order {tuple(data["channel_names"])} is '
                                 f'not the contract\'s {CHANNEL_NAMES}')
            phases = [Phase(str(name), str(kind), int(span[0]), int(span[1]), int(finger),
                            str(place))
                      for name, kind, finger, place, span in zip(
                          data['phase_names'], data['phase_kinds'], data['phase_fingers'],
                          data['phase_places'], data['phase_spans'])]
            values = data['link']
            kinds = [field.type for field in fields(LinkStatistics)]
            link = LinkStatistics(*(float(value) if kind == 'float' else int(value)
                                    for value, kind in zip(values, kinds)))
            return cls(data['frames'], data['sequence'], phases, link)
