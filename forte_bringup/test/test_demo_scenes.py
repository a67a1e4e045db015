"""The demo's nine scenes in the closed loop (no ROS): the pattern the demo test demands of
the full graph (demo_scenes.EXPECTED), so that the graph and ``run_trial`` agree."""
from __future__ import annotations

import pytest
from demo_scenes import EXPECTED, closed_loop_results, mismatches

from forte_evaluation.sim_force_model import default_force_model

pytestmark = pytest.mark.slow  # nine closed-loop grasps and, the first time, the model


@pytest.fixture(scope='module')
def model():
    return default_force_model()


def test_the_demo_scenes_end_as_the_physics_says(model):
    """The closed loop on the demo's nine scenes gives the pattern the demo test demands of
    the full ROS graph (demo_scenes.EXPECTED): the graph and run_trial agree."""
    results = closed_loop_results(model)
    assert set(results) == set(EXPECTED)
    assert not mismatches(results), mismatches(results)
