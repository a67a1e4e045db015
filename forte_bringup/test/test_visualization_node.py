"""The visualization node with real rclpy: tactile and grasp states in, wrenches and markers out.

In process, on this test's own ROS domain (conftest): a listener publishes TactileState and
GraspState as perception and control do and receives the per-pad WrenchStamped messages
(force values, frames with a prefix, stamps) and the MarkerArray (arrows, slip highlight,
grasp-state text). The console script is run as a process with visualization_msgs and
without it (hidden by a failing package of that name first on PYTHONPATH): its publishers,
its one log line when markers are missing, its clean stop on SIGINT.
"""
from __future__ import annotations

import importlib.util
import os

import pytest

rclpy = pytest.importorskip('rclpy')

from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from forte_bringup.visualization_node import (  # noqa: E402
    MARKER_TOPIC,
    NO_MARKERS,
    OUTPUT_QOS,
    WRENCH_TOPICS,
    VisualizationNode,
)
from forte_msgs.msg import GraspState, TactileState  # noqa: E402
from forte_ros.qos import GRASP_STATE, TACTILE_STATE  # noqa: E402
from forte_ros.testing import NodeProcess, SpinningGraph, ros_args, wait_until  # noqa: E402

HAVE_MARKERS = importlib.util.find_spec('visualization_msgs') is not None


def tactile(force: float, valid: bool, contact: tuple[bool, bool], seconds: int,
            slip: bool = False) -> TactileState:
    message = TactileState(force=force, force_valid=valid, contact=list(contact), slip=slip,
                           slip_active=True)
    message.header.stamp.sec, message.header.stamp.nanosec = seconds, 500
    message.header.frame_id = 'right_forte_base_link'
    return message


@pytest.fixture
def graph():
    with SpinningGraph('visualization_test') as spinning:
        node = spinning.add(VisualizationNode(context=spinning.context, parameter_overrides=[
            Parameter('prefix', value='right_'), Parameter('max_rate', value=1000.0)]))
        received = [spinning.collect(WrenchStamped, topic, OUTPUT_QOS) for topic in WRENCH_TOPICS]
        markers = []
        if HAVE_MARKERS:
            from visualization_msgs.msg import MarkerArray
            markers = spinning.collect(MarkerArray, MARKER_TOPIC, OUTPUT_QOS)
        tactile_publisher = spinning.node.create_publisher(TactileState, 'tactile/state',
                                                           TACTILE_STATE)
        grasp_publisher = spinning.node.create_publisher(GraspState, 'grasp/state', GRASP_STATE)
        spinning.start()
        assert wait_until(lambda: tactile_publisher.get_subscription_count() >= 1
                          and all(node.count_subscribers(t) >= 1 for t in WRENCH_TOPICS), 10.0)
        yield SimpleGraph(node, received, markers, tactile_publisher, grasp_publisher)


class SimpleGraph:
    """The node, the two wrench lists (left, right), the marker arrays and the test's
    publishers."""

    def __init__(self, node, received, markers, tactile_publisher, grasp_publisher) -> None:
        self.node, self.received, self.markers = node, received, markers
        self.tactile_publisher, self.grasp_publisher = tactile_publisher, grasp_publisher

    def send(self, message: TactileState) -> tuple[WrenchStamped, WrenchStamped]:
        """Publish one tactile state; the wrenches it produced (left, right)."""
        counts = [len(messages) for messages in self.received]
        self.tactile_publisher.publish(message)
        assert wait_until(lambda: all(len(m) > c for m, c in zip(self.received, counts)), 10.0)
        return self.received[0][-1], self.received[1][-1]


def test_pad_wrenches_follow_the_tactile_state(graph):
    left, right = graph.send(tactile(2.5, True, (True, True), seconds=12))
    for wrench, frame in ((left, 'right_forte_left_pad'), (right, 'right_forte_right_pad')):
        assert wrench.header.frame_id == frame
        assert (wrench.header.stamp.sec, wrench.header.stamp.nanosec) == (12, 500)
        force, torque = wrench.wrench.force, wrench.wrench.torque
        assert (force.x, force.y, force.z) == (2.5, 0.0, 0.0)
        assert (torque.x, torque.y, torque.z) == (0.0, 0.0, 0.0)

    left, right = graph.send(tactile(1.25, True, (True, False), seconds=13))
    assert (left.wrench.force.x, right.wrench.force.x) == (1.25, 0.0)   # right: no contact

    left, right = graph.send(tactile(3.0, False, (True, True), seconds=14))
    assert (left.wrench.force.x, right.wrench.force.x) == (0.0, 0.0)    # invalid estimate

    left, right = graph.send(tactile(float('nan'), True, (True, True), seconds=15))
    assert (left.wrench.force.x, right.wrench.force.x) == (0.0, 0.0)    # NaN: no arrow


