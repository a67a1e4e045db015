"""Sensor faults of a freshly assembled gripper, injected into a stream of scans (no rclpy).

What commissioning (issue 24) must find on a real FORTE gripper, as the bench twin and the
simulated commissioning session play it:

===================  ==============================================================  =========
kind                 physical cause and its effect on the readings                    channels
===================  ==============================================================  =========
``swapped_pair``     two tubes (or two ADC wires) exchanged: the two columns swap     2
``swapped_fingers``  the left and right finger's tube bundles exchanged: columns      none
                     0-2 and 3-5 swap
``reversed``         the transducer's two ports swapped: the differential pressure    1
                     changes sign, ``y = 2 rest - x`` (the electrical zero offset
                     ``rest`` stays where it was)
``dead``             no transducer signal (unpowered, cable off): a constant code      1
                     ``level`` (default 0), no noise, no response
``noisy``            extra white noise of ``noise_lsb`` LSB rms (1 LSB = 1 count =    1
                     1/1024 of full scale; default 4, i.e. more than the 3 LSB rms
                     the issue calls noisy)
``leaking``          the sealed channel pair leaks: its pressure equalises with       1
                     ambient through the leak, a first-order high-pass of the
                     channel's pressure with time constant ``tau`` [s] (default 5)
===================  ==============================================================  =========

``rest`` is the channel's reading at the start of the stream (the gripper open, no
pressure): the transducer's zero offset, which a pressure change does not move. Faults
apply in the order given, to normalised readings of shape ``(n, 6)``, and the result is
quantised again to the 11-bit grid. Every operation is pointwise, a column exchange, a
first-order IIR with carried state or noise drawn in fixed blocks by sample index, so any
chunking of the stream gives the same output (tested).

A fault is written ``kind:channel[,channel]`` with optional ``:parameter=value`` parts,
e.g. ``reversed:left_middle``, ``swapped_pair:left_distal,right_root``,
``swapped_fingers``, ``noisy:right_root:noise_lsb=5``, ``leaking:left_root:tau=8``;
:func:`parse_fault` reads it (the bench twin node's ``sensor_fault`` parameter).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from forte_ros.contract import CHANNEL_NAMES, FINGER_CHANNELS, N_CHANNELS, QUANTUM, SAMPLE_RATE
from forte_sim.model import quantise

__all__ = ['FAULT_KINDS', 'ChannelFault', 'ChannelFaultInjector', 'parse_fault',
           'parse_faults']

#: Every fault kind, and the number of channels each one names.
FAULT_KINDS = {'swapped_pair': 2, 'swapped_fingers': 0, 'reversed': 1, 'dead': 1,
               'noisy': 1, 'leaking': 1}
#: Default extra noise of a ``noisy`` channel [LSB rms].
DEFAULT_NOISE_LSB = 4.0
#: Default leak time constant of a ``leaking`` channel [s].
DEFAULT_LEAK_TAU = 5.0
#: Samples per block of injected noise (any chunking draws the same numbers).
NOISE_BLOCK = 2048
_NOISE_STREAM = 0xFA017


@dataclass(frozen=True)
class ChannelFault:
    """One injected sensor fault.

    Attributes
    ----------
    kind : str
        One of :data:`FAULT_KINDS`.
    channels : tuple of int
        Channel indices in contract order (two for ``swapped_pair``, none for
        ``swapped_fingers``, one otherwise).
    noise_lsb : float
        ``noisy``: extra white noise [LSB rms] (> 0).
    tau : float
        ``leaking``: time constant of the pressure's equalisation with ambient [s] (> 0).
    level : float
        ``dead``: the constant reading [normalised].
    """

    kind: str
    channels: tuple[int, ...] = ()
    noise_lsb: float = DEFAULT_NOISE_LSB
    tau: float = DEFAULT_LEAK_TAU
    level: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise ValueError(f'unknown fault kind {self.kind!r}; expected one of '
                             f'{tuple(FAULT_KINDS)}')
        channels = tuple(int(channel) for channel in self.channels)
        object.__setattr__(self, 'channels', channels)
        if len(channels) != FAULT_KINDS[self.kind]:
            raise ValueError(f'{self.kind} names {FAULT_KINDS[self.kind]} channel(s), '
                             f'got {len(channels)}')
        if any(not 0 <= channel < N_CHANNELS for channel in channels):
            raise ValueError(f'channel index out of 0..{N_CHANNELS - 1}: {channels}')
        if len(set(channels)) != len(channels):
            raise ValueError(f'{self.kind} needs two different channels, got {channels}')
        for label, value in (('noise_lsb', self.noise_lsb), ('tau', self.tau)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'{label} must be finite and > 0, got {value}')
        if not (math.isfinite(self.level) and abs(self.level) <= 1.0):
            raise ValueError(f'level must be within -1..1, got {self.level}')

    @property
    def label(self) -> str:
        """The fault in the text form :func:`parse_fault` reads."""
        text = self.kind
        if self.channels:
            text += ':' + ','.join(CHANNEL_NAMES[channel] for channel in self.channels)
        if self.kind == 'noisy':
            text += f':noise_lsb={self.noise_lsb:g}'
        elif self.kind == 'leaking':
            text += f':tau={self.tau:g}'
        elif self.kind == 'dead' and self.level:
            text += f':level={self.level:g}'
        return text


def _channel_index(name: str) -> int:
    if name not in CHANNEL_NAMES:
        raise ValueError(f'unknown channel {name!r}; expected one of {CHANNEL_NAMES}')
    return CHANNEL_NAMES.index(name)


def parse_fault(text: str) -> ChannelFault:
    """Read a fault written ``kind[:channel[,channel]][:parameter=value...]``.

    Parameters
    ----------
    text : str
        E.g. ``'reversed:left_middle'``, ``'swapped_pair:left_distal,left_root'``,
        ``'swapped_fingers'``, ``'noisy:right_root:noise_lsb=5'``,
        ``'leaking:left_root:tau=8'``, ``'dead:right_middle:level=0'``.

    Returns
    -------
    ChannelFault

    Raises
    ------
    ValueError
        Unknown kind, channel or parameter, wrong number of channels, bad value.
    """
    parts = [part.strip() for part in text.strip().split(':')]
    kind, channels, values = parts[0], [], {}
    for part in parts[1:]:
        if '=' in part:
            key, _, value = part.partition('=')
            if key.strip() not in ('noise_lsb', 'tau', 'level'):
                raise ValueError(f'unknown fault parameter {key!r} in {text!r}')
            try:
                values[key.strip()] = float(value)
            except ValueError:
                raise ValueError(f'{key} must be a number in {text!r}') from None
        elif part:
            channels += [_channel_index(name.strip()) for name in part.split(',')]
    return ChannelFault(kind, tuple(channels), **values)


def parse_faults(text: str) -> tuple[ChannelFault, ...]:
    """Faults separated by ``;`` (an empty text: none), e.g. ``'dead:left_root;noisy:...'``."""
    return tuple(parse_fault(part) for part in text.split(';') if part.strip())


class ChannelFaultInjector:
    """Applies faults to consecutive chunks of a scan stream, carrying state between them.

    Parameters
    ----------
    faults : sequence of ChannelFault
        Applied in this order to every chunk.
    seed : int
        Seed of the injected noise.
    """

    def __init__(self, faults: Sequence[ChannelFault], seed: int = 0) -> None:
        self.faults = tuple(faults)
        self._seed = int(seed)
        self._rest: np.ndarray | None = None       # readings at the first sample
        self._next_sample = 0
        self._leak_state: dict[int, np.ndarray] = {}

    def apply(self, frames: np.ndarray) -> np.ndarray:
        """The next chunk of the stream with the faults applied.

        Parameters
        ----------
        frames : numpy.ndarray, shape (n, 6)
            Normalised readings (quantised), the samples following the previous chunk.

        Returns
        -------
        numpy.ndarray, shape (n, 6)
            Faulty readings, quantised to the 11-bit grid; ``frames`` itself is unchanged.
        """
        frames = np.asarray(frames, dtype=np.float64)
        if not self.faults or len(frames) == 0:
            return frames.copy()
        if self._rest is None:
            self._rest = frames[0].copy()
        out = frames.copy()
        first = self._next_sample
        for index, fault in enumerate(self.faults):
            out = self._apply_one(index, fault, out, first)
        self._next_sample += len(frames)
        return quantise(out)

    def _apply_one(self, index: int, fault: ChannelFault, out: np.ndarray,
                   first: int) -> np.ndarray:
        kind = fault.kind
        if kind == 'swapped_pair':
            first_channel, second_channel = fault.channels
            out[:, [first_channel, second_channel]] = out[:, [second_channel, first_channel]]
        elif kind == 'swapped_fingers':
            left, right = (list(group) for group in FINGER_CHANNELS)
            out[:, left + right] = out[:, right + left]
        elif kind == 'reversed':
            channel = fault.channels[0]
            out[:, channel] = 2.0 * self._rest[channel] - out[:, channel]
        elif kind == 'dead':
            out[:, fault.channels[0]] = fault.level
        elif kind == 'noisy':
            out[:, fault.channels[0]] += self._noise(index, first, len(out)) * (
                fault.noise_lsb * QUANTUM)
        else:
            out[:, fault.channels[0]] = self._leak(index, fault, out[:, fault.channels[0]])
        return out

    def _leak(self, index: int, fault: ChannelFault, column: np.ndarray) -> np.ndarray:
        """High-pass of the channel's pressure (reading minus its rest level), rest added
        back: ``y = rest + p - z`` with ``z`` the first-order low-pass of the pressure ``p``
        (the pressure that has leaked out; ``tau dz/dt = p - z`` discretised exactly)."""
        channel = fault.channels[0]
        pressure = column - self._rest[channel]
        pole = math.exp(-1.0 / (fault.tau * SAMPLE_RATE))
        state = self._leak_state.get(index, np.zeros(1))
        leaked, self._leak_state[index] = lfilter([1.0 - pole], [1.0, -pole], pressure,
                                                  zi=state)
        return self._rest[channel] + pressure - leaked

    def _noise(self, index: int, first: int, count: int) -> np.ndarray:
        """Unit white noise of samples [first, first + count), drawn in fixed blocks."""
        parts, position, stop = [], first, first + count
        while position < stop:
            block = position // NOISE_BLOCK
            rng = np.random.default_rng((self._seed, _NOISE_STREAM, index, block))
            values = rng.standard_normal(NOISE_BLOCK)
            low = position - block * NOISE_BLOCK
            high = min(stop - block * NOISE_BLOCK, NOISE_BLOCK)
            parts.append(values[low:high])
            position = block * NOISE_BLOCK + high
        return np.concatenate(parts)
