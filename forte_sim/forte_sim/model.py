"""Physical model of the FORTE gripper and its sensor (pure functions and constants).

Units inside the model: finger deflection in mm, forces in N, angles in rad, lengths
exposed to users in m. The numbers carry their provenance in :data:`PROVENANCE`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from forte_ros.contract import CHANNEL_NAMES, QUANTUM, SAMPLE_RATE

STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class GripperModel:
    """Parameters of the gripper, the fin-ray fingers and the pressure sensor.

    See :data:`PROVENANCE` for where each number comes from.
    """

    # --- linkage and servo
    gap_per_radian: float = 0.136        # fingertip gap per rad of servo angle [m/rad]
    theta_max: float = 1.0               # servo travel, fully open [rad]
    default_profile_velocity: float = 0.5  # [rad/s]
    default_max_current: float = 1.0     # current limit [A]
    torque_constant: float = 1.78        # XM430-W350: 4.1 N m stall at 2.3 A [N m/A]
    friction_current: float = 0.05       # no-load current of the servo [A]
    # --- fin-ray finger: F = scale(u) * (k1 d + k3 d^3), d in mm
    finger_k1: float = 0.25              # [N/mm]
    finger_k3: float = 1.0e-4            # [N/mm^3]
    relaxation_amplitudes: tuple[float, float] = (0.10, 0.08)   # [-]
    relaxation_times: tuple[float, float] = (1.5, 15.0)         # [s]
    tangential_stiffness: float = 100.0  # contact shear stiffness per finger at 0 N [N/m]
    tangential_stiffening: float = 150.0  # its growth with normal force [N/m per N]
    bending_frequency: float = 30.0      # finger bending mode, no object [Hz]
    bending_mass: float = 0.3            # object mass that lowers it by sqrt(2) [kg]
    vibration_damping: float = 0.10      # damping ratio of that mode [-]
    # --- sensor: channel gain = base * (floor + (1 - floor) * kernel(u))
    channel_base_gain: tuple[float, float, float] = (0.026, 0.016, 0.010)   # [1/mm]
    channel_centres: tuple[float, float, float] = (0.15, 0.50, 0.85)        # [-]
    channel_floor: float = 0.55          # [-]
    channel_kernel_width: float = 0.35   # [-]
    channel_trim: tuple[float, ...] = (1.00, 0.94, 1.07, 1.05, 0.97, 0.92)  # unit spread
    finger_length: float = 0.072         # sensing span that u in [0, 1] covers [m]
    pressure_curvature: float = 0.004    # concave pressure-deflection term [1/mm]
    shear_gain: tuple[float, float, float] = (0.004, 0.0024, -0.002)       # static [1/N]
    vibration_gain: tuple[float, float, float] = (0.12, 0.08, 0.05)        # dynamic [1/N]
    # --- temperature: ideal gas, dP/P = dT/T: 101325 Pa / 293 K = 1.39 inH2O/K for the
    # whole channel; only the part under the contact is heated.
    temperature_gain: float = 0.03       # [normalised/K]
    temperature_time: float = 8.0        # [s]
    # --- noise (normalised units)
    white_noise: float = 0.0012
    low_frequency_noise: float = 0.0004
    low_frequency_time: float = 0.2      # [s]
    drift_per_sqrt_second: float = 0.00026
    impulse_rate: float = 0.2            # impulses per second per channel
    impulse_amplitude: tuple[float, float] = (0.02, 0.2)
    offset_range: float = 0.03           # zero offset of each transducer, +- [normalised]
    # --- world
    table_friction: float = 0.4          # object on table [-]
    arm_acceleration: float = 0.5        # arm velocity change limit [m/s^2]
    load_cell_noise: float = 0.005       # [N]
    channel_names: tuple[str, ...] = field(default=CHANNEL_NAMES)

    @property
    def lever_arm(self) -> float:
        """Fingertip travel per finger per radian, the servo's lever for grip force [m]."""
        return self.gap_per_radian / 2.0


