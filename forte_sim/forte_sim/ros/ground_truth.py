"""``sim/ground_truth`` and ``load_cell/wrench`` messages from a scene's
:class:`~forte_sim.truth.SceneTruth`: the one conversion used by the sim node and the bench
twin node (ground truth: evaluation only; the load cell: the calibration rig's sensor)."""
from __future__ import annotations

from collections.abc import Callable, Iterator

from builtin_interfaces.msg import Time
from geometry_msgs.msg import WrenchStamped

from forte_msgs.msg import SimGroundTruth
from forte_ros import contract
from forte_sim.scene import Scene
from forte_sim.truth import SceneTruth


def ground_truth_message(truth: SceneTruth, scene: Scene, object_name: str, stamp: Time,
                         frame_id: str) -> SimGroundTruth:
    """The truth at the last sample of a chunk.

    Parameters
    ----------
    truth : SceneTruth
        Ground truth of the chunk :meth:`forte_sim.scene.Scene.step` returned.
    scene : Scene
        The scene it came from (name, trial).
    object_name : str
        Object (or indentor) name reported.
    stamp : builtin_interfaces.msg.Time
        Time of the chunk's last sample.
    frame_id : str
        Frame of the header.
    """
    latest = truth.latest()
    message = SimGroundTruth()
    message.header.stamp = stamp
    message.header.frame_id = frame_id
    message.scene = scene.name
    message.object_name = object_name
    message.trial = scene.trial
    message.finger_force = list(latest['finger_force'])
    message.load_cell_force = latest['load_cell_force']
    message.slip_type = latest['slip_type']
    message.slip_onsets = latest['slip_onsets']
    message.object_state = latest['object_state']
    message.lift_height = latest['lift_height']
    message.object_height = latest['object_height']
    message.object_slip = latest['object_slip']
    message.object_rotation = latest['object_rotation']
    return message


#: frame_id of ``load_cell/wrench`` (the squeeze along +z), without prefix.
LOAD_CELL_FRAME = contract.LOAD_CELL_FRAME


def load_cell_messages(truth: SceneTruth, step: int, stamp_ns: Callable[[int], int],
                       frame_id: str = LOAD_CELL_FRAME) -> Iterator[WrenchStamped]:
    """The calibration rig's load cell in a chunk: one message per sample whose index is a
    multiple of ``step``, stamped with that sample's time.

    Parameters
    ----------
    truth : SceneTruth
        Ground truth of the chunk (``first_index``, ``load_cell_force`` [N]).
    step : int
        Samples per message (20: 100 Hz at 2 kHz).
    stamp_ns : callable
        ``stamp_ns(sample_index)``: the time of a scene sample in the graph's clock [ns].
    frame_id : str
        Frame of the messages (default :data:`LOAD_CELL_FRAME`; the node passes it with its
        ``prefix``).

    Yields
    ------
    geometry_msgs.msg.WrenchStamped
        ``wrench.force.z`` = the squeeze [N], every other component 0, frame ``frame_id``.
    """
    first, force = truth.first_index, truth.load_cell_force
    for row in range(-first % step, len(force), step):
        message = WrenchStamped()
        sec, nanosec = contract.split_ns(stamp_ns(first + row))
        message.header.stamp = Time(sec=sec, nanosec=nanosec)
        message.header.frame_id = frame_id
        message.wrench.force.z = float(force[row])
        yield message
