"""Signal-level slip scenes: labelled six-channel recordings generated from seeds (issue 14).

Each family stands for one situation in which the paper's slip detector was found to fail
(or must keep working), built from the physics that matters for it and nothing else.
Everything is computed in ADC steps (LSB, 1 LSB = 2/2048 of the normalised reading) and
finally rounded to the 11-bit grid and clipped to the ADC range like the sensor.

Common to every scene (``fs`` = 2000 Hz):

- a **finger profile** (:data:`PROFILES`, the "object" of the split): the contact location
  along the finger, which sets the channel pattern of pressure (distal > middle > root, the
  simulator's channel kernel), the bending mode of the finger excited by stick-slip
  releases (14-38 Hz, damping 0.07-0.12; the simulator's 30 Hz / sqrt(1 + m / 0.3 kg)
  gives 17-30 Hz for its objects), how much of a release the other finger feels
  through the object, and the static grip reading;
- a **background**: per-channel zero offset (+-30 LSB), the static grip pattern, white
  noise of standard deviation ``noise_lsb`` and the sensor's slow drift (random walk
  0.27 LSB/sqrt(s), the simulator's value; it is what moves a signal whose noise is below
  1 LSB across code boundaries);
- **context** (what the robot commands): ``servo_command`` [rad] and ``arm_velocity``
  [m/s].

Families (``noise_lsb`` log-uniform in 1-2 LSB unless stated):

``quiet_sub_lsb``, ``quiet_above_lsb``
    20 s of holding still, white noise 0.15-0.95 LSB / 1-3 LSB. No slip; all holding.
``closing_step``
    Three grip tightenings (servo steps of the controller): the grip reading rises by
    3-300 LSB (strongest channel) linearly over 10-100 ms (the servo's profile), then the
    fin-ray elastomer relaxes (standard linear solid, 10 % with 1.5 s and 8 % with 15 s, as
    in the simulator). Busy: the rise.
``ramp``
    Two slow ramps of 10-300 LSB over 0.3-4 s: a slow squeeze (grip pattern, servo moving)
    or the lift loading the contacts (shear pattern 1 / 0.6 / -0.5, arm starting).
    Busy: the ramp.
``low_frequency``
    The held object sways or the arm wobbles (not commanded): one or two sinusoids of
    0.5-5 Hz, 3-100 LSB, a random mix of grip and shear pattern with a sign per finger,
    for 4-8 s with 0.3 s raised-cosine edges. Busy: the episode.
``high_frequency``
    Motor hum while the arm moves: 62-150 Hz plus its second harmonic (0.3), 1-30 LSB with
    a 20 % amplitude modulation at 0.5-2 Hz, on for 5-8 s with 50 ms edges, channel gains
    0.3-1. The grasp is static: all holding.
``stick_slip_10_30lsb``, ``stick_slip_30_100lsb`` (and issue 26's families below)
    During a lift, three stick-slip bursts of 0.1-0.6 s: releases at 10-50 Hz (period
    jitter +-20 %, never shorter than 20 ms; jumps +-30 %) step the contact shear down
    and ring the finger's bending mode (the simulator's resonator: ringing =
    resonator(steps) - steps). Strength = peak ringing on the strongest channel of the
    slipping finger, log-uniform in [a, b] LSB; the other finger feels the profile's
    coupling (0.4-0.7) of it. The static shear steps are
    1/30 of the ringing per release (the simulator's shear / vibration gains). Event: first
    release to last release + 0.1 s (the simulator's stick-slip label). Unchanged by
    issue 38 (other tests and reports use them bit for bit); the physics below is meant to
    replace theirs in a later step.
``stick_slip_1_3lsb``, ``stick_slip_3_10lsb``, ``leading_finger`` (issue 38: re-derived)
    The same three bursts during a lift (onsets 2.5, 6.0, 9.5 s +- 0.4 s), each drawn from
    the finger's mechanics (:data:`PHYSICAL`, :class:`StickSlipRanges`; log-uniform unless
    marked uniform; reasons in docs/slip_families.md):

    - *bending mode*: profile resonance x 0.75-1.25 (10.5-47.5 Hz over the profiles;
      held-out 12.8-47.5 Hz). A printed EPU 40 fin-ray finger (tip stiffness ~250 N/m,
      modal mass 5-8 g) rings at 30-45 Hz free, which is how the slipping finger rings
      while its contact slides; a stuck contact adds the object's mass (the simulator's
      30 Hz / sqrt(1 + m / 0.3 kg): 14-27 Hz for 5 g-1 kg). Damping: profile damping
      x 0.5-2.5 (0.035-0.30): the elastomer's loss factor 0.07-0.3 gives 0.035-0.15, the
      sliding contact and a soft object add up to about as much again.
    - *stick-slip waveform* (:func:`stick_slip_train`): the shear builds at a constant
      rate while stuck and drops at each release (a sawtooth; before the first release the
      stuck contact sits at its limit, reached by the lift's or the grip's slow changes, so
      the sawtooth starts with a drop), each release rings the mode (ringing =
      resonator(shear) - shear, scaled to the strength). Static drop per release / peak
      ringing: 1/30-2 (1/30: the simulator's shear / vibration gains, a channel far more
      sensitive to the bending mode than to static shear; 1-2.7: one mode seen by the
      channel with equal static and dynamic gain, the overshoot of a step being
      exp(-pi zeta / sqrt(1 - zeta^2)) = 0.37-0.9 of the step), the mean drop at most 30 LSB
      (a release sheds at most ~0.5 N, 2 (mu_s - mu_k) N at the paper's grip forces, and the
      channels give at most ~60 LSB/N of static load: paper Fig. 3b).
    - *releases* (:func:`release_train`): mean rate 3-60 Hz (loading rate / drop: the
      simulator's mm-size slips about 1 s apart at 1 mm/s give a few Hz at the paper's 5
      mm/s lift, a stiff fast contact tens of Hz); the static-friction excess of each
      release is log-normal with sigma 0.05-0.6 (uniform), and sets both the drop and the
      stick before it (a texture, as the simulator's); no stick shorter than 5 ms. Each
      release lasts 0.5-8 ms (a mm-size slip at 0.1-1 m/s; a raised cosine). Burst 0.05-1 s
      (from a single release to the longest episode before the grip catches).
    - *channels* (:func:`vibration_pattern`): contact at the profile's location +- 0.15
      (uniform, the object's placement); the channel nearest the contact carries most:
      floor 0.05-0.5 (the global bending mode every channel feels) plus a kernel of width
      0.15-0.4 of the finger length (both uniform), with the transducers' trim. Static
      sawtooth on the simulator's shear pattern (1 / 0.6 / -0.5).
    - *the other finger*, ``stick_slip_*`` (both fingers slip: a release shifts the load
      onto the other contact, which releases too): the same releases 0-5 ms later
      (uniform), its own mode (x 0.9-1.1, uniform: the fingers are printed separately),
      peak ringing and sawtooth 0.3-1.0 of the slipping finger's; ``leading_finger`` (the
      paper's leading-finger stick-slip: the trailing finger slides at kinetic friction,
      whose force does not follow the release): in 1/3 of the bursts it feels nothing, in
      the others 0.02-0.3 of the leading finger's ringing through the object and the
      gripper (0-2 ms later, uniform); in half of the bursts it also unloads smoothly by
      1-20 LSB over the burst (its gross slip, raised cosine). Never the same ringing on
      both fingers.
    - *strength* = peak ringing on the strongest channel of the slipping (leading) finger:
      [a, b] LSB, ``leading_finger`` 1-150 LSB (the weakest stick-slip to the independent
      set's strongest).
    - *sensor*: white noise 0.3-2 LSB; mains hum in half the scenes (50 or 60 Hz,
      fundamental 0.1-2 LSB on the strongest channel, second and third harmonics 0-0.3 and
      0-0.5 of it, channel gains 0.5-1: pick-up in the transducer wiring and the ADC);
      drift: besides the background's 0.27 LSB/sqrt(s), a random walk of 0.05-1
      LSB/sqrt(s) and a thermal drift of +-1-30 LSB with time constant 2-20 s from a
      start in 0-4 s on the grip pattern (the paper's temperature limit: the simulator's
      30 LSB/K with 8 s). Hum and drift are left out of noise-free scenes.

    Event: first release to last release + 0.1 s.
``leading_finger`` before issue 38
    As stick-slip, 2-100 LSB, on one finger only (left or right, drawn): the other finger
    felt nothing; white noise 1-2 LSB, no hum.
``gross_smooth``
    During a lift, two episodes of smooth gross slip: the grip / shear pattern of both
    fingers decays monotonically (raised cosine) by 5-100 LSB over 0.5-3 s, without
    vibration (the contacts slide at kinetic friction); the object then sticks again.
    Strength = total decay on the strongest channel.

Labels: slip events as above; *busy* = the distractor plus the detector's reach after it
(0.25 s: window 400 + history 14 x 4 + median 5 samples); holding still = the rest from
``EVALUATE_FROM`` on, minus ``[onset, end + 0.5 s]`` of every event (see
:mod:`forte_perception.evaluation.labels`).

Split: profiles ``p0 p2 p4 p6`` with seeds 0, 2, 4, 6 are *tune*; ``p1 p3 p5 p7`` with
seeds 1, 3, 5, 7 are *held-out*. The held-out profiles' resonances (17, 23, 29, 38 Hz) lie
between and above the tune ones (14, 20, 26, 33 Hz); in the issue-38 families each burst
spreads them by x 0.75-1.25, so the held-out part reaches 47.5 Hz, the tune part 41 Hz.

:data:`SET_VERSION` names the families' generation (2: issue 38); the slip set's cache key
(:func:`forte_evaluation.slip_dataset.dataset_hash`) hashes this file, so any change here
rebuilds the cached set.
"""
from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from functools import partial