#: Provenance of the parameters of :class:`GripperModel`.
PROVENANCE = {
    'gap_per_radian': "paper: apple 75 mm at theta_zeroF 0.552 rad, jam jar 64.7 mm at 0.476",
    'theta_max': 'estimate (opening 136 mm)',
    'default_profile_velocity': 'estimate',
    'torque_constant': 'ROBOTIS XM430-W350 data sheet (4.1 N m at 2.3 A, 12 V)',
    'friction_current': 'estimate',
    'finger_k1, finger_k3': 'fin-ray literature order (0.1-0.5 N/mm, stiffening); fitted so '
                            "that the paper's apple needs 0.5 N at theta_grasp 0.527 rad and "
                            'the rig spans 0-8 N',
    'relaxation': 'estimate for a polyurethane elastomer (EPU 40): 18 % over ~15 s',
    'tangential_stiffness, tangential_stiffening': 'estimate; discrete mm-size slips '
        'about 1 s apart at 1 mm/s as in the paper Fig. 4a',
    'bending_frequency, bending_mass, vibration_damping': 'estimate (printed elastomer '
                                                          'finger, in the 10-50 Hz band)',
    'channel gains': 'estimate: 8 N -> about 0.6 of full scale on the distal pair, '
                     'distal > middle > root as in the paper Fig. 3b',
    'finger_length': 'hardware/forte_finger default design (fin-ray 90 mm, mount to tip, = '
                     'forte_finray_length in forte_description; sensing legs centred at '
                     '0.78 / 0.5 / 0.22 of it, i.e. 25.2 mm apart): the span on which the '
                     'channel_centres 0.15 / 0.5 / 0.85 sit on those legs, '
                     '25.2 mm / 0.35 = 72 mm (u = 0 is 9 mm below the tip, u = 1 9 mm above '
                     'the mount); the 90 mm is itself an estimate of the paper\'s finger, '
                     'which gives no dimension',
    'shear_gain, vibration_gain': 'estimate, tuned so the paper slip detector sees stick-slip',
    'temperature_gain': 'ideal gas law (1.39 inH2O/K) x ~2 % of the channel volume heated',
    'noise': 'estimate for an ESP32-S3 ADC (about 1 LSB white) and the ELVR-L01D',
    'table_friction': 'estimate',
}


DEFAULT_MODEL = GripperModel()


def contact_stiffness_scale(contact_location: float) -> float:
    """Stiffness multiplier of a fin-ray finger for a contact at ``contact_location``.

    A fin-ray finger is softest at its tip (longest lever) and stiffens towards the root.

    Parameters
    ----------
    contact_location : float
        0 = fingertip, 1 = root [-].

    Returns
    -------
    float
        Multiplier of the nominal stiffness [-].
    """
    return 0.8 + 0.8 * contact_location


def channel_gains(model: GripperModel, contact_location: float, contact_spread: float,
                  finger: int) -> np.ndarray:
    """Normal-deflection gain of the three channels of one finger.

    Parameters
    ----------
    model : GripperModel
    contact_location : float
        0 = tip, 1 = root [-].
    contact_spread : float
        Extent of the contact along the finger [-]; widens the kernel.
    finger : int
        0 = left, 1 = right.

    Returns
    -------
    numpy.ndarray, shape (3,)
        Gains [normalised/mm] for distal, middle, root.
    """
    width = math.hypot(model.channel_kernel_width, contact_spread)
    gains = np.empty(3)
    for index in range(3):
        kernel = math.exp(-((contact_location - model.channel_centres[index]) / width) ** 2)
        gains[index] = (model.channel_base_gain[index]
                        * (model.channel_floor + (1.0 - model.channel_floor) * kernel)
                        * model.channel_trim[3 * finger + index])
    return gains


def slid_contact_location(model: GripperModel, contact_location: float,
                          slide: float | np.ndarray) -> float | np.ndarray:
    """Contact location after the finger slid ``slide`` up the object.

    The fingers point down at the object: when the object slides down relative to a finger
    (gross slip, or the arm lifting the fingers along an object the table holds), the
    contact patch moves along the finger toward the tip by the slide distance.

    Parameters
    ----------
    model : GripperModel
        Its ``finger_length`` is the span that u in [0, 1] covers [m].
    contact_location : float
        Location at zero slide, 0 = tip, 1 = root [-].
    slide : float or numpy.ndarray
        Finger travel up the object (= object travel down the finger) [m]
        (:attr:`forte_sim.state.ContactState.slide`); negative: toward the root.

    Returns
    -------
    float or numpy.ndarray
        ``clip(contact_location - slide / finger_length, 0, 1)`` [-], the shape of ``slide``.
    """
    return np.clip(contact_location - slide / model.finger_length, 0.0, 1.0)


class ChannelGainMap:
    """:func:`channel_gains` of both fingers for many contact locations at once.

    Parameters
    ----------
    model : GripperModel
    contact_spread : float
        Extent of the contact along the finger [-] (fixed).

    Notes
    -----
    Each gain depends on its own location only (elementwise numpy), so any chunking of the
    locations gives the same gains. They equal :func:`channel_gains` to rounding (numpy's
    ``exp`` is not ``math.exp`` bit for bit).
    """

    def __init__(self, model: GripperModel, contact_spread: float) -> None:
        base = np.array(model.channel_base_gain * 2) * np.array(model.channel_trim)
        self._centres = np.array(model.channel_centres)
        self._width = math.hypot(model.channel_kernel_width, contact_spread)
        self._floor = base * model.channel_floor
        self._peak = base * (1.0 - model.channel_floor)

    def __call__(self, locations: np.ndarray) -> np.ndarray:
        """Gains at ``locations`` (n, 2) [-] of the left and right finger.

        Returns
        -------
        numpy.ndarray, shape (n, 6)
            Gains [normalised/mm] in channel order (left distal .. right root).
        """
        z = np.subtract(locations[:, :, None], self._centres).reshape(len(locations), 6)
        z /= self._width
        z *= z
        np.negative(z, out=z)
        np.exp(z, out=z)
        z *= self._peak
        z += self._floor
        return z