def test_grasp_state_and_slip_reach_the_view(graph):
    state = GraspState(state=GraspState.LIFTING, target_force=2.0, estimated_force=1.9,
                       force_valid=True, slip_events=2)
    graph.grasp_publisher.publish(state)
    assert wait_until(lambda: graph.node.view().label.text.startswith('LIFTING'), 10.0)
    graph.send(tactile(1.9, True, (True, True), seconds=20, slip=True))
    view = graph.node.view()
    assert view.label.text.startswith('LIFTING (FORTE)\nforce 1.90 N / target 2.00 N\nSLIP')
    assert [h.visible for h in view.highlights] == [True, True]
    assert view.label.frame == 'right_forte_base_link'


def test_parameters_have_descriptors_and_can_change(graph):
    node = graph.node
    (descriptor,) = node.describe_parameters(['arrow_scale'])
    assert descriptor.description.endswith('[m/N]')
    assert descriptor.floating_point_range[0].from_value > 0.0
    assert node.set_parameters([Parameter('arrow_scale', value=0.05)])[0].successful
    assert node.config.arrow_scale == 0.05
    assert not node.set_parameters([Parameter('prefix', value='left_')])[0].successful
    assert not node.set_parameters([Parameter('slip_hold', value=-1.0)])[0].successful
    assert node.markers_enabled == HAVE_MARKERS


@pytest.mark.skipif(not HAVE_MARKERS, reason='visualization_msgs is not installed')
def test_markers_show_force_slip_and_grasp_state(graph):
    from visualization_msgs.msg import Marker

    arrays = graph.markers
    assert wait_until(lambda: graph.node.count_subscribers(MARKER_TOPIC) >= 1, 10.0)
    graph.grasp_publisher.publish(GraspState(state=GraspState.HOLDING, slip_events=1))
    graph.send(tactile(2.0, True, (True, False), seconds=30, slip=True))
    assert wait_until(lambda: arrays and arrays[-1].markers[-1].text.startswith('HOLDING')
                      and arrays[-1].markers[0].action == Marker.ADD, 10.0)
    markers = {(m.ns, m.id): m for m in arrays[-1].markers}
    assert set(markers) == {('force', 0), ('force', 1), ('slip', 0), ('slip', 1),
                            ('grasp_state', 0)}
    left = markers[('force', 0)]
    assert left.type == Marker.ARROW and left.header.frame_id == 'right_forte_left_pad'
    assert left.points[1].x == pytest.approx(2.0 * graph.node.config.arrow_scale)
    assert markers[('force', 1)].action == Marker.DELETE        # right finger: no contact
    assert markers[('slip', 0)].action == Marker.ADD and markers[('slip', 1)].action == \
        Marker.DELETE
    text = markers[('grasp_state', 0)]
    assert text.type == Marker.TEXT_VIEW_FACING and 'SLIP  events 1' in text.text
    assert text.header.frame_id == 'right_forte_base_link'


@pytest.mark.parametrize('hide_markers', [True, False])
def test_the_executable_starts_says_what_it_publishes_and_stops_cleanly(tmp_path, hide_markers):
    """Without visualization_msgs (hidden here by a package of that name that fails to
    import, first on PYTHONPATH) the node logs the one line and publishes wrenches only."""
    if not hide_markers and not HAVE_MARKERS:
        pytest.skip('visualization_msgs is not installed')
    env = {}
    if hide_markers:
        shadow = tmp_path / 'visualization_msgs'
        shadow.mkdir()
        (shadow / '__init__.py').write_text("raise ImportError('hidden by the test')\n")
        env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(tmp_path),
                                                          os.environ.get('PYTHONPATH')]))
    with NodeProcess(['forte_visualization', *ros_args(prefix='left_')], env=env) as process:
        with SpinningGraph('visualization_probe') as probe:
            probe.start()
            assert wait_until(lambda: probe.node.count_publishers(WRENCH_TOPICS[1]) >= 1, 30.0)
            # the marker publisher is created with the wrench publishers, before start-up ends
            wait_until(lambda: probe.node.count_publishers(MARKER_TOPIC) >= 1, 3.0)
            markers = probe.node.count_publishers(MARKER_TOPIC)
        assert markers == (0 if hide_markers else 1), process.output
        process.stop_cleanly()
        assert process.output.count(NO_MARKERS) == (1 if hide_markers else 0), process.output