import numpy as np
from scipy.signal import lfilter

from forte_perception.evaluation.labels import (
    EVALUATE_FROM,
    FINGER_BOTH,
    FINGER_LEFT,
    FINGER_RIGHT,
    SPLITS,
    SlipScene,
    subtract_intervals,
)
from forte_ros.contract import QUANTUM as LSB
from forte_ros.contract import SAMPLE_RATE as FS

__all__ = ['FAMILIES', 'FS', 'LSB', 'PHYSICAL', 'PROFILES', 'SET_VERSION', 'FingerProfile',
           'StickSlipRanges', 'StickSlipTrain', 'burst_component', 'make_scene',
           'quantise_lsb', 'release_train', 'scene_keys', 'shear_sawtooth', 'signal_scenes',
           'static_drop', 'stick_slip_train', 'vibration_pattern']

#: Generation of the families (1: issues 14 and 26; 2: issue 38's physical stick-slip).
from forte_perception.evaluation.scene_parts import (
    _NOISE,
    _PROFILE,
    DETECTOR_REACH,
    DRIFT_LSB_PER_SQRT_S,
    GRIP_ANGLE,
    LIFT_VELOCITY,
    PROFILES,
    SEEDS_PER_SPLIT,
    SET_VERSION,
    SLIP_GRACE,
    FingerProfile,
    _both,
    _Draft,
    _loguniform,
    burst_component,
    quantise_lsb,
)
from forte_perception.evaluation.stick_slip import (
    PHYSICAL,
    StickSlipRanges,
    StickSlipTrain,
    _physical_stick_slip,
    release_train,
    shear_sawtooth,
    static_drop,
    stick_slip_train,
    vibration_pattern,
)