def finger_force_elastic(model: GripperModel, deflection_mm: float, scale: float) -> float:
    """Relaxed (long-term) elastic force of a finger at a deflection [N]."""
    return scale * (model.finger_k1 * deflection_mm + model.finger_k3 * deflection_mm ** 3)


def solve_finger(model: GripperModel, penetration_mm: float, relax1: float, relax2: float,
                 scale: float, object_stiffness: float | None,
                 guess_mm: float) -> tuple[float, float, float]:
    """Deflection and normal force of a finger pressed against an object.

    The finger (nonlinear spring with two relaxation branches, standard-linear-solid style)
    is in series with the object's local contact stiffness; their deflections add up to the
    penetration given by the gripper geometry.

    Parameters
    ----------
    model : GripperModel
    penetration_mm : float
        Overlap between the undeformed finger and the undeformed object [mm].
    relax1, relax2 : float
        Relaxation states (lagging copies of the elastic force) [N].
    scale : float
        Finger stiffness multiplier for the contact location [-].
    object_stiffness : float or None
        Object contact stiffness [N/mm]; None = rigid.
    guess_mm : float
        Starting point of the Newton iteration (previous deflection) [mm].

    Returns
    -------
    deflection_mm : float
        Finger deflection [mm].
    force : float
        Normal force [N] (>= 0).
    stiffness : float
        d force / d penetration [N/mm].
    """
    if penetration_mm <= 0.0:
        return 0.0, 0.0, 0.0
    a1, a2 = model.relaxation_amplitudes
    gain = 1.0 + a1 + a2
    k1 = model.finger_k1 * scale
    k3 = model.finger_k3 * scale
    offset = a1 * relax1 + a2 * relax2
    if object_stiffness is None:
        d = penetration_mm
        force = gain * (k1 * d + k3 * d * d * d) - offset
        slope = gain * (k1 + 3.0 * k3 * d * d)
        if force <= 0.0:
            return d, 0.0, 0.0
        return d, force, slope
    d = min(max(guess_mm, 0.0), penetration_mm)
    for _ in range(8):
        force = gain * (k1 * d + k3 * d * d * d) - offset
        if force < 0.0:
            force = 0.0
            slope = 0.0
        else:
            slope = gain * (k1 + 3.0 * k3 * d * d)
        residual = d + force / object_stiffness - penetration_mm
        derivative = 1.0 + slope / object_stiffness
        step = residual / derivative
        d -= step
        if d < 0.0:
            d = 0.0
        if abs(step) < 1e-7:
            break
    force = gain * (k1 * d + k3 * d * d * d) - offset
    if force <= 0.0:
        return d, 0.0, 0.0
    slope = gain * (k1 + 3.0 * k3 * d * d)
    return d, force, slope / (1.0 + slope / object_stiffness)


def pressure_response(model: GripperModel, deflection_mm: np.ndarray) -> np.ndarray:
    """Channel pressure shape function of the finger deflection (concave) [mm-equivalent]."""
    return deflection_mm - model.pressure_curvature * deflection_mm * deflection_mm


def quantise(values: np.ndarray) -> np.ndarray:
    """Normalised 11-bit reading: round to 2/2048 steps and clip to the ADC range.

    Parameters
    ----------
    values : numpy.ndarray
        Analog values in normalised units.

    Returns
    -------
    numpy.ndarray
        Same shape, values in {-1, -1 + 2/2048, ..., 1 - 2/2048}.
    """
    codes = np.clip(np.rint(values / QUANTUM), -1024, 1023)
    return codes * QUANTUM


def resonator_coefficients(frequency: float, damping: float,
                           sample_rate: float = SAMPLE_RATE) -> tuple[np.ndarray, np.ndarray]:
    """Discrete 2nd-order low-pass resonator with unit DC gain (bilinear, prewarped).

    Parameters
    ----------
    frequency : float
        Natural frequency [Hz].
    damping : float
        Damping ratio [-].
    sample_rate : float
        [Hz].

    Returns
    -------
    b, a : numpy.ndarray
        Filter coefficients for scipy.signal.lfilter.
    """
    omega = 2.0 * sample_rate * math.tan(math.pi * frequency / sample_rate)
    k = 2.0 * sample_rate
    a0 = k * k + 2.0 * damping * omega * k + omega * omega
    a1 = 2.0 * omega * omega - 2.0 * k * k
    a2 = k * k - 2.0 * damping * omega * k + omega * omega
    b = np.array([omega * omega, 2.0 * omega * omega, omega * omega]) / a0
    a = np.array([1.0, a1 / a0, a2 / a0])
    return b, a
