"""The physical stick-slip of issue 38's families (:mod:`forte_perception.evaluation.scenes`
docstring; reasons in docs/slip_families.md): release trains, the shear sawtooth, the
channel pattern of the vibration, a burst on one or both fingers, and the sensor's hum and
drift. Split out of ``scenes`` (size)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from forte_perception.evaluation.labels import (
    FINGER_BOTH,
    FINGER_LEFT,
    FINGER_RIGHT,
)
from forte_perception.evaluation.scene_parts import (
    _CENTRES,
    _TRIM,
    LIFT_VELOCITY,
    FingerProfile,
    _both,
    _Draft,
    _loguniform,
    _resonator,
)
from forte_ros.contract import SAMPLE_RATE as FS


# ------------------------------------------------- physical stick-slip (issue 38)
@dataclass(frozen=True)
class StickSlipRanges:
    """Ranges drawn by the physical stick-slip families (issue 38; reasons in the module
    docstring and docs/slip_families.md). Pairs are (low, high); draws are log-uniform
    unless the module docstring says uniform."""

    resonance_factor: tuple[float, float] = (0.75, 1.25)    # x profile mode [-]
    damping_factor: tuple[float, float] = (0.5, 2.5)        # x profile damping [-]
    rate_hz: tuple[float, float] = (3.0, 60.0)              # mean release rate [Hz]
    irregularity: tuple[float, float] = (0.05, 0.6)         # log-normal sigma, uniform [-]
    min_interval_s: float = 0.005                           # shortest stick [s]
    release_s: tuple[float, float] = (0.0005, 0.008)        # release duration [s]
    duration_s: tuple[float, float] = (0.05, 1.0)           # burst length [s]
    static_share: tuple[float, float] = (1.0 / 30.0, 2.0)   # static drop / peak ringing
    max_static_lsb: float = 30.0                            # cap of the mean static drop
    contact_jitter: float = 0.15                            # +- along the finger, uniform
    vibration_width: tuple[float, float] = (0.15, 0.4)      # kernel width, uniform [-]
    vibration_floor: tuple[float, float] = (0.05, 0.5)      # global-mode share, uniform
    coupling: tuple[float, float] = (0.3, 1.0)              # other finger, both-finger slip
    other_delay_s: tuple[float, float] = (0.0, 0.005)       # its lag, uniform [s]
    other_mode_factor: tuple[float, float] = (0.9, 1.1)     # its own mode, uniform [-]
    trailing_share: tuple[float, float] = (0.02, 0.3)       # leading-finger slip [-]
    trailing_silent: float = 1.0 / 3.0                      # P(trailing feels nothing)
    trailing_delay_s: tuple[float, float] = (0.0, 0.002)    # uniform [s]
    trailing_unload_lsb: tuple[float, float] = (1.0, 20.0)  # its smooth gross slip
    trailing_unloads: float = 0.5                           # P(it unloads smoothly)
    noise_lsb: tuple[float, float] = (0.3, 2.0)             # white noise
    hum_probability: float = 0.5                            # mains hum in a scene
    hum_lsb: tuple[float, float] = (0.1, 2.0)               # fundamental, strongest channel
    hum_harmonics: tuple[float, float] = (0.3, 0.5)         # 2nd, 3rd: uniform 0 .. this
    hum_gain: tuple[float, float] = (0.5, 1.0)              # per channel, uniform
    walk_lsb_per_sqrt_s: tuple[float, float] = (0.05, 1.0)  # extra random-walk drift
    thermal_lsb: tuple[float, float] = (1.0, 30.0)          # thermal drift amplitude
    thermal_tau_s: tuple[float, float] = (2.0, 20.0)        # its time constant


#: The ranges of :func:`_physical_stick_slip` (issue 38).
PHYSICAL = StickSlipRanges()
_MAINS_HZ = (50.0, 60.0)


def vibration_pattern(contact: float, width: float, floor: float) -> np.ndarray:
    """Share (3,) of a release's ringing on the distal, middle and root channels.

    The channel nearest the contact carries most: ``floor + (1 - floor) * exp(-((contact -
    centre) / width)^2)``, normalised to a maximum of 1 (``floor``: the finger's global
    bending mode, felt by every channel; the kernel: the local deformation at the contact).
    """
    p = floor + (1.0 - floor) * np.exp(-((contact - _CENTRES) / width) ** 2)
    return p / p.max()


def _smooth_step(n: int, at: np.ndarray, heights: np.ndarray, length: int) -> np.ndarray:
    """Sum (n,) of raised-cosine steps of ``heights`` starting at samples ``at``, each
    rising over ``length`` samples."""
    impulses = np.zeros(n)
    np.add.at(impulses, at, heights)
    ramp = 0.5 * (1.0 - np.cos(np.pi * np.arange(1, length + 1) / length))
    return np.cumsum(np.convolve(impulses, np.diff(ramp, prepend=0.0))[:n])


def release_train(onset: int, duration: float, rate_hz: float, irregularity: float,
                  rng: np.random.Generator,
                  min_interval: float = PHYSICAL.min_interval_s
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Release samples and static-friction excesses of one stick-slip burst.

    Stick-slip under a constant loading rate (the lift): while stuck the shear builds at
    a constant rate; it releases when it reaches the local static limit, kinetic +
    ``e_i / 2`` (``e_i`` log-normal, sigma ``irregularity``, mean 1: the surface's
    texture), and drops to kinetic - ``e_i / 2`` (the simulator's 2 kinetic - static), by
    ``e_i`` in units of the mean drop. The stick before release ``i`` then builds
    ``(e_{i-1} + e_i) / 2`` and lasts ``(e_{i-1} + e_i) / 2 / rate_hz`` (at least
    ``min_interval``): the irregularities of the intervals and of the drops come from the
    same texture. Before the first release the contact is stuck at its limit.

    Returns
    -------
    times : ndarray of int (k,)
        Release samples, the first at ``onset``, all before ``onset + duration``.
    excess : ndarray (k,)
        Drop of each release (mean 1 over many releases) [-].
    """
    def draw() -> float:
        return float(math.exp(irregularity * rng.standard_normal()
                              - 0.5 * irregularity ** 2))

    e = draw()
    times, excess, t = [onset], [e], float(onset)
    while True:
        nxt = draw()
        t += max(0.5 * (e + nxt) / rate_hz, min_interval) * FS
        if round(t) >= onset + duration * FS:
            break
        times.append(int(round(t)))
        excess.append(nxt)
        e = nxt
    return np.array(times, np.int64), np.array(excess)


