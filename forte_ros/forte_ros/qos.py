"""The QoS profiles of docs/contracts.md ("Topics, services, actions"), defined once.

Every FORTE publisher and subscriber on a contract topic takes its profile from here, so a
change to the contract is a change to this file and the table, nothing else.

- :data:`SENSOR_FRAMES`: ``tactile/frames`` by default; best effort, volatile, keep last 50.
- :data:`RELIABLE_FRAMES`: ``tactile/frames`` from a driver with ``reliable:=true``;
  reliable, volatile, keep last 50.
- :data:`TACTILE_STATE`: ``tactile/state``; reliable, keep last 50.
- :data:`COMMANDS`: ``gripper/command``, ``joint_states``, ``arm/cmd_vel``; reliable, keep
  last 10.
- :data:`GRASP_STATE`: ``grasp/state``; reliable, transient local, keep last 1.
- :data:`SENSOR_INFO`: ``tactile/sensor_info``; reliable, transient local, keep last 1.
- :data:`LOAD_CELL`: ``load_cell/wrench``; reliable, keep last 5000.
- :data:`GROUND_TRUTH`: ``sim/ground_truth``; reliable, keep last 50.
- :data:`DIAGNOSTICS`: ``/diagnostics``; reliable, keep last 10.

:func:`reliable` is for the few places that need a deeper reliable queue than the contract's
(a bag replayed faster than real time, a recorder, a benchmark's probe).
"""
from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['COMMANDS', 'DIAGNOSTICS', 'GRASP_STATE', 'GROUND_TRUTH', 'LOAD_CELL',
           'RELIABLE_FRAMES', 'SENSOR_FRAMES', 'SENSOR_INFO', 'TACTILE_STATE', 'frames_profile',
           'reliable']


def reliable(depth: int, transient_local: bool = False) -> QoSProfile:
    """A reliable keep-last profile.

    Parameters
    ----------
    depth : int
        History depth [messages], >= 1.
    transient_local : bool
        Keep the last ``depth`` messages for late-joining subscribers.

    Returns
    -------
    rclpy.qos.QoSProfile
    """
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if transient_local
                    else DurabilityPolicy.VOLATILE))


#: ``tactile/frames`` by default: sensor data, a late batch is worth less than the next one.
SENSOR_FRAMES = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=50,
                           reliability=ReliabilityPolicy.BEST_EFFORT,
                           durability=DurabilityPolicy.VOLATILE)
#: ``tactile/frames`` from a driver with ``reliable:=true`` (recording).
RELIABLE_FRAMES = reliable(50)
#: ``tactile/state``.
TACTILE_STATE = reliable(50)
#: ``gripper/command``, ``joint_states``, ``arm/cmd_vel``.
COMMANDS = reliable(10)
#: ``grasp/state``: the latest state for anyone who joins late.
GRASP_STATE = reliable(1, transient_local=True)
#: ``tactile/sensor_info``: the sensor's identity, latched for late subscribers.
SENSOR_INFO = reliable(1, transient_local=True)
#: ``load_cell/wrench``: the calibration rig's load cell, 50 s at 100 Hz queued (a fast
#: simulation must not overwrite samples the procedure has not read).
LOAD_CELL = reliable(5000)
#: ``sim/ground_truth``.
GROUND_TRUTH = reliable(50)
#: ``/diagnostics``.
DIAGNOSTICS = reliable(10)


def frames_profile(reliable_frames: bool) -> QoSProfile:
    """The ``tactile/frames`` profile of a driver's ``reliable`` parameter."""
    return RELIABLE_FRAMES if reliable_frames else SENSOR_FRAMES