# ------------------------------------------------------------------------------ families
def _quiet(rng, profile, n) -> _Draft:
    return _Draft(np.zeros((n, 6)))


def _closing_steps(rng, profile, n) -> _Draft:
    draft = _Draft(np.zeros((n, 6)), servo=np.full(n, GRIP_ANGLE))
    normal = profile.pattern('normal')
    steps = []
    for centre in (2.0, 5.5, 9.0):
        t0 = int((centre + rng.uniform(-0.5, 0.5)) * FS)
        amp, rise = _loguniform(rng, 3.0, 300.0), rng.uniform(0.01, 0.1)
        u = np.clip((np.arange(n) - t0) / (rise * FS), 0.0, 1.0)
        du = np.diff(u, prepend=0.0)
        relax = sum(a * lfilter([1.0], [1.0, -math.exp(-1.0 / (tau * FS))], du)
                    for a, tau in ((0.10, 1.5), (0.08, 15.0)))
        balance = rng.uniform(0.8, 1.2)
        draft.signal += _both(normal, amp * (u + relax) / 1.18, (1.0, balance))
        draft.servo[t0:] -= amp * 1e-4
        draft.busy.append((t0, t0 + int(rise * FS) + 1))
        steps.append({'time_s': t0 / FS, 'amplitude_lsb': amp, 'rise_s': rise})
    draft.params['steps'] = steps
    return draft


