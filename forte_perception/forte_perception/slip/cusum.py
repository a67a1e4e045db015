"""Slip as sequential change detection: a CUSUM on the log band power (issue 26, a candidate mode).

Derivation
----------
**Observation.** Per channel c and detector update t (every ``hop`` samples) the slip
detector already computes ``y_c(t)`` = the maximum over the 10-50 Hz bins of the Hann-windowed
PSD of the last N samples, in dB (``psd_max_db``; with the quantisation floor of the robust
mode added before the logarithm, :mod:`forte_perception.slip.robust`, so that silence and
sub-LSB noise give a finite, nearly constant value instead of -120 dB). Slip adds vibration
in the band: before the onset ``y_c`` fluctuates around the channel's own quiet level
``L_c``; after it, it lies ``D`` dB higher for as long as the object slides (D is about 20 dB
for a 3-LSB ringing over 1 LSB of noise, 40 dB and more for strong stick-slip). In dB the
fluctuation does not depend on the noise level (the log of a scaled chi-square variable has
a fixed spread, a few dB for the maximum of 9 bins), so one drift ``k`` in dB fits every
channel once its own level is subtracted: ``z_c = y_c - L_c``.

**Statistic.** For a change of the mean of independent observations from 0 to ``D`` (noise
variance ``s^2``) the log-likelihood ratio of one observation is ``(D / s^2) (z - D / 2)``.
Page's CUSUM ``S(t) = max(0, S(t-1) + llr(t))`` with an alarm when ``S > h'`` is the test
that minimises the worst-case detection delay among all tests with the same mean time
between false alarms (Lorden 1971, Moustakides 1986). Dividing the LLR by the constant
``D / s^2`` keeps the test and puts the statistic in dB: increment ``z - k`` with the
*drift* ``k = D / 2``. The three channels of a finger see the same slip; their LLRs add, and
averaging them (the same test, scaled by 1/3) gives per finger f

    ``S_f(t) = max(0, S_f(t-1) + (zbar_f(t) - k) * dt)``,   alarm when ``S_f > h``,

``zbar_f`` = mean of ``z_c`` over the finger's usable channels, ``dt = hop / fs`` [s], so
``S`` and ``h`` are in dB s and do not depend on the hop. A finger alarms alone: stick-slip
under the leading finger needs nothing from the other one (the paper's alpha gate does).

**Delay and false alarms.** For a step of size ``D > k`` in ``zbar`` (noise-free) the alarm
comes at the first update with ``(D - k) * n * dt > h``: ``n = floor(h / ((D - k) dt)) + 1``
updates after the step (:func:`expected_delay`; with noise, Wald's approximation
``h / (D - k)`` plus the overshoot). A quiet channel has ``E[z] = 0 < k``: ``S`` drifts to
0 at ``k`` dB per second and an alarm needs an excursion of the band power ``k`` dB above
the level lasting ``h / (excess - k)`` seconds. For independent observations the mean time
between false alarms grows exponentially with ``h`` while the delay grows linearly: that is
the curve of :mod:`forte_perception.evaluation.change_detection`. The updates are not
independent (windows overlap 99 %, so ``y`` is correlated over about N / hop updates), so
the exponential law holds only in shape; ``h`` and ``k`` are set from measured false alarms
on the tune part of the slip set, not from a formula. Delay is counted from when ``zbar``
rises; the window itself adds the time the slip's vibration needs to dominate the
Hann-weighted 200 ms window (a few tens of ms for a strong slip).

**Two drifts** (``weak_drift``, ``weak_threshold``; off unless set). The test is optimal for
the rise ``D = 2 k`` it is tuned to and slow for smaller ones: a rise just above ``k`` needs
``h / (D - k)``, and one under ``k`` is never found. A weak stick-slip raises the fast band
power by 9-14 dB, barely over the sequential mode's 8 dB drift. A second statistic with a
lower drift ``k2`` and a higher threshold ``h2`` (the usual bank of CUSUMs for an unknown
change size) runs on the same input; a finger alarms when either exceeds its threshold, and
the veto, the slipping state and the restart are shared (either alarm restarts both sums).
The quiet levels stay the first test's (updates with ``S_f = 0``), so with the weak test off
every output is bit for bit the single test's. The lower drift admits the larger spread of a
mean of fewer channels, so the weak test hears only fingers whose three channels are all
usable at that update; a finger with a channel lost keeps the first test.

*The weak test hears only what varies within the window* (issue 38), where the update brings
the window moments (below): its input is the same pooled excess with each channel's power
less the square of its window mean (:func:`demeaned_excess`). A ramp through the band-pass
is a constant and a 0.5-5 Hz sway nearly one over a 30 ms window: with its lower drift the
weak test summed the excess they leak (8-10 dB on a finger, at 1.2-1.6 LSB noise) into
alarms that a noise alternation let through the level-shift veto. A ring of the finger's
modes keeps most of its power (the mean of a sine over a window of length ``T`` carries
``sinc^2(f T)`` of it on average: 2.1 dB lost at 17 Hz, 0.1 dB at 38 Hz, for ``T`` = 30 ms).
The first test keeps the whole power.

**Coherent sum** (``coherent_offset``; off unless set and the update brings the window
moments). A release rings one mode that a finger's three channels see in phase, over
independent noises. The power of the sum of the channels' band-passed signals, each divided
by its quiet band amplitude, the window's mean removed (a ramp is a coherent constant), over
its quiet value 3 (:func:`coherent_excess`, the largest of the four sign patterns: a
transducer may be plumbed reversed) gains 4.8 dB over a channel for three equal channels.
Its quiet spread is one signal's, so less an offset it joins the finger's input
(:func:`pooled_excess`) where the weak test may listen (code flicker below).

**Quiet level.** ``L_c`` is measured, not a constant: per block of ``level_block`` seconds
(fixed absolute update indices), the median of ``y_c`` over the block's *quiet* updates
(the finger neither slipping nor accumulating, ``S_f = 0``) moves ``L_c`` by the fraction
``1 - exp(-level_block / level_tau)`` towards it; the first block with a finite value sets
it. Until a channel has a level it is not usable; a finger without usable channels cannot
alarm. The median keeps a few transient values in a block from moving the level.

**Slipping state.** The alarm is the slip *event*; the finger is then *slipping* while its
band power stays above its quiet level: the state is cleared when ``zbar_f < margin`` dB
has held for ``clear_time`` seconds (hysteresis: raised by accumulated evidence above
``k``, cleared by the level falling below ``margin``). Then ``S_f`` restarts at 0. A
sustained slide is thus one event and one held state, not a change into slip followed by
silence.

**Distractors.** An optional veto (a callback, e.g. the robust mode's level-shift veto,
:func:`forte_perception.slip.robust.level_shift_veto`) is asked at every alarm; a vetoed
alarm raises nothing and restarts ``S_f`` at 0, so a slip that outlasts the distractor is
found when it alarms again.

**Missing data, silence, saturation.** Nothing is invented. A NaN or inf ``y_c`` (a masked
channel) is left out of its finger's mean and of its level; a finger with no usable channel
contributes no evidence at that update (increment 0: its ``S`` is held), cannot clear or
raise its state (``zbar`` unknown), and does not move its levels. Silence and a railed
(constant) channel give ``y_c`` = the floor: below the level, so never an alarm, and the
level follows it down slowly (``level_tau``).

**Exactness.** Within a segment ``S`` is computed in closed form (Lindley): with
``C(t) = S0 + sum(x)`` (a sequential cumulative sum carried across calls) and
``M(t) = min(0, C(.) up to t)``, ``S(t) = C(t) - M(t)``; segments end at block boundaries,
alarms and clears, so the work is vectorised and feeding updates in chunks of any size gives
bit for bit the batch result.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from forte_perception.slip.excess import coherent_excess, demeaned_excess, pooled_excess
from forte_perception.slip.state import CHANNEL_FINGER, FINGER_INDEX, QuietLevels
from forte_ros.contract import FINGER_CHANNELS, N_CHANNELS

#: Segments of at most this many updates take the scalar quiet path (a 20-sample chunk: 5).
_SCALAR_UPDATES = 16

__all__ = ['BandPowerCusum', 'CusumParams', 'CusumResult', 'coherent_excess', 'demeaned_excess',
           'expected_delay', 'pooled_excess']  # a finger's input: slip.excess


@dataclass(frozen=True)
class CusumParams:
    """Parameters of the band-power CUSUM (derivation in the module docstring).

    Attributes
    ----------
    drift : float
        k: half the band-power rise the test is tuned to [dB] (6).
    threshold : float
        h: alarm when the finger statistic exceeds it [dB s] (0.05).
    margin : float
        The finger stays slipping while its mean excess over the quiet level is at least
        this [dB] (3).
    clear_time : float
        ... and is cleared once it has been below for this long [s] (0.01).
    level_block : float
        The quiet level is updated once per block of this length [s] (0.2); the first
        block is the warm-up.
    level_tau : float
        Time constant of the quiet level [s] (5).
    single_offset : float
        A finger's input is the larger of its channels' mean excess and its largest
        channel's excess less this [dB] (inf: the mean alone; :func:`pooled_excess`).
    weak_drift, weak_threshold : float
        The weak-change test beside it: a second drift, under ``drift`` [dB] (4), and its
        threshold [dB s] (inf: off); module docstring, "Two drifts".
    coherent_offset : float
        Where the update brings the window moments of the band-passed signals, a finger's
        input is also at least its coherent excess less this [dB] (inf: off;
        :func:`coherent_excess`).
    """

    drift: float = 6.0
    threshold: float = 0.05
    margin: float = 3.0
    clear_time: float = 0.01
    level_block: float = 0.2
    level_tau: float = 5.0
    single_offset: float = math.inf
    weak_drift: float = 4.0
    weak_threshold: float = math.inf
    coherent_offset: float = math.inf

    @property
    def weak(self) -> bool:
        """True when the weak-change test runs."""
        return math.isfinite(self.weak_threshold)

    def validate(self) -> None:
        """Raise ValueError with a reason if a value is unusable."""
        for name in ('drift', 'threshold', 'level_block', 'level_tau'):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f'{name} must be positive and finite, got {value}')
        if not np.isfinite(self.margin):
            raise ValueError(f'margin must be finite, got {self.margin}')
        if not (np.isfinite(self.clear_time) and self.clear_time >= 0):
            raise ValueError(f'clear_time must be >= 0, got {self.clear_time}')
        for name in ('single_offset', 'coherent_offset'):
            if not getattr(self, name) >= 0:  # NaN fails too; inf is allowed (off)
                raise ValueError(f'{name} must be >= 0 dB, got {getattr(self, name)}')
        if not (math.isfinite(self.weak_drift) and self.weak_drift > 0):
            raise ValueError(f'weak_drift must be positive and finite, got {self.weak_drift}')
        if not self.weak_threshold > 0:  # inf allowed (off), NaN refused
            raise ValueError(f'weak_threshold must be > 0 dB s (inf: off), '
                             f'got {self.weak_threshold}')
        if self.weak and not self.weak_drift < self.drift:
            raise ValueError(f'weak_drift ({self.weak_drift} dB) must lie under drift '
                             f'({self.drift} dB): it is the test for the smaller change')


def _lindley(x: np.ndarray, c0, m0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed-form CUSUM over increments ``x`` (n,) or (n, f) from the carried sum ``c0`` and
    minimum ``m0`` (scalars or (f,)): the sums C, their running minima M (with ``m0``) and
    the statistic S = C - M."""
    part = x.copy()
    part[0] += c0
    c = np.add.accumulate(part, axis=0)
    mins = np.minimum.accumulate(np.minimum(c, m0), axis=0)
    return c, mins, c - mins


