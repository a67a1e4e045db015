"""The sensor contract of docs/contracts.md, declared once for every package.

Pure Python (no rclpy): the pure cores, the simulator, the bench devices, the offline tools
and the nodes all import these names instead of writing them again.

Channels are in contract order: index ``c`` of every ``(n, 6)`` frame array, every
``TactileFrames.data`` row and every per-channel field is :data:`CHANNEL_NAMES` ``[c]``.
"""
from __future__ import annotations

import re

#: The six differential pressure channels, in contract order (docs/contracts.md).
CHANNEL_NAMES = ('left_distal', 'left_middle', 'left_root',
                 'right_distal', 'right_middle', 'right_root')
#: Number of channels.
N_CHANNELS = len(CHANNEL_NAMES)
#: Fingers, in contract order (finger index 0 = left, 1 = right).
FINGER_NAMES = ('left', 'right')
#: Channel indices of each finger: ``FINGER_CHANNELS[finger]`` = (distal, middle, root).
FINGER_CHANNELS = ((0, 1, 2), (3, 4, 5))
#: Position of a channel on its finger, the index inside a :data:`FINGER_CHANNELS` entry.
DISTAL, MIDDLE, ROOT = 0, 1, 2

#: Sampling rate of the sensor [Hz] and its period [s].
SAMPLE_RATE = 2000.0
SAMPLE_PERIOD = 1.0 / SAMPLE_RATE

#: Reading scale of the sensor board: 1024 counts = 1.0 normalised = +1 inH2O; readings are
#: clipped to +-1024 counts (docs/firmware.md).
COUNTS_PER_FULL_SCALE = 1024
#: Inclusive range of a normalised reading (the transducer's span, +-1 inH2O).
VALUE_RANGE = (-1.0, 1.0)
#: Quantisation step of the normalised 11-bit reading: 2048 levels over -1..1 [normalised].
QUANTUM = (VALUE_RANGE[1] - VALUE_RANGE[0]) / 2048.0

#: TF frames of the gripper (docs/contracts.md, "Frames (TF) and frame_id"), base names: a
#: graph's ``prefix`` (launch argument / node parameter) is prepended to each (:func:`prefixed`).
BASE_FRAME = 'forte_base_link'
FINGER_FRAMES = ('forte_left_finger', 'forte_right_finger')
PAD_FRAMES = ('forte_left_pad', 'forte_right_pad')
#: Frame of the calibration rig's load cell (``load_cell/wrench``, simulated rig).
LOAD_CELL_FRAME = 'forte_load_cell'
#: Finger joints of ``joint_states``, in JointState order (left, right): position = theta
#: of that finger's servo [rad].
LEFT_FINGER_JOINT = 'forte_left_finger_joint'
RIGHT_FINGER_JOINT = 'forte_right_finger_joint'
JOINT_NAMES = (LEFT_FINGER_JOINT, RIGHT_FINGER_JOINT)

#: Torque constant of the XM430-W350 finger servos [N m / A]: the stall torque over the stall
#: current at 12 V, 4.1 N m / 2.3 A (ROBOTIS e-manual, DYNAMIXEL X series table; 11.1 V:
#: 3.8 / 2.1 = 1.81, 14.8 V: 4.8 / 2.7 = 1.78). Each finger joint is its servo's horn angle
#: (1:1), so joint torque = servo output torque. A linear model through zero: it ignores the
#: no-load (friction) current and the torque-current nonlinearity near stall (the e-manual's
#: performance graph is a line of about the same slope offset by roughly -0.2 N m, so at
#: small currents the estimate is high by up to ~0.2 N m); good for caps and for comparing
#: loads, not a torque sensor.
SERVO_TORQUE_CONSTANT = 4.1 / 2.3


def current_to_effort(current: float) -> float:
    """Joint effort [N m] of a servo current [A] (:data:`SERVO_TORQUE_CONSTANT`, linear).

    The sign is kept: ``joint_states`` reports both along theta (positive = opening), so a
    finger squeezing an object has a negative current and a negative effort.
    """
    return float(current) * SERVO_TORQUE_CONSTANT


def effort_to_current(effort: float) -> float:
    """Servo current [A] of a joint effort [N m]: the inverse of :func:`current_to_effort`
    (sign kept; a current cap is its magnitude)."""
    return float(effort) / SERVO_TORQUE_CONSTANT