def _ramps(rng, profile, n) -> _Draft:
    draft = _Draft(np.zeros((n, 6)), servo=np.full(n, GRIP_ANGLE), arm=np.zeros(n))
    ramps = []
    for start_range in ((1.5, 2.5), (7.0, 7.5)):
        t0 = int(rng.uniform(*start_range) * FS)
        length = _loguniform(rng, 0.3, 4.0)
        amp = _loguniform(rng, 10.0, 300.0) * rng.choice((-1.0, 1.0))
        kind = str(rng.choice(('squeeze', 'lift_load')))
        u = np.clip((np.arange(n) - t0) / (length * FS), 0.0, 1.0)
        pattern = profile.pattern('normal' if kind == 'squeeze' else 'shear')
        draft.signal += _both(pattern, amp * u, (1.0, rng.uniform(0.8, 1.2)))
        if kind == 'squeeze':
            draft.servo -= amp * 1e-4 * u
        else:
            draft.arm[t0:] = LIFT_VELOCITY
        draft.busy.append((t0, t0 + int(length * FS) + 1))
        ramps.append({'time_s': t0 / FS, 'amplitude_lsb': amp, 'length_s': length,
                      'kind': kind})
    draft.params['ramps'] = ramps
    return draft


def _edges(n: int, start: int, stop: int, edge: float) -> np.ndarray:
    """Envelope 0 -> 1 -> 0 with raised-cosine edges of ``edge`` seconds."""
    k = np.arange(n)
    e = max(int(edge * FS), 1)
    rise = np.clip((k - start) / e, 0.0, 1.0)
    fall = np.clip((stop - k) / e, 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * np.minimum(rise, fall)))


def _low_frequency(rng, profile, n) -> _Draft:
    draft = _Draft(np.zeros((n, 6)))
    t0 = int(rng.uniform(1.5, 3.0) * FS)
    stop = t0 + int(rng.uniform(4.0, 8.0) * FS)
    env = _edges(n, t0, stop, 0.3)
    t = np.arange(n) / FS
    mix = rng.uniform(0.0, 1.0)
    pattern = mix * profile.pattern('normal') + (1.0 - mix) * profile.pattern('shear')
    pattern = pattern / np.abs(pattern).max()
    amp = _loguniform(rng, 3.0, 100.0)
    parts = []
    for k in range(int(rng.integers(1, 3))):
        f = _loguniform(rng, 0.5, 5.0)
        a = amp * (1.0 if k == 0 else rng.uniform(0.3, 1.0))
        wave = a * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
        draft.signal += _both(pattern, env * wave, rng.choice((-1.0, 1.0), 2))
        parts.append({'frequency_hz': f, 'amplitude_lsb': a})
    draft.busy.append((t0, stop))
    draft.params.update(components=parts, start_s=t0 / FS, stop_s=stop / FS)
    return draft


