"""Sequential slip detection on the fast band power (issue 26, a candidate mode).

Derivation
----------
**Why.** The paper's detector (and the robust mode) decide on the 200 ms Hann-windowed PSD:
new vibration enters that window where the Hann weight is near zero, so a slip becomes
visible only when it has filled a quarter of the window, 40-50 ms after its onset, and a
rule on 15 monotone rises adds 30 ms more. The slipping state
(:mod:`forte_perception.slip.state`) already computes a fast estimate of the same band
power: a second-order 10-50 Hz band-pass, squared, averaged (here over ``window``, 30 ms)
in dB over each channel's own quiet level (the *excess* ``z``). A change of its mean from
0 to ``D`` dB is what a slip does.

**Statistic.** Page's CUSUM per finger on the mean excess of its usable channels,
``S_f = max(0, S_f + (zbar_f - k) dt)``, alarm at ``S_f > h``
(:class:`forte_perception.slip.cusum.BandPowerCusum`, whose derivation holds unchanged:
only its input is the fast power instead of the PSD maximum). A finger alarms alone, so
stick-slip under the leading finger is heard whatever the trailing finger does. Nor does a
finger need all three channels (issue 38): its input is the larger of the mean excess and the
largest channel's excess less ``single_offset`` (4 dB, :func:`~forte_perception.slip.excess.
pooled_excess`), so a slip that one input carries alone (a contact over one leg, a tube
crossed to the other finger's input, a recording wired to one input) is not diluted to a
third.

**Weak slips** (issue 38). A 3-10 LSB stick-slip raises the fast excess by 9-14 dB, just over
the drift, so the first alarm waits ``h / (D - k)``, and a slip under 8 dB is never heard.
Beside the CUSUM runs the weak-slip test (:data:`WEAK_DRIFT` 6 dB, :data:`WEAK_THRESHOLD`
0.05 dB s; :class:`~forte_perception.slip.cusum.CusumParams`, "Two drifts": it hears only
what varies within the 30 ms window, so a ramp's or a sway's leak is not summed), on fingers with
all three channels usable and whose loudest channel has a fast band amplitude ``sqrt(2 P)``
of at least ``weak_least`` (1 LSB: below it a median-filtered channel near a code step
flickers by one code, which moves its excess 7-10 dB); its alarms meet the same vetoes.
Chosen on the tune part of the slip set (docs/perception.md): a lower drift or threshold
(5 dB / 0.15, 4 dB / 0.4 on the whole power; 6 dB / 0.03 on the varying part) made false
alarms on sub-LSB quiet holds or 0.5-5 Hz sways. Both tests also read the
finger's coherent excess less :data:`COHERENT_OFFSET` (2 dB; the CUSUM's "Coherent sum").

**What else raises the fast power, and the vetoes** (asked at every alarm; a vetoed alarm
restarts ``S``):

1. *Level shifts* (closing steps, ramps, 0.5-5 Hz sway): a second-order band-pass has a
   gentle skirt, so a shift of many LSB leaks into it. Stick-slip moves the level little
   against its vibration (the static shear step per release is about 1/30 of the ringing).
   With ``A = sqrt(2 P)`` the amplitude of a sine of band power ``P`` (linear, per
   channel), the alarm is vetoed when on every finger the range (largest minus smallest)
   of the running mean of ``shift_length`` samples over the last ``shift_length + 1``
   positions exceeds ``veto_ratio`` times the largest ``2 A``. The range sees a sway's
   swing at any phase; the difference of two adjacent span means is near zero where a
   0.5-5 Hz sway turns, and let it alarm there.

   *A finger that rings is exempt* (issue 38). Stick-slip's contact shear is a sawtooth (it
   builds while stuck and drops at each release, by 1/30 to 2 times the ringing;
   docs/slip_families.md), so a slip shifts the level too, and the ratio alone took those
   drops for grip changes. What a level shift cannot do is ring: through the band-pass a
   step is one lobe (the second-order 10-50 Hz band-pass is damped at 0.9 of critical), a
   ramp a constant, a 0.5-5 Hz sway at most one sign change in a tenth of a second, while a
   release rings the finger's bending mode (10-48 Hz, damping 0.07-0.12) for several cycles.
   So the band-passed signal of each channel over the last ``fs / band[0]`` samples (one
   period of the band's lowest frequency, 0.1 s) is read at every alarm the level shift
   would veto: a channel *rings* when its fast excess is at or above the drift and the
   signal alternates ``ring_crossings`` (2) times between above ``ring_fraction`` (0.5) of
   its peak magnitude and below minus that (up, down, up: one whole period of an
   oscillation), with a median spacing of the alternations between half a period of the
   band's upper edge and half a period of its lower edge (``fs / (2 band[1])`` to
   ``fs / (2 band[0])``, 20 to 100 samples: the finger's modes lie in the band, while a
   62-150 Hz motor hum leaking into the band alternates faster, even where its amplitude
   modulation leaves cycles under the threshold, and a 0.5-5 Hz sway's skirt slower).
   Three more conditions keep what is not a finger's mode out: the peak magnitude is at
   least ``ring_least`` (1 LSB; one code step through the band-pass is a lobe of 0.71 LSB,
   so code flicker under sub-LSB noise alternates below it); the channel's fast power in
   the slip band is above its power in ``high_band`` (a ringing mode at 38 Hz already puts
   5.2 dB less into the high band than into the slip band, lower modes less still; a motor
   hum does the opposite); and it is the loudest channel of its finger in the slip band (a
   release rings the whole finger, most clearly where the mode's gain is largest; a quieter
   channel alternating while the loudest does not is noise near the code step). A finger
   with a ringing channel does not vote for the level-shift veto.

   *A decaying ring counts too* (issue 38). A fraction of the window's peak misses the
   heavily damped low modes: a mode of damping ratio ``z`` keeps ``exp(-pi z / sqrt(1 -
   z^2))`` per half period (0.37 at 0.30, the families' top), and the release's static drop
   adds to its first lobe, so the third lobe falls under half the peak. Beside the
   alternations, :func:`decaying_alternations` reads the lobes from the window's largest
   on, each next one counting while it is at least ``ring_decay`` (0.3) of the one before;
   lobes are taken with a hysteresis of ``RING_FLOOR_NOISE`` (3) times the channel's quiet
   band amplitude, at least ``RING_FLOOR_LSB`` (0.5 LSB), so noise does not split or make
   one. A step stays one lobe and a ramp two equal ones: neither alternates twice. The same
   spacing, peak and candidate conditions apply. Why (tune part, 20-sample chunks): 24 of
   the 53 slips flagged after 80 ms had alarmed within 60 ms and were vetoed, 20 of them on
   11-24 Hz modes. The first alarm falls inside the release's first lobe, when no reading
   of the waveform can tell it from a step, so the ring shows at the earliest one period of
   the mode later (42-91 ms at 11-24 Hz).
2. *Out-of-band vibration switching on* (motor hum at 62-150 Hz, only 4-6 dB down in the
   slip band's skirt at its lowest frequencies): the same fast estimate in ``high_band``
   (60-250 Hz) gains more power than the slip band. Per finger, the power gained (linear,
   summed over its usable channels) over each band's quiet level is compared; the alarm is
   vetoed when on every finger the high band gained at least ``hum_ratio_db`` relative to
   the slip band. Both levels are learnt at the same updates, the CUSUM's quiet ones
   (``S = 0``; ``companion`` of :meth:`~forte_perception.slip.cusum.BandPowerCusum.update`).
   Learnt at every update, the high band's level absorbed a hum within seconds while the
   slip band's, which a loud hum keeps over the drift, did not; when the hum switched off
   (50 ms edges), the high band fell under its raised level while the slip band still held
   10-15 dB of the hum, and the ratio let an alarm through (the false runs of the slip
   set's tune part and of a fresh part, each at a hum's end). A hum too weak in the slip
   band to keep ``S`` from 0 is absorbed by both. With second-order band-passes a hum at
   62 Hz gains +1.7 dB more in the high band (70 Hz: +5.4 dB), a stick-slip ringing at
   38 Hz -5.2 dB less (14 Hz: less still): the default -2 dB lies between.

Missing data and silence: as for the state and the CUSUM (a finger with no usable channel
holds its statistic; silence sits at the quantisation floor, never an alarm).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import sosfilt_zi

from forte_perception.slip.cusum import BandPowerCusum, CusumParams
from forte_perception.slip.params import SlipParams
from forte_perception.slip.ring import (
    alternations_of,
    band_passed,
    decaying_alternations_of,
    loudest_of_finger,
)
from forte_perception.slip.state import (
    FINGER_INDEX,
    BandPower,
    SlippingParams,
    SlippingState,
    SlippingUpdate,
    finger_means,
    quantisation_floor,
)
from forte_ros.contract import FINGER_CHANNELS, N_CHANNELS, QUANTUM

__all__ = ['SequentialDetector', 'SequentialParams']


@dataclass(frozen=True)
class SequentialParams:
    """Parameters of the sequential detector (derivation in the module docstring).

    Attributes
    ----------
    cusum : CusumParams
        Drift k [dB], threshold h [dB s] and single-channel offset [dB] of the CUSUM on the
        fast excess (8, 0.05, 4).
    window : float
        Averaging window of the fast band power the CUSUM reads [s] (0.03; the slipping
        state averages over its own window).
    veto_ratio : float
        Level-shift veto: shift against the vibration's peak-to-peak amplitude (0.1).
    shift_length : int
        Running mean length and span of the level shift [samples] (200).
    high_band : tuple of float
        The out-of-band reference [Hz] (60, 250).
    hum_ratio_db : float
        Hum veto: the high band's power gain against the slip band's [dB] (-2).
    servo_hold : float
        Servo veto: alarms within this long after a servo command change are vetoed [s]
        (0.1; :mod:`forte_perception.slip.servo_gate`).
    ring_crossings : int
        Alternations of a channel's band-passed signal between +-``ring_fraction`` of its
        peak within one period of the band's lowest frequency that make it ring and exempt
        its finger from the level-shift veto (2; 0: no exemption; 1 is refused: the spacing
        of the alternations needs two).
    ring_fraction : float
        The alternations' threshold, a fraction of the window's peak magnitude (0.5).
    ring_least : float
        Least peak magnitude of a ringing channel's band-passed signal [LSB] (1.0).
    weak_least : float
        The weak-slip test hears a finger only while its loudest channel's fast band
        amplitude ``sqrt(2 P)`` is at least this [LSB] (1.0; module docstring).
    ring_decay : float
        The decaying-ring reading beside the alternations: from the window's largest lobe
        on, each next lobe of opposite sign at least this fraction of the one before counts
        (0.3: a mode of damping ratio 0.30 keeps 0.37 per half period; 0: off;
        :func:`decaying_alternations`).
    """

    cusum: CusumParams = field(default_factory=lambda: _cusum_of(SlipParams()))
    window: float = 0.03
    veto_ratio: float = 0.1
    shift_length: int = 200
    high_band: tuple[float, float] = (60.0, 250.0)
    hum_ratio_db: float = -2.0
    servo_hold: float = 0.1
    ring_crossings: int = 2
    ring_fraction: float = 0.5
    ring_least: float = 1.0
    weak_least: float = 1.0
    ring_decay: float = 0.3

    @classmethod
    def from_slip(cls, slip: SlipParams) -> SequentialParams:
        """The defaults with the CUSUM's drift, threshold and single-channel offset of
        ``slip`` (its ``sequential_*`` fields: the perception node's parameters)."""
        return cls(cusum=_cusum_of(slip))

    def validate(self, fs: float) -> None:
        """Raise ValueError with a reason if a value is unusable at ``fs``."""
        self.cusum.validate()
        if not (math.isfinite(self.veto_ratio) and self.veto_ratio >= 0):
            raise ValueError(f'veto_ratio must be >= 0, got {self.veto_ratio}')
        if int(self.shift_length) != self.shift_length or self.shift_length < 1:
            raise ValueError(f'shift_length must be an integer >= 1, got {self.shift_length}')
        low, high = self.high_band
        if not 0 < low < high < fs / 2:
            raise ValueError(f'high_band {self.high_band} Hz must lie inside (0, {fs / 2})')
        if not math.isfinite(self.hum_ratio_db):
            raise ValueError(f'hum_ratio_db must be finite, got {self.hum_ratio_db}')
        if not (math.isfinite(self.servo_hold) and self.servo_hold >= 0):
            raise ValueError(f'servo_hold must be >= 0 s, got {self.servo_hold}')
        if int(self.ring_crossings) != self.ring_crossings or self.ring_crossings == 1 \
                or self.ring_crossings < 0:  # a spacing needs two alternations
            raise ValueError(f'ring_crossings must be 0 (no exemption) or an integer >= 2, '
                             f'got {self.ring_crossings}')
        if not 0 < self.ring_fraction < 1:
            raise ValueError(f'ring_fraction must lie in (0, 1), got {self.ring_fraction}')
        if not (math.isfinite(self.ring_least) and self.ring_least >= 0):
            raise ValueError(f'ring_least must be >= 0 LSB, got {self.ring_least}')
        if not (math.isfinite(self.weak_least) and self.weak_least >= 0):
            raise ValueError(f'weak_least must be >= 0 LSB, got {self.weak_least}')
        if not 0 <= self.ring_decay < 1:
            raise ValueError(f'ring_decay must lie in [0, 1), got {self.ring_decay}')


#: The weak-slip test beside the CUSUM: its drift [dB] and threshold [dB s] (module docstring).
WEAK_DRIFT, WEAK_THRESHOLD = 6.0, 0.05
#: A finger's input is at least its coherent excess less this [dB] (module docstring).
COHERENT_OFFSET = 2.0
#: Hysteresis of the decaying-ring reading: at least this [LSB] and this many times the
#: channel's quiet band amplitude (rms), so noise alone makes no lobe (module docstring).
RING_FLOOR_LSB, RING_FLOOR_NOISE = 0.5, 3.0


def _cusum_of(slip: SlipParams) -> CusumParams:
    """The CUSUM of the sequential mode: drift, threshold and single-channel offset from
    ``slip``'s ``sequential_*`` fields (their one source of defaults), clearing after 0.05 s,
    with the weak-slip test (:data:`WEAK_DRIFT`, :data:`WEAK_THRESHOLD`) where the drift lies
    above the weak test's (a drift at or under it is already the weaker test)."""
    weak = WEAK_THRESHOLD if slip.sequential_drift > WEAK_DRIFT else math.inf
    return CusumParams(drift=slip.sequential_drift, threshold=slip.sequential_threshold,
                       clear_time=0.05, single_offset=slip.sequential_single_offset,
                       weak_drift=WEAK_DRIFT, weak_threshold=weak,
                       coherent_offset=COHERENT_OFFSET)


class SequentialDetector:
    """Streaming sequential detector with its slipping state.

    Parameters
    ----------
    fs : float
        [Hz]
    hop : int
        Samples between updates.
    band : tuple of float
        The slip band [Hz] (10, 50).
    params : SequentialParams, optional
    state : SlippingParams, optional
        The slipping state's parameters. One band-pass of the slip band gives both the
        state's power (its ``window``) and the CUSUM's (the ``window`` of ``params``).
    """

    def __init__(self, fs: float, hop: int, band: tuple[float, float] = (10.0, 50.0),
                 params: SequentialParams | None = None,
                 state: SlippingParams | None = None) -> None:
        self.params = params or SequentialParams()
        self.params.validate(fs)
        self.fs, self.hop = float(fs), int(hop)
        dt = self.hop / self.fs
        self.state = SlippingState(fs, band, dt, state)
        fast = int(round(self.params.window * fs))
        order = self.state.params.order
        # one band-pass of the slip band for the CUSUM's fast window and the state's window
        self._low = BandPower(fs, band, order, (fast, self.state.window), self.state.floor,
                              moments=fast)
        self._high = BandPower(fs, self.params.high_band, order, (fast,), quantisation_floor(
            self.state.params.floor_factor, self.params.high_band, fs))
        self._cusum = BandPowerCusum(dt, self.params.cusum)
        self._ring_window = int(round(fs / band[0]))  # one period of the band's lowest
        # median spacing of the alternations: half a period of the upper to the lower edge
        self._ring_spacing = (fs / (2.0 * band[1]), fs / (2.0 * band[0]))
        self._ring_rest = sosfilt_zi(self._low.sos)
        least = 0.5 * (self.params.weak_least * QUANTUM) ** 2  # [power] of sqrt(2 P) = least
        self._weak_least_db = 10.0 * math.log10(least) if least > 0 else -math.inf
        if self._ring_window > 2 * int(self.params.shift_length):
            raise ValueError(f'one period of {band[0]} Hz ({self._ring_window} samples) must '
                             f'fit the level-shift spans (2 x {self.params.shift_length})')
        self.reset()

    def reset(self) -> None:
        """Forget everything."""
        self.state.reset()
        self._low.reset()
        self._high.reset()
        self._cusum.reset()
        self._samples = 0
        self._history = np.zeros((0, N_CHANNELS))  # the last 2 shift_length samples
        # servo gate across chunks: (last update gated, its fast power, the power before
        # the current gated run)
        self._gate_memory = (False, np.full(N_CHANNELS, np.nan), np.full(N_CHANNELS, np.nan))
        self.vetoed = 0

    def update(self, filtered: np.ndarray, usable: np.ndarray | None = None,
               ends: np.ndarray | None = None, gated: np.ndarray | None = None,
               servo: tuple[np.ndarray, np.ndarray] | None = None
               ) -> tuple[np.ndarray, np.ndarray, SlippingUpdate]:
        """Consume filtered samples (n, 6); updates at every ``hop``-th sample, or at the
        sample indices ``ends`` (since the reset, inside this chunk) when given (the PSD
        detector's updates, in the pipeline); ``usable`` (m, 6): channels without an invalid
        value in reach; ``gated`` (m,): updates within ``servo_hold`` after a servo command
        change (:class:`~forte_perception.slip.servo_gate.ServoGate`), whose alarms are
        vetoed; ``servo`` ((m,) int, (m,) bool): the sample (since the reset) where the
        latest gated interval begun by each update ends (-1: none) and whether its motion
        had a known duration (:meth:`~forte_perception.slip.servo_gate.ServoGate.latest`).
        After a known motion's interval the level-shift veto's spans do not look into it.
        When a finger's fast excess was at or above the drift at the update before the
        interval began, the slip made the servo move: neither the gate nor the level-shift
        veto (whose spans hold the servo's step) drops its alarms.

        Returns
        -------
        sample_index : ndarray (m,)
            Last sample of each update (since the reset).
        slip : ndarray (m,), bool
            Slip events (alarms that no veto dropped).
        state : SlippingUpdate
            The slipping state at each update.
        """
        x = np.asarray(filtered, np.float64).reshape(-1, N_CHANNELS)
        first = self._samples
        if ends is None:
            ends = np.arange(first + (-first - 1) % self.hop, first + x.shape[0], self.hop)
        ends = np.asarray(ends, np.int64)
        low, power = self._low.feed(x, ends)
        high = self._high.feed(x, ends)[0]
        if usable is not None:
            low = np.where(usable, low, np.nan)
        ext = np.concatenate([self._history, x])
        origin = first - self._history.shape[0]  # absolute index of ext[0]

        before = self._before_gates(low, gated)

        def veto(i: int) -> bool:  # the CUSUM's own level is the one in effect at update i
            levels = (self._cusum.level, self._cusum.companion_level)
            stop, known = (-1, False) if servo is None else (int(servo[0][i]), servo[1][i])
            if stop >= 0 and self._slip_before_servo(before[i]):
                # the slip made the servo move: neither its gate nor its step is a veto
                return self._veto(ext, origin, (int(ends[i]), stop), low[i], high[i], levels)
            if gated is not None and gated[i]:
                return True
            stop = stop if known else -1  # an unknown motion may still move the level
            return self._veto(ext, origin, (int(ends[i]), stop), low[i], high[i], levels)

        result = self._cusum.update(low, veto, self._audible(low), lambda: self._low.moments,
                                    companion=high)
        self.vetoed += result.vetoed
        state = self.state.decide(power, result.slip, usable)
        self._samples += x.shape[0]
        self._history = ext[-2 * int(self.params.shift_length):]
        return ends, result.slip, state

    def _audible(self, low: np.ndarray) -> np.ndarray:
        """Fingers (m, 2) whose loudest channel's fast band amplitude ``sqrt(2 P)`` (``low``
        (m, 6) [dB]; NaN: unusable) reaches ``weak_least``: where the weak-slip test listens."""
        return np.fmax.reduce(low[:, FINGER_INDEX], axis=2) >= self._weak_least_db

    def _before_gates(self, low: np.ndarray, gated: np.ndarray | None) -> np.ndarray:
        """Per update (m, 6) [dB]: the fast power ``low`` at the update before the latest
        gated run began (the band as it was before the servo last moved); NaN before the
        first run."""
        out = np.empty(low.shape)
        was_gated, last, before = self._gate_memory
        if gated is None or not np.any(gated):  # the common case: no servo change near
            out[:] = before
            if low.shape[0]:
                self._gate_memory = (False, low[-1], before)
            return out
        for i, gate in enumerate(np.asarray(gated, bool).tolist()):
            if gate and not was_gated:
                before = last
            out[i] = before
            was_gated, last = gate, low[i]
        self._gate_memory = (was_gated, last, before)
        return out

    def _slip_before_servo(self, before: np.ndarray) -> bool:
        """True if a finger's fast excess (mean over its channels with a level, of
        ``before`` (6,) [dB] minus the CUSUM's levels) was at or above the drift: evidence
        the servo cannot have caused."""
        excess = finger_means((before - self._cusum.level)[None, :])[0]
        return bool((excess >= self.params.cusum.drift).any())  # NaN: no say

    def _rings(self, span: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """Channels (6,) bool that ring in the slip band (module docstring): fast power
        ``low`` (6,) [dB] at least the drift over the CUSUM's level and above the high band's
        ``high`` (6,) [dB], and the band-passed ``span`` (the last samples (n, 6), filtered
        from their first value at rest) alternating ``ring_crossings`` times within the ring
        window, as fast as a component inside the band, with a peak of ``ring_least``, and
        the loudest of its finger in ``low``."""
        if self.params.ring_crossings == 0:
            return np.zeros(N_CHANNELS, bool)
        candidates = (((low - self._cusum.level) >= self.params.cusum.drift) & (low > high)
                      & loudest_of_finger(low))
        if not candidates.any():  # NaN: not a candidate
            return candidates
        start = span.shape[0] - self._ring_window - self._ring_window // 2  # half to settle
        y = band_passed(self._low.sos, span[max(start, 0):], self._ring_window,
                        self._ring_rest)
        rings = candidates & self._ringing(*alternations_of(y, self.params.ring_fraction))
        unfound = candidates & ~rings
        if self.params.ring_decay > 0 and unfound.any():
            quiet = np.sqrt(10.0 ** (self._cusum.level / 10.0))  # quiet band amplitude (rms)
            floor = np.maximum(RING_FLOOR_LSB * QUANTUM, RING_FLOOR_NOISE * quiet)
            rings |= unfound & self._ringing(*decaying_alternations_of(
                y, np.nan_to_num(floor, nan=np.inf), self.params.ring_decay, unfound))
        return rings

    def _ringing(self, count: np.ndarray, spacing: np.ndarray, peak: np.ndarray
                 ) -> np.ndarray:
        """Channels (6,) whose ``count`` alternations, median ``spacing`` [samples] and
        ``peak`` make a ring: ``ring_crossings`` of them, as fast as a component inside the
        band, with a peak of ``ring_least``."""
        return ((count >= self.params.ring_crossings)
                & (spacing >= self._ring_spacing[0]) & (spacing <= self._ring_spacing[1])
                & (peak >= self.params.ring_least * QUANTUM))

    def _veto(self, ext: np.ndarray, origin: int, samples: tuple[int, int], low: np.ndarray,
              high: np.ndarray, levels: tuple[np.ndarray, np.ndarray]) -> bool:
        """The level-shift and hum vetoes of an alarm whose fast powers are ``low`` and
        ``high`` (6,) [dB]; ``samples``: the alarm's last sample and the end of the latest
        servo gate begun by then (-1: none); ``levels``: the bands' quiet levels [dB]."""
        length = int(self.params.shift_length)
        end, servo_stop = samples
        stop = end - origin + 1
        if stop < 2 * length:
            return True  # too early to tell a slip from the start-up: no alarm
        fingers = [list(c) for c in FINGER_CHANNELS]
        if servo_stop < 0 or servo_stop - origin <= stop - 2 * length:  # no servo step in them
            span = ext[stop - 2 * length:stop]
            total = np.concatenate([np.zeros((1, N_CHANNELS)), np.cumsum(span, axis=0)])
            running = (total[length:] - total[:-length]) / length  # (length + 1, 6)
            shift = running.max(axis=0) - running.min(axis=0)
            amplitude = 2.0 * np.sqrt(2.0 * 10.0 ** (low / 10.0))
            amplitude = np.where(np.isnan(amplitude), -np.inf, amplitude)  # unusable: no say
            ratio = self.params.veto_ratio
            if all(shift[c].max() > ratio * amplitude[c].max() for c in fingers):
                if not self._rings(span, low, high).any():  # a ringing finger does not vote
                    return True
        gain_low = 10.0 ** (low / 10.0) - 10.0 ** (levels[0] / 10.0)
        gain_high = 10.0 ** (high / 10.0) - 10.0 ** (levels[1] / 10.0)
        hum = 10.0 ** (self.params.hum_ratio_db / 10.0)
        verdicts = []
        for c in fingers:
            known = np.isfinite(gain_low[c]) & np.isfinite(gain_high[c])
            if known.any():
                verdicts.append(gain_high[c][known].sum() >= hum * gain_low[c][known].sum())
        return bool(verdicts) and all(verdicts)
