"""Vectorised 2 kHz synthesis of the sensor frames and the per-sample truth.

Per :meth:`SignalSynthesis.synthesise` call: interpolate the mechanics tick records, add
the step of every stick-slip release, run the finger's bending resonance (2nd-order IIR
with carried state), map deflections, shear and temperature to the 6 channel pressures,
add noise, quantise to 11 bits. The normal load's channel pattern follows the contact as
it slides along each finger (:func:`~forte_sim.model.slid_contact_location`, per sample);
the shear, ringing and temperature patterns stay those of the grasp location. Every
operation is pointwise or a sequential IIR with carried state, so any chunking gives the
same data.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from forte_sim.model import (
    ChannelGainMap,
    GripperModel,
    channel_gains,
    pressure_response,
    quantise,
    resonator_coefficients,
    slid_contact_location,
)
from forte_sim.noise import SensorNoise, load_cell_reading
from forte_sim.state import (
    TICK_SAMPLES,
    ArmState,
    ContactState,
    GripperState,
    ObjectState,
    TrialDraws,
)

try:  # the compiled core of scipy.signal.lfilter, without its per-call argument handling
    from scipy.signal._sigtools import _linear_filter as _compiled_linear_filter
except ImportError:  # pragma: no cover - other scipy layouts: the public function
    _compiled_linear_filter = None

#: Columns of a mechanics tick record (one row per tick boundary).
RECORD_FIELDS = ('theta', 'deflection_left', 'deflection_right', 'force_left', 'force_right',
                 'shear_left', 'shear_right', 'temperature_left', 'temperature_right',
                 'lift', 'height', 'slip', 'rotation', 'slide_left', 'slide_right')
_COLUMN = {name: index for index, name in enumerate(RECORD_FIELDS)}


def _pair(name: str) -> slice:
    """Columns of the left and right value of a per-finger record field."""
    return slice(_COLUMN[name + '_left'], _COLUMN[name + '_right'] + 1)


_THETA, _LIFT, _HEIGHT, _SLIP, _ROTATION = (
    _COLUMN[name] for name in ('theta', 'lift', 'height', 'slip', 'rotation'))
_DEFLECTION, _FORCE, _SHEAR, _TEMPERATURE, _SLIDE = (
    _pair(name) for name in ('deflection', 'force', 'shear', 'temperature', 'slide'))
_RELEASE_COUPLING = 0.5     # share of a release step felt by the other finger [-]
_TICK_INDEX = np.arange(1 << 16) // TICK_SAMPLES
_TICK_FRACTION = (np.arange(1 << 16) % TICK_SAMPLES) / TICK_SAMPLES


def tick_record(gripper: GripperState, arm: ArmState, body: ObjectState,
                contact: ContactState) -> tuple:
    """The state at a tick boundary, in the order of :data:`RECORD_FIELDS`.

    The shear excludes the release steps (added at their own sample by the synthesis);
    the slide of each finger up the object [m] moves its contact along the finger.
    """
    return (gripper.theta, gripper.deflection[0], gripper.deflection[1], gripper.force[0],
            gripper.force[1], contact.shear[0] - contact.jumps[0],
            contact.shear[1] - contact.jumps[1], gripper.temperature[0],
            gripper.temperature[1], arm.lift, body.height,
            0.5 * (contact.slide[0] + contact.slide[1]), body.rotation, contact.slide[0],
            contact.slide[1])


def _iir(b: np.ndarray, a: np.ndarray, x: np.ndarray,
         state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """scipy.signal.lfilter along axis 0 with initial state (same arithmetic, less overhead)."""
    if _compiled_linear_filter is not None:
        return _compiled_linear_filter(b, a, x, 0, state)
    return lfilter(b, a, x, axis=0, zi=state)


def _jump_series(samples: np.ndarray, finger: int, events: list[tuple[int, int, float]],
                 before: float) -> np.ndarray:
    """Cumulative release steps of one finger at each sample (piecewise constant)."""
    own = [(sample, total) for sample, who, total in events if who == finger]
    if not own:
        return np.full(len(samples), before)
    indices = np.array([sample for sample, _ in own], dtype=np.float64)
    totals = np.array([before] + [total for _, total in own])
    position = np.searchsorted(indices, samples, side='right')
    return totals[position]


class SignalSynthesis:
    """Sensor readings of one scene at 2 kHz from its mechanics tick records.

    Parameters
    ----------
    model : GripperModel
        Sensor parameters.
    seed : int
        Seed of the scene (noise).
    draws : TrialDraws
        Contact location at zero slide and spread (channel gains) and transducer offsets.
    mass : float
        Object mass [kg] (lowers the finger's bending mode); 0 without an object.
    dynamics : bool
        Shear and release vibration (grasp scenes); False for the rig and the empty scene.
    load_cell : bool
        The scene has a load cell (calibration rig).
    """

    def __init__(self, model: GripperModel, seed: int, draws: TrialDraws, mass: float,
                 dynamics: bool, load_cell: bool) -> None:
        self.model = model
        self._seed = seed
        self._dynamics = dynamics
        self._load_cell = load_cell
        self._offsets = draws.offsets
        gains = [channel_gains(model, draws.contact_location, draws.contact_spread, finger)
                 for finger in (0, 1)]
        #: Normal gains at the grasp location (zero slide), as channel_gains gives them.
        self._normal_gain = np.concatenate(gains)                      # (6,)
        self._location = draws.contact_location
        self._gain_map = ChannelGainMap(model, draws.contact_spread)
        self._shear_gain = np.array(model.shear_gain * 2)              # (6,)
        self._vibration_gain = np.array(model.vibration_gain * 2)      # (6,)
        self._temperature_gain = model.temperature_gain * np.array((1.0, 0.6, 0.3) * 2)
        self._noise = SensorNoise(model, seed)
        #: Bending-mode frequency excited by stick-slip releases [Hz].
        self.vibration_frequency = model.bending_frequency / math.sqrt(
            1.0 + mass / model.bending_mass)
        self._resonator_b, self._resonator_a = resonator_coefficients(
            self.vibration_frequency, model.vibration_damping)
        self._resonator_state = np.zeros((2, 2))      # (filter order, finger)

    def synthesise(self, first_sample: int, records: np.ndarray, slip_types: np.ndarray,
                   object_states: np.ndarray, events: list[tuple[int, int, float]],
                   jumps_before: tuple[float, float]) -> dict[str, np.ndarray]:
        """Frames and per-sample truth of the ticks between consecutive ``records`` rows.

        Parameters
        ----------
        first_sample : int
            Sample index of the first tick's start.
        records : numpy.ndarray, shape (ticks + 1, len(RECORD_FIELDS))
            Tick boundary records (:func:`tick_record`), the first one from before.
        slip_types, object_states : numpy.ndarray, shape (ticks,), uint8
            Labels of each tick.
        events : list of (int, int, float)
            Stick-slip releases of these ticks: (sample, finger, jumps after).
        jumps_before : tuple of float
            Cumulative release steps of each finger before the first tick [N].

        Returns
        -------
        dict
            ``frames`` (n, 6) and the per-sample ``theta``, ``finger_force`` (n, 2),
            ``load_cell``, ``lift``, ``height``, ``slip``, ``rotation``, ``slip_type``,
            ``object_state``.
        """
        count = len(slip_types) * TICK_SAMPLES
        # linear interpolation of every tick quantity between tick boundaries: the value
        # of a sample depends only on its two boundary records and its place in the tick
        tick = _TICK_INDEX[:count] if count <= len(_TICK_INDEX) else (
            np.arange(count) // TICK_SAMPLES)
        fraction = _TICK_FRACTION[:count] if count <= len(_TICK_FRACTION) else (
            (np.arange(count) % TICK_SAMPLES) / TICK_SAMPLES)
        start = records[:-1][tick]
        fine = start + (records[1:][tick] - start) * fraction[:, None]
        force = fine[:, _FORCE]
        if self._load_cell:
            load_cell = load_cell_reading(force.mean(axis=1), first_sample, self._seed,
                                          self.model.load_cell_noise)
        else:
            load_cell = np.full(count, np.nan)
        return {
            'frames': self._frames(fine, first_sample, events, jumps_before),
            'theta': fine[:, _THETA],
            'finger_force': force,
            'load_cell': load_cell,
            'lift': fine[:, _LIFT],
            'height': fine[:, _HEIGHT],
            'slip': fine[:, _SLIP],
            'rotation': fine[:, _ROTATION],
            'slip_type': slip_types[tick],
            'object_state': object_states[tick],
        }

    def _frames(self, fine: np.ndarray, first_sample: int,
                events: list[tuple[int, int, float]],
                jumps_before: tuple[float, float]) -> np.ndarray:
        """Quantised raw readings of the interpolated samples ``fine``."""
        count = len(fine)
        pressure = pressure_response(self.model, fine[:, _DEFLECTION])   # (n, 2)
        raw = np.repeat(pressure, 3, axis=1) * self._normal_gains(fine[:, _SLIDE])
        raw += np.repeat(fine[:, _TEMPERATURE], 3, axis=1) * self._temperature_gain
        if self._dynamics:
            jumps = self._release_steps(first_sample, count, events, jumps_before)
            shear = fine[:, _SHEAR] + jumps
            # the bending mode rings after every release step (smooth loading does not
            # excite it); a release jolts the object, which shakes the other finger too
            drive = jumps + _RELEASE_COUPLING * jumps[:, ::-1]
            dynamic, self._resonator_state = _iir(self._resonator_b, self._resonator_a, drive,
                                                  self._resonator_state)
            raw += (np.repeat(shear, 3, axis=1) * self._shear_gain
                    + np.repeat(dynamic - drive, 3, axis=1) * self._vibration_gain)
        raw += self._offsets
        raw += self._noise.read(first_sample, first_sample + count)
        return quantise(raw)

    def _normal_gains(self, slide: np.ndarray) -> np.ndarray:
        """Normal-load channel gains of each sample, shape (6,) or (n, 6) [normalised/mm].

        ``slide`` (n, 2) [m]: each finger's slide up the object; its contact moves toward
        the tip by it. A sample whose contact is at the grasp location (zero slide) keeps
        :func:`channel_gains`' values exactly, so frames without slide are those of a fixed
        location bit for bit, whatever the chunking.
        """
        if not slide.any():
            return self._normal_gain
        locations = slid_contact_location(self.model, self._location, slide)
        gains = self._gain_map(locations)
        at_grasp = locations == self._location
        if at_grasp.any():
            return np.where(np.repeat(at_grasp, 3, axis=1), self._normal_gain, gains)
        return gains

    @staticmethod
    def _release_steps(first_sample: int, count: int, events: list[tuple[int, int, float]],
                       jumps_before: tuple[float, float]) -> np.ndarray:
        """Cumulative release steps of both fingers at each sample, shape (count, 2) [N]."""
        if events:
            samples = np.arange(first_sample, first_sample + count)
            return np.column_stack([_jump_series(samples, finger, events, jumps_before[finger])
                                    for finger in (0, 1)])
        jumps = np.empty((count, 2))
        jumps[:, 0] = jumps_before[0]
        jumps[:, 1] = jumps_before[1]
        return jumps