def _add_hum(draft: _Draft, rng, n: int, t0: int, stop: int) -> dict:
    """Add motor hum (62-150 Hz + 0.3 second harmonic, 1-30 LSB, 20 % modulation) on
    [t0, stop) with 50 ms edges; its parameters."""
    env = _edges(n, t0, stop, 0.05)
    t = np.arange(n) / FS
    f0, amp, fm = rng.uniform(62.0, 150.0), _loguniform(rng, 1.0, 30.0), rng.uniform(0.5, 2.0)
    gains = rng.uniform(0.3, 1.0, 6)
    gains /= gains.max()
    phase = rng.uniform(0, 2 * np.pi, 2)
    hum = (np.sin(2 * np.pi * f0 * t + phase[0]) + 0.3 * np.sin(4 * np.pi * f0 * t + phase[1]))
    hum *= amp / 1.3 * env * (1.0 + 0.2 * np.sin(2 * np.pi * fm * t))
    draft.signal += hum[:, None] * gains[None, :]
    return {'frequency_hz': f0, 'amplitude_lsb': amp, 'modulation_hz': fm,
            'start_s': t0 / FS, 'stop_s': stop / FS}


def _high_frequency(rng, profile, n) -> _Draft:
    draft = _Draft(np.zeros((n, 6)), arm=np.zeros(n))
    t0 = int(rng.uniform(1.5, 3.0) * FS)
    stop = t0 + int(rng.uniform(5.0, 8.0) * FS)
    draft.params.update(_add_hum(draft, rng, n, t0, stop))
    draft.arm[t0:stop] = LIFT_VELOCITY
    return draft


def _burst(rng, profile, n: int, onset: int, duration: float,
           strength: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, int, dict]:
    """One stick-slip burst: ringing and static shear (n,) [LSB], last release, parameters."""
    rate, amp = rng.uniform(10.0, 50.0), _loguniform(rng, *strength)
    resonance = profile.resonance_hz * rng.uniform(0.95, 1.05)
    ringing, static, last = burst_component(n, onset, duration, rate, resonance,
                                            profile.damping, amp, rng)
    return ringing, static, last, {'onset_s': onset / FS, 'duration_s': duration,
                                   'rate_hz': rate, 'resonance_hz': resonance,
                                   'strength_lsb': amp}


def _add_burst(draft: _Draft, profile, burst: tuple, weights: np.ndarray,
               fingers: int) -> None:
    """Add a burst of :func:`_burst` on the fingers' ``weights`` (2,) and its event."""
    ringing, static, last, params = burst
    draft.signal += (_both(profile.pattern('vibration'), ringing, weights)
                     + _both(profile.pattern('shear'), static, weights))
    draft.events.append((int(round(params['onset_s'] * FS)), last + int(0.1 * FS), fingers,
                         'stick_slip', params['strength_lsb']))


def _one_finger(rng) -> tuple[int, np.ndarray]:
    """A drawn finger (0 left, 1 right) and its unit weights (2,)."""
    finger = int(rng.integers(0, 2))
    weights = np.zeros(2)
    weights[finger] = 1.0
    return finger, weights


def _stick_slip(rng, profile, n, strength: tuple[float, float], both: bool,
                durations: tuple[float, float] = (0.1, 0.6),
                centres: tuple[float, ...] = (2.5, 6.0, 9.5), hum: bool = False) -> _Draft:
    draft = _Draft(np.zeros((n, 6)), arm=np.full(n, LIFT_VELOCITY))
    bursts = []
    for centre in centres:
        onset = int((centre + rng.uniform(-0.4, 0.4)) * FS)
        burst = _burst(rng, profile, n, onset, rng.uniform(*durations), strength)
        finger, weights = _one_finger(rng)
        if both:
            weights[1 - finger] = profile.coupling
        fingers = FINGER_BOTH if both else (FINGER_LEFT, FINGER_RIGHT)[finger]
        _add_burst(draft, profile, burst, weights, fingers)
        bursts.append({**burst[3], 'finger': finger})
    draft.params['bursts'] = bursts
    if hum:  # the arm's motor hums through the whole lift
        draft.params['hum'] = _add_hum(draft, rng, n, 0, n)
    return draft


