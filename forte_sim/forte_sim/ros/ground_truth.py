"""``sim/ground_truth`` messages from a scene's :class:`~forte_sim.truth.SceneTruth`: the one
conversion used by the sim node and the bench twin node (evaluation only)."""
from __future__ import annotations

from builtin_interfaces.msg import Time

from forte_msgs.msg import SimGroundTruth
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