@dataclass
class StickSlipTrain:
    """One finger's stick-slip burst (:func:`stick_slip_train`), all (n,) [LSB].

    Attributes
    ----------
    ringing : ndarray
        Bending-mode ringing, peak ``|ringing|`` = the strength.
    static : ndarray
        Static shear sawtooth: builds while stuck, drops at each release (mean drop =
        ``static_share`` x strength).
    shear : ndarray
        The sawtooth in units of the mean drop (the force that drives the mode) [-].
    releases : ndarray of int
        Release samples.
    """

    ringing: np.ndarray
    static: np.ndarray
    shear: np.ndarray
    releases: np.ndarray


def shear_sawtooth(n: int, times: np.ndarray, excess: np.ndarray, rate_hz: float,
                   release_s: float) -> np.ndarray:
    """The contact shear (n,) of a release train, in units of the mean drop, 0 before the
    first release (stuck at its limit).

    Each release drops ``excess[i]`` along a raised cosine of ``release_s``; between
    releases the shear builds at ``rate_hz`` mean drops per second (the lift reloads the
    re-stuck contact) until the last release; constant after it (stuck again, the load
    carried).
    """
    k = np.arange(n, dtype=float)
    onset, last = float(times[0]), float(times[-1])
    build = rate_hz / FS * np.clip(k - onset, 0.0, last - onset)
    length = max(int(round(release_s * FS)), 1)
    return build - _smooth_step(n, times, excess, length)


def _ring(shear: np.ndarray, resonance_hz: float, damping: float) -> np.ndarray:
    b, a = _resonator(resonance_hz, damping)
    return lfilter(b, a, shear) - shear


def _delayed(x: np.ndarray, samples: int) -> np.ndarray:
    out = np.zeros_like(x)
    out[samples:] = x[:x.size - samples]
    return out