def _leading_gross(rng, profile, n) -> _Draft:
    """Stick-slip under the leading finger while the trailing finger slides smoothly."""
    draft = _Draft(np.zeros((n, 6)), arm=np.full(n, LIFT_VELOCITY))
    k = np.arange(n)
    episodes = []
    for centre in (2.5, 6.0, 9.5):
        onset = int((centre + rng.uniform(-0.4, 0.4)) * FS)
        duration = rng.uniform(0.2, 1.0)
        burst = _burst(rng, profile, n, onset, duration, (3.0, 30.0))
        finger, weights = _one_finger(rng)
        _add_burst(draft, profile, burst, weights, (FINGER_LEFT, FINGER_RIGHT)[finger])
        decay = _loguniform(rng, 5.0, 50.0)  # the trailing finger's gross slip [LSB]
        s = 0.5 * (1.0 - np.cos(np.pi * np.clip((k - onset) / (duration * FS), 0.0, 1.0)))
        trailing = 1.0 - weights
        draft.signal -= _both(profile.pattern('shear'), decay * s, trailing)
        episodes.append({**burst[3], 'finger': finger, 'trailing_decay_lsb': decay})
    draft.params['bursts'] = episodes
    return draft


def _gross_smooth(rng, profile, n) -> _Draft:
    draft = _Draft(np.zeros((n, 6)), arm=np.full(n, LIFT_VELOCITY))
    k = np.arange(n)
    onset = int(rng.uniform(2.5, 3.5) * FS)
    episodes = []
    for _ in range(2):
        room = (n - onset) / FS - SLIP_GRACE - 0.1
        length = min(rng.uniform(0.5, 3.0), room)
        amp = _loguniform(rng, 5.0, 100.0)
        mix = rng.uniform(0.3, 1.0)
        pattern = mix * profile.pattern('normal') + (1.0 - mix) * profile.pattern('shear')
        pattern = pattern / np.abs(pattern).max()
        s = 0.5 * (1.0 - np.cos(np.pi * np.clip((k - onset) / (length * FS), 0.0, 1.0)))
        draft.signal -= _both(pattern, amp * s)
        end = onset + int(length * FS)
        draft.events.append((onset, end, FINGER_BOTH, 'gross', amp))
        episodes.append({'onset_s': onset / FS, 'length_s': length, 'decay_lsb': amp,
                         'normal_share': mix})
        onset = end + int(rng.uniform(1.5, 2.5) * FS)
    draft.params['episodes'] = episodes
    return draft


def _family(builder: Callable, seconds: float, noise: tuple[float, float] = _NOISE,
            **kwargs) -> tuple[Callable, float, tuple[float, float]]:
    return partial(builder, **kwargs), seconds, noise


#: family name -> (builder, seconds, noise range [LSB])
FAMILIES: dict[str, tuple[Callable, float, tuple[float, float]]] = {
    'quiet_sub_lsb': _family(_quiet, 20.0, (0.15, 0.95)),
    'quiet_above_lsb': _family(_quiet, 20.0, (1.0, 3.0)),
    'closing_step': _family(_closing_steps, 12.0),
    'ramp': _family(_ramps, 12.0),
    'low_frequency': _family(_low_frequency, 12.0),
    'high_frequency': _family(_high_frequency, 12.0),
    # issue 38: re-derived from the finger's mechanics (module docstring)
    'stick_slip_1_3lsb': _family(_physical_stick_slip, 12.0, PHYSICAL.noise_lsb,
                                 strength=(1.0, 3.0), leading=False),
    'stick_slip_3_10lsb': _family(_physical_stick_slip, 12.0, PHYSICAL.noise_lsb,
                                  strength=(3.0, 10.0), leading=False),
    'stick_slip_10_30lsb': _family(_stick_slip, 12.0, strength=(10.0, 30.0), both=True),
    'stick_slip_30_100lsb': _family(_stick_slip, 12.0, strength=(30.0, 100.0), both=True),
    'leading_finger': _family(_physical_stick_slip, 12.0, PHYSICAL.noise_lsb,
                              strength=(1.0, 150.0), leading=True),
    'gross_smooth': _family(_gross_smooth, 13.0),
    # issue 26: what the paper describes and the first set lacked
    'sustained_sliding': _family(_stick_slip, 12.0, strength=(3.0, 30.0), both=True,
                                 durations=(0.5, 2.0), centres=(2.5, 7.0)),
    'leading_gross': _family(_leading_gross, 12.0),
    'stick_slip_hum': _family(_stick_slip, 12.0, strength=(3.0, 30.0), both=True, hum=True),
}


