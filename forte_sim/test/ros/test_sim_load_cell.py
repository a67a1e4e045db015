"""sim_node's load cell (calibration scene): ``load_cell/wrench`` once every
``load_cell_decimation`` samples, stamped with the sample time it reports, the scene's
load-cell force on +z; none in the other scenes."""
from __future__ import annotations

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.parameter import Parameter

from forte_msgs.msg import TactileFrames
from forte_ros.qos import reliable
from forte_ros.testing import SpinningGraph, wait_until
from forte_sim import make_scene
from forte_sim.ros.ground_truth import LOAD_CELL_FRAME
from forte_sim.ros.sim_node import SimNode


def run_sim(samples: int, **parameters) -> tuple[list, list]:
    """Frames and load-cell messages of a sim node until ``samples`` samples came."""
    graph = SpinningGraph('load_cell_peer')
    overrides = [Parameter(name, value=value) for name, value in parameters.items()]
    try:
        graph.add(SimNode(context=graph.context, parameter_overrides=overrides))
        frames = graph.collect(TactileFrames, 'tactile/frames', reliable(5000))
        load = graph.collect(WrenchStamped, 'load_cell/wrench', reliable(5000))
        graph.start()
        assert wait_until(lambda: sum(m.sample_count for m in frames) >= samples, 60.0)
        return list(frames), list(load)
    finally:
        graph.close()


def stamp_ns(message) -> int:
    return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec


@pytest.mark.parametrize('decimation', [20, 50])
def test_the_load_cell_comes_at_its_sample_times_with_the_scene_s_force(decimation):
    frames, load = run_sim(4000, scene='calibration', object='sphere', seed=5, trial=2,
                           reliable=True, batch_size=20, real_time_factor=0.0,
                           load_cell_decimation=decimation)
    assert frames[0].first_sequence == 0
    origin = stamp_ns(frames[0])
    indices = [(stamp_ns(message) - origin) / 500_000 for message in load]
    count = len(indices)
    assert count >= 4000 // decimation - 2
    np.testing.assert_allclose(indices, np.arange(count) * decimation, atol=1e-3)
    assert all(message.header.frame_id == LOAD_CELL_FRAME for message in load)
    assert all(message.wrench.force.x == message.wrench.force.y == 0.0 for message in load)
    # the same scene stepped offline with the same (no) commands: the same load cell
    scene = make_scene('calibration', indentor='sphere', seed=5, trial=2)
    _, truth = scene.step(count * decimation, scene.initial_angle, 0.0)
    np.testing.assert_array_equal([message.wrench.force.z for message in load],
                                  truth.load_cell_force[::decimation][:count])


def test_no_load_cell_outside_the_calibration_scene():
    frames, load = run_sim(1000, scene='grasp', object='apple', reliable=True,
                           real_time_factor=0.0)
    assert frames and not load