def stick_slip_train(n: int, onset: int, duration: float, rate_hz: float,
                     irregularity: float, release_s: float, resonance_hz: float,
                     damping: float, strength: float, static_share: float,
                     rng: np.random.Generator) -> StickSlipTrain:
    """One finger's stick-slip burst: a sawtooth of contact shear that rings the finger's
    bending mode at every release.

    Parameters
    ----------
    n, onset : int
        Samples of the scene; sample of the first release.
    duration : float
        Releases fall in ``[onset, onset + duration)`` [s].
    rate_hz : float
        Mean release rate [Hz] (:func:`release_train`).
    irregularity : float
        Log-normal sigma of the static-friction excess (drop sizes and intervals) [-].
    release_s : float
        Duration of one release (the slip) [s].
    resonance_hz, damping : float
        Bending mode [Hz] and its damping ratio [-].
    strength : float
        Peak ringing [LSB].
    static_share : float
        Mean static drop per release / ``strength`` [-]; the mean drop is capped at
        ``PHYSICAL.max_static_lsb``.
    rng : numpy.random.Generator
    """
    times, excess = release_train(onset, duration, rate_hz, irregularity, rng)
    shear = shear_sawtooth(n, times, excess, rate_hz, release_s)
    ringing = _ring(shear, resonance_hz, damping)
    ringing *= strength / np.abs(ringing).max()
    static = shear * (static_drop(strength, static_share) / excess.mean())
    return StickSlipTrain(ringing, static, shear / excess.mean(), times)


def static_drop(strength: float, static_share: float) -> float:
    """Mean static drop per release [LSB]: ``static_share * strength``, at most
    ``PHYSICAL.max_static_lsb`` (a release sheds at most ~0.5 N of shear, 2 (mu_s - mu_k) N,
    and the channels give at most ~60 LSB/N of static load)."""
    return min(static_share * strength, PHYSICAL.max_static_lsb)


def _finger_pattern(vibration: np.ndarray, finger: int) -> np.ndarray:
    """(3,) vibration pattern with the finger's transducer trim, strongest 1."""
    p = vibration * _TRIM[finger]
    return p / p.max()


def _add_finger(signal: np.ndarray, finger: int, ringing: np.ndarray, vibration: np.ndarray,
                static: np.ndarray, shear: np.ndarray) -> None:
    cols = slice(3 * finger, 3 * finger + 3)
    signal[:, cols] += ringing[:, None] * vibration[None, :] + static[:, None] * shear[None, :]


def _physical_burst(rng, profile: FingerProfile, n: int, onset: int,
                    strength: tuple[float, float]) -> tuple[StickSlipTrain, dict]:
    r = PHYSICAL
    params = {'onset_s': onset / FS, 'duration_s': _loguniform(rng, *r.duration_s),
              'rate_hz': _loguniform(rng, *r.rate_hz),
              'irregularity': float(rng.uniform(*r.irregularity)),
              'release_s': _loguniform(rng, *r.release_s),
              'resonance_hz': profile.resonance_hz * _loguniform(rng, *r.resonance_factor),
              'damping': profile.damping * _loguniform(rng, *r.damping_factor),
              'strength_lsb': _loguniform(rng, *strength),
              'static_share': _loguniform(rng, *r.static_share),
              'contact': float(np.clip(profile.contact + rng.uniform(-r.contact_jitter,
                                                                     r.contact_jitter),
                                       0.05, 0.95)),
              'vibration_width': float(rng.uniform(*r.vibration_width)),
              'vibration_floor': float(rng.uniform(*r.vibration_floor))}
    train = stick_slip_train(n, onset, params['duration_s'], params['rate_hz'],
                             params['irregularity'], params['release_s'],
                             params['resonance_hz'], params['damping'],
                             params['strength_lsb'], params['static_share'], rng)
    params['releases'] = int(train.releases.size)
    return train, params


