"""The slipping *state* beside the slip *event*: raised at detection, held while it slides.

Derivation
----------
**Why a state.** Every detector mode fires on a *rise* of the 10-50 Hz band power (the
paper's moving variance of a monotone rise, the CUSUM's accumulated excess): it marks the
change into slip. An object that keeps sliding after the controller's first tightening keeps
the band power high but no longer rising, so the event is not repeated; a controller that
is told only about changes is never told that its tightening did not stop the slide. The
state answers the question the controller needs: *is it still sliding now?*

**What is measured.** Sliding excites the fingers' bending modes (14-38 Hz) for as long as
it lasts: the band power stays above the channel's quiet level (about 20 dB on a real
recording of an object sliding across a fingertip for 0.57 s). The detector's PSD window
(N = 400 samples, 200 ms, Hann) is too slow to say when a slide has *ended*: a vibration
that stopped ``tau`` seconds ago still fills the oldest ``0.2 - tau`` s of the window, whose
Hann weight is ``int_0^(1 - tau/0.2) sin^4(pi u) du / (3/8)``, -3 dB at tau = 100 ms.
A 20 dB slide would therefore be reported for about 170 ms after it stopped. The state uses
its own, shorter estimate: per channel the filtered signal through a Butterworth band-pass
(``order``, the detector's ``f_min``..``f_max``), squared, averaged over the last
``window`` seconds (50 ms: 2.5 periods at 50 Hz, half a period at 10 Hz). In dB, with a quantisation
floor added before the logarithm (uniform quantisation noise of variance q^2/12 has the
fraction ``2 (f_max - f_min) / fs`` of its power in the band; ``floor_factor`` times that),
so silence, a railed channel and sub-LSB noise give a finite level, never -inf.

**Quiet level.** Per channel ``L_c``: the median of the band power over the updates of a
block (``level_block`` s, fixed absolute update indices) at which the channel's finger was
not slipping and no event was flagged, moving ``L_c`` by ``1 - exp(-level_block /
level_tau)`` towards it; the first such block sets it. A channel without a level, or not
usable at an update (a masked window), is left out of its finger's mean.

**The state, per finger** (``e_f`` = mean over the finger's usable channels of
``P_c - L_c``, its *excess* [dB]):

- *raised* at an update whose slip event the detector flagged, for every finger with
  ``e_f >= margin``: the event says "slip began", the excess says where. A finger below
  the margin at the event is not raised: it is not vibrating (a false event on a quiet
  hold raises nothing when the power did not rise);
- *held* while ``e_f >= margin``;
- *cleared* once ``e_f < margin`` has held for ``clear_time`` seconds (hysteresis against
  the dips of a stick-slip train between releases), or once its ringing decays freely (see
  below). A finger with no usable channel keeps its state (unknown is not "stopped").

**Free decay.** A slide is a train of releases, each ringing the finger's lightly damped
bending mode (damping 0.07-0.12). When the train stops, the ringing decays at ``2 zeta
omega``: 53 dB/s at 14 Hz, damping 0.07, so 20-30 dB of excess need 0.4-0.6 s to fall to
the margin, while the slide ended with its last release. What the margin cannot tell, the
time course can: a *release* is a rise of ``e_f`` by ``release_rise`` (3 dB) over its
lowest value since the previous release; the finger is cleared when none has come for
``decay_time`` (0.15 s: longer than the 0.12 s gap of a 10 Hz train) and ``e_f`` lies
``decay_drop`` (10 dB) below its largest value of the last ``decay_time + window`` (the
window delays the excess). A release that damps the ringing instead of feeding it looks
like a decay; the next release then lifts ``e_f`` again, and a finger cleared by the decay
rule is raised again by a release within ``decay_time + window`` of its clear.

The state can only be raised by an event, so on quiet holds and distractors it is raised at
most as often as the detector has false events. A slide that outlasts a tightening keeps it
raised; the controller tightens again while it persists (forte_control).

Exactness: the band-pass keeps its state across calls and runs sample by sample, and each
update's power is a reduction of its own window, so any chunking gives the batch result bit
for bit.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import butter, sosfilt, sosfilt_zi

from forte_ros.contract import FINGER_CHANNELS, N_CHANNELS, QUANTUM

#: Each finger's channels, (2, 3): one gather groups a (k, 6) array by finger.
FINGER_INDEX = np.array(FINGER_CHANNELS)
#: The finger of each channel, (6,).
CHANNEL_FINGER = np.argsort(FINGER_INDEX.ravel()) // FINGER_INDEX.shape[1]
#: The three channel pairs of each finger, (01, 02, 12) of the left then the right finger:
#: the columns of :attr:`BandPower.moments`' cross products, (6,) each.
PAIR_FIRST = FINGER_INDEX[:, [0, 0, 1]].ravel()
PAIR_SECOND = FINGER_INDEX[:, [1, 2, 2]].ravel()
#: Updates since the last release before the first one (longer than any decay time).
_NO_RELEASE = 1 << 30

__all__ = ['FINGER_INDEX', 'BandPower', 'QuietLevels', 'SlippingParams', 'SlippingState',
           'SlippingUpdate', 'finger_means', 'quantisation_floor', 'update_quiet_levels']


@dataclass(frozen=True)
class SlippingParams:
    """Parameters of the slipping state (derivation in the module docstring).

    Attributes
    ----------
    window : float
        Band-power averaging window [s] (0.05).
    order : int
        Butterworth band-pass order (1: a second-order band-pass, which rings least).
    margin : float
        A finger is slipping while its mean excess over the quiet level is at least this
        [dB] (4).
    clear_time : float
        ... and is cleared once the excess has stayed below ``margin`` this long [s] (0.05).
    release_rise : float
        A rise of a finger's excess by this much over its lowest value since the previous
        such rise marks a release (fresh vibration) [dB] (3).
    decay_time : float
        A slipping finger is also cleared when no release has come for this long and its
        excess has fallen ``decay_drop`` below its largest value of the last ``decay_time +
        window``: the ringing decays freely, nothing excites it any more [s] (0.15; 0 turns
        this off).
    decay_drop : float
        See ``decay_time`` [dB] (10).
    level_block : float
        Quiet levels are updated once per block of this length [s] (0.2).
    level_tau : float
        Time constant of the quiet level [s] (5).
    floor_factor : float
        Band-power floor in units of the in-band quantisation noise power (4).
    """

    window: float = 0.05
    order: int = 1
    margin: float = 4.0
    clear_time: float = 0.05
    release_rise: float = 3.0
    decay_time: float = 0.15
    decay_drop: float = 10.0
    level_block: float = 0.2
    level_tau: float = 5.0
    floor_factor: float = 4.0

    def validate(self, fs: float, band: tuple[float, float]) -> None:
        """Raise ValueError with a reason if a value is unusable at ``fs`` for ``band``."""
        for name in ('window', 'level_block', 'level_tau', 'floor_factor'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f'slipping {name} must be positive and finite, got {value}')
        if round(self.window * fs) < 2:
            raise ValueError(f'slipping window {self.window} s is under 2 samples at {fs} Hz')
        if int(self.order) != self.order or not 1 <= self.order <= 8:
            raise ValueError(f'slipping order must be an integer in 1..8, got {self.order}')
        if not math.isfinite(self.margin):
            raise ValueError(f'slipping margin must be finite, got {self.margin}')
        for name in ('clear_time', 'release_rise', 'decay_time', 'decay_drop'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f'slipping {name} must be >= 0 and finite, got {value}')
        low, high = band
        if not 0 < low < high < fs / 2:
            raise ValueError(f'band {band} Hz must lie inside (0, {fs / 2}) Hz')


@dataclass
class SlippingUpdate:
    """The state at m detector updates.

    Attributes
    ----------
    slipping : ndarray (m, 2), bool
        Per finger (left, right) after each update.
    excess : ndarray (m, 2)
        Mean excess of the finger's usable channels over their quiet levels [dB]; NaN when
        the finger has none.
    power_db : ndarray (m, 6)
        Short-window band power per channel [dB re 1 normalised unit^2].
    level : ndarray (m, 6)
        The quiet level in effect at each update [dB]; NaN before the channel's first.
    """

    slipping: np.ndarray
    excess: np.ndarray
    power_db: np.ndarray
    level: np.ndarray


class BandPower:
    """Streaming short-window band power of the 6 channels, for one or more windows.

    The filtered signal through a Butterworth band-pass (``order``), squared, averaged over
    the last ``window`` samples of each window (fewer at the start), plus ``floor``, in dB.
    One band-pass serves every window.

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    band : tuple of float
        Band [Hz].
    order : int
        Butterworth order.
    windows : tuple of int
        Averaging windows [samples], each >= 2.
    floor : float
        Power added before the logarithm [normalised unit^2].
    moments : int, optional
        Also keep, at every update, the mean of each channel's band-passed signal and of the
        products of the channel pairs of each finger (:data:`PAIR_FIRST`,
        :data:`PAIR_SECOND`) over the last ``moments`` samples (:attr:`moments`).
    """

    def __init__(self, fs: float, band: tuple[float, float], order: int,
                 windows: tuple[int, ...], floor: float, moments: int | None = None) -> None:
        self._sos = butter(int(order), band, btype='bandpass', fs=fs, output='sos')
        self._windows = tuple(int(w) for w in windows)
        self._floor = float(floor)
        self._moment_window = None if moments is None else int(moments)
        self.reset()

    @property
    def sos(self) -> np.ndarray:
        """The band-pass's second-order sections (``scipy.signal.butter`` ``output='sos'``)."""
        return self._sos

    def reset(self) -> None:
        """Forget the filter state and the squares kept."""
        self._zi: np.ndarray | None = None
        self._squares = np.zeros((0, N_CHANNELS))  # the last max(windows) - 1 squared outputs
        self._outputs = np.zeros((0, N_CHANNELS))  # the last moments - 1 band-passed outputs
        self._samples = 0
        self._pending: tuple[np.ndarray, np.ndarray] | None = None  # outputs, update rows
        self._moments: tuple[np.ndarray, np.ndarray] | None = None

    def feed(self, filtered: np.ndarray, ends: np.ndarray) -> list[np.ndarray]:
        """Band-pass the new samples (n, 6); the power (m, 6) [dB] of each window at the
        sample indices ``ends`` (m,) (absolute, counted from the last reset, inside this
        chunk), one array per window."""
        x = np.asarray(filtered, np.float64).reshape(-1, N_CHANNELS)
        if not np.isfinite(x).all():
            raise ValueError('slipping state input must be finite')
        if self._zi is None and x.shape[0]:
            self._zi = sosfilt_zi(self._sos)[:, :, None] * x[0][None, None, :]
        first = self._samples
        if x.shape[0]:
            y, self._zi = sosfilt(self._sos, x, axis=0, zi=self._zi)
        else:
            y = x
        ext = np.concatenate([self._squares, y * y])
        self._samples += x.shape[0]
        keep = max(self._windows) - 1
        self._squares = ext[-keep:]
        rel = np.asarray(ends, int) - (first - (ext.shape[0] - x.shape[0]))
        if self._moment_window is not None:
            outputs = np.concatenate([self._outputs, y])
            self._outputs = outputs[max(outputs.shape[0] - self._moment_window + 1, 0):]
            self._pending = (outputs, np.asarray(ends, int)
                             - (first - (outputs.shape[0] - x.shape[0])))
            self._moments = None
        return self._window_powers(ext, rel)

    @property
    def moments(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The window means of each channel's band-passed signal and of the products of the
        finger pairs (:data:`PAIR_FIRST`, :data:`PAIR_SECOND`) at the updates of the last
        :meth:`feed`, (m, 6) each [normalised unit, unit^2]; None without ``moments``.
        Computed when first asked for (the detector asks only where it may use them)."""
        if self._moments is None and self._pending is not None:
            outputs, rows = self._pending
            columns = np.concatenate(
                [outputs, outputs[:, PAIR_FIRST] * outputs[:, PAIR_SECOND]], axis=1)
            means = window_means(columns, rows, self._moment_window)
            self._moments = (means[:, :N_CHANNELS], means[:, N_CHANNELS:])
        return self._moments

    def _window_powers(self, ext: np.ndarray, rel: np.ndarray) -> list[np.ndarray]:
        """The power [dB] (m, 6) of each window ending at the rows ``rel`` (m,) of ``ext``.

        Each window is summed as its own contiguous run of samples, so any chunking gives the
        batch result bit for bit. Where the longest window is full, one gather of it serves
        every window (a shorter window is the tail of each gathered run: the same sums)."""
        longest = max(self._windows)
        full = rel >= longest - 1
        block = None
        if full.any():
            view = sliding_window_view(ext, longest, axis=0)  # (k, 6, longest)
            block = np.ascontiguousarray(view[rel[full] - longest + 1])
        out = []
        for window in self._windows:
            power = np.empty((rel.size, N_CHANNELS))
            if block is not None:
                power[full] = block[:, :, longest - window:].sum(axis=2) / window
            for i in np.flatnonzero(~full):  # the first longest - 1 samples after a reset
                length = min(window, rel[i] + 1)
                run = np.ascontiguousarray(ext[rel[i] + 1 - length:rel[i] + 1].T)
                power[i] = run.sum(axis=1) / length
            out.append(10.0 * np.log10(power + self._floor))
        return out


def window_means(values: np.ndarray, rows: np.ndarray, window: int) -> np.ndarray:
    """Column means of the last ``window`` rows of ``values`` (k, c) up to each of ``rows``
    (m,) (fewer at the start), (m, c); each a reduction of its own contiguous run, so any
    chunking gives the same means bit for bit."""
    def gathered(ends: np.ndarray) -> np.ndarray:  # (k, window, c), summed row after row
        return values[ends[:, None] + np.arange(1 - window, 1)].sum(axis=1) / window

    full = rows >= window - 1
    if full.all():  # the common case
        return gathered(rows)
    out = np.empty((rows.size, values.shape[1]))
    out[full] = gathered(rows[full])
    for i in np.flatnonzero(~full):  # the first window - 1 samples after a reset
        # the same (1, rows, c) reduction as the gather's, over the rows there are
        out[i] = values[None, :rows[i] + 1].sum(axis=1)[0] / (rows[i] + 1)
    return out


class QuietLevels:
    """Each channel's quiet level [dB]: the median of its quiet values over a block of
    ``block`` updates (fixed absolute update indices), approached by ``beta`` per block.

    Parameters
    ----------
    block : int
        Updates per block.
    beta : float
        Fraction of the way to a block's median the level moves.
    """

    def __init__(self, block: int, beta: float) -> None:
        self.block, self.beta = int(block), float(beta)
        self.reset()

    def reset(self) -> None:
        """Forget the levels."""
        self.updates = 0
        self.level = np.full(N_CHANNELS, np.nan)
        self._values: list[np.ndarray] = []

    def segment_stop(self, pos: int, m: int) -> int:
        """End (exclusive) of the segment of m updates from ``pos`` with one level."""
        block_end = (self.updates // self.block + 1) * self.block
        return min(m, pos + block_end - self.updates)

    def record(self, quiet_values: np.ndarray) -> bool:
        """The values (k, 6) of a segment [dB] (NaN: not quiet); closes a full block (then
        True: the levels are new)."""
        self._values.append(quiet_values)
        self.updates += quiet_values.shape[0]
        if self.updates % self.block:
            return False
        update_quiet_levels(self.level, np.concatenate(self._values), self.beta)
        self._values = []
        return True

    def track(self, power_db: np.ndarray) -> np.ndarray:
        """Record m updates whose finite values are all quiet; the level in effect at each
        (m, 6) [dB]."""
        p = np.asarray(power_db, np.float64).reshape(-1, N_CHANNELS)
        levels = np.empty_like(p)
        pos = 0
        while pos < p.shape[0]:
            stop = self.segment_stop(pos, p.shape[0])
            levels[pos:stop] = self.level
            self.record(np.where(np.isfinite(p[pos:stop]), p[pos:stop], np.nan))
            pos = stop
        return levels


class SlippingState:
    """Streaming slipping state: feed filtered samples, then decide at the detector updates.

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    band : tuple of float
        Band [Hz] (the detector's ``f_min``, ``f_max``).
    update_interval : float
        Time between detector updates [s] (``hop / fs``); sets the block and clear counts.
    params : SlippingParams, optional
    """

    def __init__(self, fs: float, band: tuple[float, float], update_interval: float,
                 params: SlippingParams | None = None) -> None:
        self.params = params or SlippingParams()
        self.params.validate(fs, band)
        self.fs = float(fs)
        self.window = int(round(self.params.window * fs))
        self.floor = quantisation_floor(self.params.floor_factor, band, fs)
        self._power = BandPower(fs, band, self.params.order, (self.window,), self.floor)
        self._clear = int(math.ceil(self.params.clear_time / update_interval - 1e-9))
        self._decay = int(math.ceil(self.params.decay_time / update_interval - 1e-9))
        self._decay_span = self._decay + int(math.ceil(self.params.window / update_interval
                                                       - 1e-9))
        self.levels = QuietLevels(max(1, int(round(self.params.level_block / update_interval))),
                                  1.0 - math.exp(-self.params.level_block
                                                 / self.params.level_tau))
        self.reset()

    def reset(self) -> None:
        """Forget everything (filter, levels, state)."""
        self._power.reset()
        self.levels.reset()
        self._slipping = np.zeros(2, bool)
        self._below = np.zeros(2, int)
        self._updates = 0
        # per finger: the update of its last clear by free decay, updates since the last
        # release, the lowest excess since it, and the candidates for the largest excess of
        # the decay span: (update, excess), decreasing
        self._cleared = [-_NO_RELEASE, -_NO_RELEASE]
        self._ringing = [False, False]
        self._since = [_NO_RELEASE, _NO_RELEASE]
        self._lowest = [math.inf, math.inf]
        self._peaks: tuple[deque, deque] = (deque(), deque())

    @property
    def level(self) -> np.ndarray:
        """Quiet level per channel [dB]; NaN before its first block."""
        return self.levels.level.copy()

    @property
    def slipping(self) -> np.ndarray:
        """Current state per finger, (2,) bool."""
        return self._slipping.copy()

    def feed(self, filtered: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Band-pass the new samples; the band power at the sample indices ``ends``.

        Parameters
        ----------
        filtered : ndarray (n, 6)
            The next filtered samples (finite; a pipeline substitutes invalid values).
        ends : ndarray (m,)
            Absolute sample indices (counted from the last reset) inside this chunk.

        Returns
        -------
        ndarray (m, 6)
            Mean square band-passed value over the ``window`` samples up to each end (fewer
            at the start), plus the floor, in dB.
        """
        return self._power.feed(filtered, ends)[0]

    def decide(self, power_db: np.ndarray, events: np.ndarray,
               usable: np.ndarray | None = None) -> SlippingUpdate:
        """The state after each of m consecutive updates.

        Parameters
        ----------
        power_db : ndarray (m, 6)
            From :meth:`feed` at the updates' last samples [dB] (or the same estimate
            computed elsewhere, :class:`BandPower`).
        events : ndarray (m,), bool
            The detector's slip event at each update.
        usable : ndarray (m, 6), bool, optional
            Channels whose window holds no invalid value (default all).
        """
        p = np.asarray(power_db, np.float64).reshape(-1, N_CHANNELS)
        m = p.shape[0]
        ok = np.isfinite(p) if usable is None else (np.asarray(usable, bool) & np.isfinite(p))
        events = np.asarray(events, bool).reshape(-1)
        out = SlippingUpdate(np.zeros((m, 2), bool), np.full((m, 2), np.nan), p,
                             np.empty((m, N_CHANNELS)))
        pos = 0
        while pos < m:  # segments of constant quiet levels, up to a block's end
            stop = self.levels.segment_stop(pos, m)
            seg = slice(pos, stop)
            out.level[seg] = self.levels.level
            out.excess[seg] = self._excess(p[seg], ok[seg])
            out.slipping[seg], ringing = self._run(out.excess[seg], events[seg])
            busy = np.repeat(out.slipping[seg] | ringing, 3, axis=1)
            quiet = ~busy & ok[seg] & ~events[seg, None]
            self.levels.record(np.where(quiet, p[seg], np.nan))
            pos = stop
        return out

    def _excess(self, power: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """Mean excess of each finger's usable channels with a level, (k, 2); NaN if none."""
        return finger_means(np.where(ok, power - self.levels.level, np.nan))

    def _run(self, excess: np.ndarray, events: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The hysteresis over k updates (Python floats: a few microseconds an update): the
        state (k, 2), and the updates of a finger cleared by free decay whose excess is still
        at least the margin (k, 2), which are no quiet updates."""
        margin, need = self.params.margin, max(self._clear, 1)
        slipping, below, ringing = self._slipping.tolist(), self._below.tolist(), self._ringing
        states = np.empty(excess.shape, bool)
        tails = np.empty(excess.shape, bool)
        first = self._updates
        for i, (row, event) in enumerate(zip(excess.tolist(), events.tolist())):
            for f in (0, 1):
                value = row[f]
                if value != value:  # NaN, no usable channel: unknown keeps the state
                    continue
                decayed, released = self._free_decay(f, first + i, value)
                # a release soon after a clear by free decay: the slide goes on
                again = released and first + i - self._cleared[f] <= self._decay_span
                if value >= margin and (event or again or (slipping[f] and not decayed)):
                    slipping[f], below[f], ringing[f] = True, 0, False
                elif slipping[f]:
                    below[f] += 1
                    if below[f] >= need or decayed:
                        slipping[f], below[f], ringing[f] = False, 0, decayed
                        if decayed:
                            self._cleared[f] = first + i
                ringing[f] = ringing[f] and value >= margin
            states[i] = slipping
            tails[i] = ringing
        self._updates = first + excess.shape[0]
        self._slipping = np.array(slipping, bool)
        self._below = np.array(below, int)
        return states, tails

    def _free_decay(self, finger: int, update: int, value: float) -> tuple[bool, bool]:
        """Track the releases and the decay span's largest excess of ``finger`` at
        ``update`` (its excess ``value`` [dB]): (its ringing decays freely: no release for
        ``decay_time`` and ``decay_drop`` below the span's largest excess; a release now)."""
        p = self.params
        if value >= self._lowest[finger] + p.release_rise:
            self._since[finger], self._lowest[finger] = 0, value
        else:
            self._since[finger] += 1
            self._lowest[finger] = min(self._lowest[finger], value)
        peaks = self._peaks[finger]
        while peaks and peaks[-1][1] <= value:
            peaks.pop()
        peaks.append((update, value))
        while peaks[0][0] <= update - self._decay_span:
            peaks.popleft()
        since = self._since[finger]
        return 0 < self._decay <= since and peaks[0][1] - value >= p.decay_drop, since == 0


def finger_means(values: np.ndarray) -> np.ndarray:
    """Per finger, the mean of its channels' finite values: (k, 6) -> (k, 2); NaN where a
    finger has none (NaN or inf: unusable, or no quiet level yet)."""
    grouped = values[:, FINGER_INDEX]  # (k, 2, 3)
    known = np.isfinite(grouped)
    if known.all():  # the common case: the same sum and division without the masking
        return grouped.sum(axis=2) / grouped.shape[2]
    count = known.sum(axis=2)
    total = np.where(known, grouped, 0.0).sum(axis=2)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def quantisation_floor(factor: float, band: tuple[float, float], fs: float) -> float:
    """``factor`` times the in-band power of uniform quantisation noise (variance
    q^2 / 12, the fraction ``2 (f_max - f_min) / fs`` of it in ``band``) [unit^2]."""
    return factor * QUANTUM ** 2 / 12.0 * 2.0 * (band[1] - band[0]) / fs


def update_quiet_levels(level: np.ndarray, values: np.ndarray, beta: float) -> None:
    """Move each channel's quiet level (6,) [dB] in place by ``beta`` towards the median of
    its finite values of a block (k, 6) (NaN: not quiet or unusable); the first block with
    a value sets it; a channel without one keeps its level."""
    for c in range(level.size):
        column = values[:, c]
        column = column[np.isfinite(column)]
        if not column.size:
            continue
        median = float(np.median(column))
        if np.isnan(level[c]):
            level[c] = median
        else:
            level[c] += beta * (median - level[c])