# ------------------------------------------------------------------------------ scenes
def _background(rng, profile: FingerProfile, n: int, noise_lsb: float,
                noise_free: bool) -> np.ndarray:
    """Offsets + static grip + white noise + drift, (n, 6) [LSB]."""
    base = rng.uniform(-30.0, 30.0, 6) + profile.grip_lsb * profile.pattern('normal').reshape(6)
    white = rng.standard_normal((n, 6))
    steps = rng.standard_normal((n, 6)) * (DRIFT_LSB_PER_SQRT_S / math.sqrt(FS))
    if noise_free:
        return np.broadcast_to(base, (n, 6)).copy()
    return base + white * noise_lsb + np.cumsum(steps, axis=0)


def make_scene(family: str, profile: str, seed: int, *, quantised: bool = True,
               noise_free: bool = False) -> SlipScene:
    """One labelled signal-level scene.

    Parameters
    ----------
    family : str
        A key of :data:`FAMILIES`.
    profile : str
        A finger profile name of :data:`PROFILES` ('p0' .. 'p7').
    seed : int
        Its parity must match the profile's split (even: tune profiles, odd: held-out).
    quantised : bool
        False: the analog signal (normalised units, not rounded), for tests.
    noise_free : bool
        Without white noise and drift (for tests of the family's own signal).

    Raises
    ------
    ValueError
        Unknown family or profile, or a seed of the other split.
    """
    if family not in FAMILIES:
        raise ValueError(f'unknown family {family!r}; expected one of {tuple(FAMILIES)}')
    if profile not in _PROFILE:
        raise ValueError(f'unknown profile {profile!r}')
    prof = _PROFILE[profile]
    if SPLITS[seed % 2] != prof.split:
        raise ValueError(f'seed {seed} belongs to the other split than profile {profile}')
    builder, seconds, noise = FAMILIES[family]
    n = int(seconds * FS)
    rng = np.random.default_rng([zlib.crc32(family.encode()), int(profile[1:]), seed])
    noise_lsb = _loguniform(rng, *noise)
    background = _background(rng, prof, n, noise_lsb, noise_free)
    draft = builder(rng, prof, n)
    x = background + draft.signal
    if draft.disturbance is not None and not noise_free:
        x = x + draft.disturbance
    frames = quantise_lsb(x) if quantised else x * LSB
    reach, grace = int(DETECTOR_REACH * FS), int(SLIP_GRACE * FS)
    remove = [(a, b + grace) for a, b, *_ in draft.events] + [(a, b + reach)
                                                              for a, b in draft.busy]
    ev = draft.events
    context = {'servo_command': draft.servo if draft.servo is not None
               else np.full(n, GRIP_ANGLE),
               'arm_velocity': draft.arm if draft.arm is not None else np.zeros(n)}
    return SlipScene(
        name=f'{family}/{profile}/{seed}', family=family, split=prof.split, source='signal',
        object_name=profile, seed=seed, frames=frames,
        events=np.array([e[:2] for e in ev], np.int64).reshape(-1, 2),
        event_fingers=[e[2] for e in ev], event_kinds=tuple(e[3] for e in ev),
        event_strength=[e[4] for e in ev],
        holding=subtract_intervals(EVALUATE_FROM, n, remove), fs=FS,
        evaluate_from=EVALUATE_FROM, context=context,
        params={'noise_lsb': noise_lsb, **draft.params})


def scene_keys(split: str | None = None, families=None) -> list[tuple[str, str, int]]:
    """(family, profile, seed) of every scene of the set (or of one split / some families)."""
    keys = []
    for family in (families or FAMILIES):
        for prof in PROFILES:
            if split is not None and prof.split != split:
                continue
            first = SPLITS.index(prof.split)
            keys += [(family, prof.name, first + 2 * i) for i in range(SEEDS_PER_SPLIT)]
    return keys


def signal_scenes(split: str | None = None, families=None) -> list[SlipScene]:
    """Every signal-level scene of the set (or of one split / some families)."""
    return [make_scene(*key) for key in scene_keys(split, families)]