def _physical_stick_slip(rng, profile, n, strength: tuple[float, float],
                         leading: bool) -> _Draft:
    """Stick-slip bursts on both fingers (``leading`` False) or under the leading finger
    (module docstring, issue 38)."""
    r = PHYSICAL
    draft = _Draft(np.zeros((n, 6)), arm=np.full(n, LIFT_VELOCITY),
                   disturbance=np.zeros((n, 6)))
    shear = profile.pattern('shear')
    k = np.arange(n)
    bursts = []
    for centre in (2.5, 6.0, 9.5):
        onset = int((centre + rng.uniform(-0.4, 0.4)) * FS)
        train, params = _physical_burst(rng, profile, n, onset, strength)
        finger = int(rng.integers(0, 2))
        other = 1 - finger
        vib = vibration_pattern(params['contact'], params['vibration_width'],
                                params['vibration_floor'])
        _add_finger(draft.signal, finger, train.ringing, _finger_pattern(vib, finger),
                    train.static, shear[finger])
        other_contact = float(np.clip(params['contact'] + rng.uniform(-0.05, 0.05),
                                      0.05, 0.95))
        other_vib = _finger_pattern(vibration_pattern(
            other_contact, params['vibration_width'], params['vibration_floor']), other)
        if leading:
            silent = rng.uniform() < r.trailing_silent
            share = 0.0 if silent else _loguniform(rng, *r.trailing_share)
            delay = int(round(rng.uniform(*r.trailing_delay_s) * FS))
            unload = (_loguniform(rng, *r.trailing_unload_lsb)
                      if rng.uniform() < r.trailing_unloads else 0.0)
            s = 0.5 * (1.0 - np.cos(np.pi * np.clip(
                (k - onset) / (params['duration_s'] * FS), 0.0, 1.0)))
            _add_finger(draft.signal, other, share * _delayed(train.ringing, delay),
                        other_vib, -unload * s, shear[other])
            params.update(trailing_share=share, trailing_delay_s=delay / FS,
                          trailing_unload_lsb=unload)
            fingers = (FINGER_LEFT, FINGER_RIGHT)[finger]
        else:
            coupling = _loguniform(rng, *r.coupling)
            delay = int(round(rng.uniform(*r.other_delay_s) * FS))
            mode = params['resonance_hz'] * rng.uniform(*r.other_mode_factor)
            shifted = _delayed(train.shear, delay)
            ringing = _ring(shifted, mode, params['damping'])
            ringing *= coupling * params['strength_lsb'] / np.abs(ringing).max()
            static = shifted * (coupling * static_drop(params['strength_lsb'],
                                                       params['static_share']))
            _add_finger(draft.signal, other, ringing, other_vib, static, shear[other])
            params.update(coupling=coupling, other_delay_s=delay / FS,
                          other_resonance_hz=mode)
            fingers = FINGER_BOTH
        draft.events.append((onset, int(train.releases[-1]) + int(0.1 * FS), fingers,
                             'stick_slip', params['strength_lsb']))
        bursts.append({**params, 'finger': finger, 'other_contact': other_contact,
                       'static_drop_lsb': static_drop(params['strength_lsb'],
                                                      params['static_share'])})
    draft.params['bursts'] = bursts
    draft.params.update(_add_disturbances(draft, rng, profile, n))
    return draft


def _add_disturbances(draft: _Draft, rng, profile: FingerProfile, n: int) -> dict:
    """Mains hum (in some scenes), extra random-walk drift and thermal drift into
    ``draft.disturbance`` (left out of noise-free scenes); their parameters."""
    r = PHYSICAL
    t = np.arange(n) / FS
    out = {}
    if rng.uniform() < r.hum_probability:
        mains = float(rng.choice(_MAINS_HZ))
        amp = _loguniform(rng, *r.hum_lsb)
        h2, h3 = (float(rng.uniform(0.0, h)) for h in r.hum_harmonics)
        phase = rng.uniform(0.0, 2.0 * np.pi, 3)
        gains = rng.uniform(*r.hum_gain, 6)
        gains /= gains.max()
        wave = amp * (np.sin(2 * np.pi * mains * t + phase[0])
                      + h2 * np.sin(4 * np.pi * mains * t + phase[1])
                      + h3 * np.sin(6 * np.pi * mains * t + phase[2]))
        draft.disturbance += wave[:, None] * gains[None, :]
        out['mains_hum'] = {'frequency_hz': mains, 'amplitude_lsb': amp,
                            'second_harmonic': h2, 'third_harmonic': h3}
    walk = _loguniform(rng, *r.walk_lsb_per_sqrt_s)
    draft.disturbance += np.cumsum(rng.standard_normal((n, 6)), axis=0) * (
        walk / math.sqrt(FS))
    amp = _loguniform(rng, *r.thermal_lsb) * rng.choice((-1.0, 1.0))
    tau = _loguniform(rng, *r.thermal_tau_s)
    start = rng.uniform(0.0, 4.0)
    thermal = amp * (1.0 - np.exp(-np.clip(t - start, 0.0, None) / tau))
    weights = rng.uniform(0.5, 1.0, 2)
    draft.disturbance += _both(profile.pattern('normal'), thermal, weights)
    out['drift'] = {'walk_lsb_per_sqrt_s': walk, 'thermal_lsb': float(amp),
                    'thermal_tau_s': tau, 'thermal_start_s': start}
    return out