def stamp_ns(stamp) -> int:
    """A ``builtin_interfaces/Time`` (anything with ``sec`` and ``nanosec``) in integer
    nanoseconds: the time unit of the contract's stamps, without float rounding."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def split_ns(nanoseconds: int) -> tuple[int, int]:
    """Integer nanoseconds as the ``(sec, nanosec)`` fields of a ``builtin_interfaces/Time``
    (``0 <= nanosec < 1e9``; a time before the epoch has a negative ``sec``): the inverse of
    :func:`stamp_ns`."""
    sec, nanosec = divmod(int(nanoseconds), 1_000_000_000)
    return sec, nanosec


def stamp_seconds(stamp) -> float:
    """The same stamp in float seconds (``sec + 1e-9 nanosec``): for plots and time axes,
    where a step of 256 ns at 1.8e9 s does not matter."""
    return stamp.sec + 1e-9 * stamp.nanosec


def prefixed(name: str, prefix: str = '') -> str:
    """``name`` (a frame or joint base name) with the TF / joint-name ``prefix`` prepended.

    Parameters
    ----------
    name : str
        Base name, e.g. :data:`BASE_FRAME`; an empty name stays empty (no frame).
    prefix : str
        Prefix of one gripper's frames and joints, e.g. ``'right_'`` ('' = none). Written
        as given: ``prefixed('forte_base_link', 'right_')`` is ``'right_forte_base_link'``.

    Returns
    -------
    str
        ``prefix + name``.
    """
    return prefix + name if name else name


#: A token of a ROS namespace: letters, digits, underscores, not starting with a digit.
_NAMESPACE_TOKEN = re.compile(r'[A-Za-z_][A-Za-z0-9_]*')
#: A TF / joint-name prefix: letters, digits, underscores, inner slashes (e.g. ``gripper2/``).
_PREFIX = re.compile(r'[A-Za-z0-9_][A-Za-z0-9_/]*')


def graph_namespace(text: str) -> str:
    """The ``namespace`` argument as an absolute ROS namespace.

    Parameters
    ----------
    text : str
        ``''`` (root), ``right``, ``/right``, ``/robots/right/``, ...

    Returns
    -------
    str
        ``''`` for the root namespace, else ``/token[/token...]`` (no trailing slash).

    Raises
    ------
    ValueError
        If a token is not a valid ROS name (letters, digits, underscores; not starting
        with a digit; no empty token inside).
    """
    stripped = text.strip().strip('/')
    if not stripped:
        return ''
    tokens = stripped.split('/')
    bad = [token for token in tokens if not _NAMESPACE_TOKEN.fullmatch(token)]
    if bad:
        raise ValueError(f'namespace {text!r}: {bad[0]!r} is not a valid ROS name (letters, '
                         'digits and underscores, not starting with a digit)')
    return '/' + '/'.join(tokens)


def check_prefix(prefix: str) -> str:
    """The TF / joint-name ``prefix`` of a gripper (a graph's ``prefix`` argument), checked.

    Returns
    -------
    str
        ``prefix``, unchanged.

    Raises
    ------
    ValueError
        If it is not empty and not letters, digits, underscores and inner slashes.
    """
    if prefix and not _PREFIX.fullmatch(prefix):
        raise ValueError(f'prefix {prefix!r}: expected letters, digits, underscores (e.g. '
                         'right_), not starting with a slash')
    return prefix


def joint_names(prefix: str = '') -> tuple[str, str]:
    """The finger joints of ``joint_states`` (:data:`JOINT_NAMES`) with ``prefix``."""
    return tuple(prefixed(name, prefix) for name in JOINT_NAMES)


__all__ = ['BASE_FRAME', 'CHANNEL_NAMES', 'COUNTS_PER_FULL_SCALE', 'DISTAL', 'FINGER_CHANNELS',
           'FINGER_FRAMES', 'FINGER_NAMES', 'JOINT_NAMES', 'LEFT_FINGER_JOINT',
           'LOAD_CELL_FRAME', 'MIDDLE', 'N_CHANNELS', 'PAD_FRAMES', 'QUANTUM',
           'RIGHT_FINGER_JOINT', 'ROOT', 'SAMPLE_PERIOD', 'SAMPLE_RATE', 'SERVO_TORQUE_CONSTANT',
           'VALUE_RANGE', 'check_prefix', 'current_to_effort', 'effort_to_current',
           'graph_namespace', 'joint_names', 'prefixed']