def expected_delay(step_db: float, params: CusumParams, dt: float) -> float:
    """Updates from a noise-free step of ``step_db`` in the finger excess to the alarm,
    starting from ``S = 0``: the sooner of the test and the weak-change test (inf when the
    step exceeds neither drift)."""
    tests = [(params.drift, params.threshold)]
    if params.weak:
        tests.append((params.weak_drift, params.weak_threshold))
    delays = [math.floor(threshold / ((step_db - drift) * dt)) + 1
              for drift, threshold in tests if step_db > drift]
    return min(delays, default=math.inf)


@dataclass
class CusumResult:
    """Per-update output of :class:`BandPowerCusum` (m updates).

    Attributes
    ----------
    statistic : ndarray (m, 2)
        S per finger (left, right) [dB s]; NaN while the finger is slipping.
    excess : ndarray (m, 2)
        The finger's input (:func:`pooled_excess`; the mean excess of its usable channels
        over their quiet levels with the default ``single_offset``) [dB]; NaN without a
        usable channel.
    alarm : ndarray (m, 2), bool
        A finger's (not vetoed) alarm: the slip event.
    slipping : ndarray (m, 2), bool
        The finger's slipping state after the update.
    active : ndarray (m,), bool
        Some channel has a quiet level (the warm-up is over).
    vetoed : int
        Alarms the veto dropped.
    """

    statistic: np.ndarray
    excess: np.ndarray
    alarm: np.ndarray
    slipping: np.ndarray
    active: np.ndarray
    vetoed: int = 0

    @property
    def slip(self) -> np.ndarray:
        """Slip event per update: either finger alarms, (m,) bool."""
        return self.alarm.any(axis=1)

    @property
    def any_slipping(self) -> np.ndarray:
        """Slipping state per update: either finger slipping, (m,) bool."""
        return self.slipping.any(axis=1)


@dataclass
class _Finger:
    """Carried state of one finger."""

    c: float = 0.0          # C(t): sequential cumulative sum since the last restart
    m: float = 0.0          # M(t) = min(0, C up to t)
    weak: tuple[float, float] = (0.0, 0.0)  # (C, M) of the weak-change test
    slipping: bool = False
    below: int = 0          # consecutive updates below the margin while slipping
    channels: tuple[int, ...] = field(default_factory=tuple)


class BandPowerCusum:
    """Streaming CUSUM on ``psd_max_db`` updates: feed them in chunks of any size.

    Parameters
    ----------
    dt : float
        Time between updates, ``hop / fs`` [s].
    params : CusumParams, optional
    """

    def __init__(self, dt: float, params: CusumParams | None = None) -> None:
        self.params = params or CusumParams()
        self.params.validate()
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f'dt must be positive, got {dt}')
        self.dt = float(dt)
        self._block = max(1, int(round(self.params.level_block / self.dt)))
        self._clear = int(math.ceil(self.params.clear_time / self.dt - 1e-9))
        beta = 1.0 - math.exp(-self._block * self.dt / self.params.level_tau)
        self._levels = QuietLevels(self._block, beta)
        self._companion = QuietLevels(self._block, beta)
        self.reset()

    def reset(self) -> None:
        """Forget everything, levels included: the next update is update 0 again."""
        self._levels.reset()
        self._companion.reset()
        self._fingers = [_Finger(channels=tuple(c)) for c in FINGER_CHANNELS]

    @property
    def level(self) -> np.ndarray:
        """Quiet level per channel [dB]; NaN before its first block."""
        return self._levels.level.copy()

    @property
    def companion_level(self) -> np.ndarray:
        """Quiet level per channel of the ``companion`` powers [dB] (:meth:`update`), learnt
        at the updates the levels are (NaN before its first block); read from a veto, the
        level in effect at the alarm's update."""
        return self._companion.level.copy()

    def update(self, psd_db: np.ndarray, veto: Callable[[int], bool] | None = None,
               weak: np.ndarray | None = None,
               moments: Callable[[], tuple[np.ndarray, np.ndarray] | None] | None = None,
               companion: np.ndarray | None = None) -> CusumResult:
        """Consume updates ``psd_db`` (m, 6) [dB] and return their decisions.

        Parameters
        ----------
        psd_db : ndarray (m, 6)
            Band maximum per channel [dB]; NaN / inf = channel unusable at that update.
        veto : callable, optional
            ``i -> bool`` for an alarm at row ``i`` of this chunk; True drops it.
        weak : ndarray (m, 2), bool, optional
            Fingers the weak-change test and the coherent excess may hear at each update
            (default: all; the weak test never hears a finger with a channel unusable).
        moments : callable, optional
            Returns the window means of the band-passed signals and of the finger pairs'
            products behind ``psd_db``, (m, 6) each
            (:attr:`~forte_perception.slip.state.BandPower.moments`); asked only where a
            finger may hear the coherent excess, which then joins its input (with a finite
            ``coherent_offset``).
        companion : ndarray (m, 6), optional
            Powers of another band [dB] whose quiet levels (:attr:`companion_level`) are
            learnt at the same quiet updates as the levels: a ratio of the two bands' gains
            is then taken over references of the same moments.
        """
        y = np.asarray(psd_db, np.float64).reshape(-1, N_CHANNELS)
        m = y.shape[0]
        allowed = None if weak is None else np.asarray(weak, bool).reshape(m, 2)
        out = CusumResult(np.full((m, 2), np.nan), np.full((m, 2), np.nan),
                          np.zeros((m, 2), bool), np.zeros((m, 2), bool), np.zeros(m, bool))
        pos = 0
        while pos < m:  # segments of constant quiet levels, up to a block's end
            stop = self._levels.segment_stop(pos, m)
            self._segment(y, pos, stop, out, veto,
                          None if allowed is None else allowed[pos:stop], moments,
                          None if companion is None else companion[pos:stop])
            pos = stop
        return out

    # -- one stretch of updates with constant levels
    def _segment(self, y: np.ndarray, lo: int, hi: int, out: CusumResult,
                 veto: Callable[[int], bool] | None, allowed: np.ndarray | None,
                 moments: Callable[[], tuple[np.ndarray, np.ndarray] | None] | None,
                 companion: np.ndarray | None) -> None:
        seg = y[lo:hi]
        level = self._levels.level
        coherent_offset = self.params.coherent_offset
        z = seg - level  # NaN where the channel is unusable or has no level yet
        finite = np.isfinite(z)
        everywhere = bool(finite.all())  # the common case: every channel usable, with a level
        out.active[lo:hi] = True if everywhere else (finite.any(axis=1)
                                                     | np.isfinite(level).any())
        coherent = means = None
        # only where the weak test may listen (code flicker below)
        if moments is not None and (self.params.weak or coherent_offset < math.inf) \
                and (allowed is None or allowed.any()):
            means, products = (values[lo:hi] for values in moments())
            if coherent_offset < math.inf:
                coherent = coherent_excess(seg, level, means, products)
                if allowed is not None:
                    coherent = np.where(allowed, coherent, np.nan)
        # NaN: no usable channel
        excess = pooled_excess(z, self.params.single_offset, coherent, coherent_offset)
        out.excess[lo:hi] = excess
        x = (excess - self.params.drift) * self.dt  # (n, 2)
        if not everywhere:
            x = np.where(np.isnan(excess), 0.0, x)
        weak = None
        if self.params.weak:  # only fingers with every channel usable
            heard = excess if means is None else pooled_excess(
                demeaned_excess(seg, level, means), self.params.single_offset, coherent,
                coherent_offset)
            weak = (heard - self.params.weak_drift) * self.dt
            whole = None if everywhere else finite[:, FINGER_INDEX].all(axis=2)
            if allowed is not None:  # (hi - lo, 2): where the caller lets it listen
                whole = allowed if whole is None else whole & allowed
            if whole is not None:
                weak = np.where(whole, weak, 0.0)
        quiet = np.zeros(seg.shape, bool)
        if not self._quiet_run(x, weak, out.statistic[lo:hi], quiet):
            for f, finger in enumerate(self._fingers):
                s, slipping, alarm = self._run(finger, x[:, f],
                                               None if weak is None else weak[:, f],
                                               excess[:, f], lo, veto, out)
                out.statistic[lo:hi, f] = s
                out.slipping[lo:hi, f] = slipping
                out.alarm[lo:hi, f] = alarm
                quiet[:, list(finger.channels)] = (~slipping & (s == 0.0))[:, None]
        if companion is not None:
            self._companion.record(np.where(quiet & np.isfinite(companion), companion, np.nan))
        if self._levels.record(np.where(quiet & np.isfinite(seg), seg, np.nan)):  # new levels
            for finger in self._fingers:
                if not finger.slipping:  # S = C - M; re-base so that C stays small
                    finger.c, finger.m = finger.c - finger.m, 0.0
                    finger.weak = (finger.weak[0] - finger.weak[1], 0.0)

    def _quiet_run(self, x: np.ndarray, weak: np.ndarray | None, statistic: np.ndarray,
                   quiet: np.ndarray) -> bool:
        """Both fingers over one segment at once when neither is slipping nor alarms in it
        (the common case; the same sums as :meth:`_run`): fill ``statistic`` (n, 2) and
        ``quiet`` (n, 6) and return True; otherwise change nothing and return False."""
        fingers = self._fingers
        if any(finger.slipping for finger in fingers):
            return False
        if x.shape[0] <= _SCALAR_UPDATES:
            return self._quiet_scalar(x, weak, statistic, quiet)
        c, mins, stat = _lindley(x, [f.c for f in fingers], [f.m for f in fingers])
        if (stat > self.params.threshold).any():
            return False
        if weak is not None:
            weak_c, weak_mins, weak_stat = _lindley(weak, [f.weak[0] for f in fingers],
                                                    [f.weak[1] for f in fingers])
            if (weak_stat > self.params.weak_threshold).any():
                return False
            for f, finger in enumerate(fingers):
                finger.weak = (float(weak_c[-1, f]), float(weak_mins[-1, f]))
        statistic[:] = stat
        quiet[:] = (stat == 0.0)[:, CHANNEL_FINGER]
        for f, finger in enumerate(fingers):
            finger.c, finger.m = float(c[-1, f]), float(mins[-1, f])
        return True

    def _quiet_scalar(self, x: np.ndarray, weak: np.ndarray | None, statistic: np.ndarray,
                      quiet: np.ndarray) -> bool:
        """:meth:`_quiet_run` for a few updates in Python floats: the additions and minima of
        :func:`_lindley` in the same order, so the same sums bit for bit, without a dozen
        array operations on a (5, 2) array."""
        fingers = self._fingers
        tests = [(x.tolist(), self.params.threshold, [(f.c, f.m) for f in fingers])]
        if weak is not None:
            tests.append((weak.tolist(), self.params.weak_threshold, [f.weak for f in fingers]))
        results = []  # per test: S (n, 2) as lists, and the carried (C, M) per finger
        for rows, threshold, start in tests:
            stat, ends = [[0.0] * len(fingers) for _ in rows], []
            for f, (c, m) in enumerate(start):
                for t, row in enumerate(rows):
                    c += row[f]
                    m = min(m, c)
                    stat[t][f] = c - m
                    if stat[t][f] > threshold:
                        return False  # an alarm: the state machine takes the segment
                ends.append((c, m))
            results.append((stat, ends))
        first = np.array(results[0][0])
        statistic[:] = first
        quiet[:] = (first == 0.0)[:, CHANNEL_FINGER]
        for f, finger in enumerate(fingers):
            finger.c, finger.m = results[0][1][f]
            if weak is not None:
                finger.weak = results[1][1][f]
        return True

    def _run(self, finger: _Finger, x: np.ndarray, weak: np.ndarray | None, zbar: np.ndarray,
             offset: int, veto: Callable[[int], bool] | None, out: CusumResult
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The state machine of one finger over one segment: CUSUM (closed form) until an
        alarm of either test (``x``, ``weak``: the increments of the test and of the
        weak-change test, or None), slipping until cleared, again."""
        n = x.size
        s = np.full(n, np.nan)
        slipping = np.zeros(n, bool)
        alarm = np.zeros(n, bool)
        i = 0
        while i < n:
            if finger.slipping:
                j = self._clear_index(finger, zbar[i:])
                if j is None:
                    slipping[i:] = True
                    return s, slipping, alarm
                slipping[i:i + j] = True  # cleared at i + j: the statistic restarts there
                s[i + j] = 0.0
                finger.slipping, finger.c, finger.m, finger.weak = False, 0.0, 0.0, (0.0, 0.0)
                i += j + 1
                continue
            c, mins, stat = _lindley(x[i:], finger.c, finger.m)
            over = stat > self.params.threshold
            if weak is not None:
                weak_c, weak_mins, weak_stat = _lindley(weak[i:], *finger.weak)
                over |= weak_stat > self.params.weak_threshold
            over = np.flatnonzero(over)
            if not over.size:
                s[i:] = stat
                finger.c, finger.m = float(c[-1]), float(mins[-1])
                if weak is not None:
                    finger.weak = (float(weak_c[-1]), float(weak_mins[-1]))
                return s, slipping, alarm
            a = int(over[0])
            s[i:i + a + 1] = stat[:a + 1]
            finger.c, finger.m, finger.weak = 0.0, 0.0, (0.0, 0.0)  # either test restarts both
            if veto is not None and veto(offset + i + a):
                out.vetoed += 1
            else:
                alarm[i + a] = True
                slipping[i + a] = True
                s[i + a] = np.nan
                finger.slipping, finger.below = True, 0
            i += a + 1
        return s, slipping, alarm

    def _clear_index(self, finger: _Finger, zbar: np.ndarray) -> int | None:
        """Index at which the slipping finger clears (its excess below the margin for
        ``clear_time``, counting the run carried from earlier updates), or None; updates
        ``finger.below``."""
        below = zbar < self.params.margin  # NaN: not below (unknown)
        k = np.arange(below.size)
        last_not = np.maximum.accumulate(np.where(below, -1, k))
        run = np.where(last_not < 0, k + 1 + finger.below, k - last_not)
        need = max(self._clear, 1)
        hit = np.flatnonzero(run >= need)
        if hit.size:
            return int(hit[0])
        finger.below = int(run[-1]) if run.size else finger.below
        return None
