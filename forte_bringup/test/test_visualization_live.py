"""The running sim graph has what the shipped views show, and the robot model fits it.

The sim graph is brought up as ``forte_bringup sim`` does (:class:`Bringup`, its
visualization node and, where installed, robot_state_publisher included); a probe in the
test process then checks, over DDS:

- every topic named in ``rviz/forte.rviz`` and ``plotjuggler/forte.xml`` (read with the
  parsers of ``view_files.py``, which ``test_visualization_files.py`` checks offline) is in
  the running graph, with the message type the view expects;
- the topics only robot_state_publisher publishes (:data:`ROBOT_STATE_PUBLISHER_TOPICS`:
  ``/robot_description``, RViz's RobotModel; ``/tf`` and ``/tf_static``, RViz's TF display)
  are required where it runs, and absent where it is not installed; then the graph printed
  :data:`ROBOT_STATE_PUBLISHER_MISSING` once and came up all the same;
- the live ``joint_states`` name exactly the non-fixed joints of the expanded URDF, so the
  TF tree robot_state_publisher makes from them is complete from the gripper's root link
  (RViz's fixed frame) to both pads: every movable joint on the way is published. Where
  robot_state_publisher runs, ``/tf`` and ``/tf_static`` also carry every joint on the way.

The URDF's own structure (one root, every link reachable, the pads below the parent link,
the movable joints the drivers' names) is ``test_gripper_urdf_macro.py``'s.
"""
from __future__ import annotations

import io
import time
from pathlib import Path

import pytest
from geometry_msgs.msg import WrenchStamped
from test_gripper_urdf_macro import Tree
from view_files import (
    ROBOT_STATE_PUBLISHER_TOPICS,
    load_layout,
    load_rviz,
    plotjuggler_topics,
    rviz_topics,
)

from forte_bringup.bringup import Bringup
from forte_bringup.robot_model import (
    ROBOT_STATE_PUBLISHER_MISSING,
    expand_gripper,
    robot_state_publisher_available,
)
from forte_bringup.testing import force_model_file, watching
from forte_bringup.visualization_node import WRENCH_TOPICS
from forte_ros import contract
from forte_ros.testing import wait_until

#: Longest wait for the graph and for each expectation [s] (2 shared cores).
UP = 90.0
WAIT = 60.0


def view_topics() -> dict[str, str]:
    """Absolute topic -> message type of every topic the RViz config and the PlotJuggler
    layout subscribe to."""
    topics = {name: message_type for name, (message_type, _)
              in rviz_topics(load_rviz()).items()}
    for name, message_type in plotjuggler_topics(load_layout()).items():
        assert topics.setdefault(name, message_type) == message_type, name
    return topics


def pad_chains(tree: Tree) -> dict[str, list[str]]:
    """Pad link -> the joints from the root down to it (names, root first)."""
    chains = {}
    for pad in contract.PAD_FRAMES:
        joints, link = [], pad
        while link in tree.parent_joint:
            joint = tree.parent_joint[link]
            joints.insert(0, joint.get('name'))
            link = joint.find('parent').get('link')
        assert link == contract.BASE_FRAME, (pad, link)  # the gripper's root: RViz's frame
        chains[pad] = joints
    return chains


def test_the_views_name_topics_of_the_running_graph_and_the_rsp_ones_are_known():
    """Offline half (no graph): what the live test below requires."""
    topics = view_topics()
    assert {'/tactile/frames', '/tactile/state', '/grasp/state', '/gripper/command',
            '/visualization/left_pad_wrench', '/visualization/markers',
            '/robot_description'} <= set(topics)
    # robot_description is the only view topic of robot_state_publisher (TF has no topic
    # field in the RViz config; the TF display reads /tf and /tf_static)
    assert set(topics) & set(ROBOT_STATE_PUBLISHER_TOPICS) == {'/robot_description'}
    chains = pad_chains(Tree(expand_gripper('')))
    assert all(chain for chain in chains.values())


class _TfCollector:
    """Child frame -> parent frame of every transform on ``/tf`` and ``/tf_static``."""

    def __init__(self, node) -> None:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from tf2_msgs.msg import TFMessage  # installed wherever robot_state_publisher is

        self.parents: dict[str, str] = {}
        latched = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(TFMessage, '/tf', self._on_tf, 100)
        node.create_subscription(TFMessage, '/tf_static', self._on_tf, latched)

    def _on_tf(self, message) -> None:
        for transform in message.transforms:
            self.parents[transform.child_frame_id] = transform.header.frame_id


@pytest.mark.slow
def test_the_running_sim_graph_has_every_view_topic_and_the_urdf_joints(tmp_path: Path):
    running = robot_state_publisher_available()
    expected = view_topics()
    required = {name: kind for name, kind in expected.items()
                if name not in ROBOT_STATE_PUBLISHER_TOPICS}
    if running:  # required only where robot_state_publisher runs
        required.update(ROBOT_STATE_PUBLISHER_TOPICS)
    tree = Tree(expand_gripper(''))
    chains = pad_chains(tree)
    echo = io.StringIO()
    bringup = Bringup('sim', {'object': 'raspberry', 'real_time_factor': '1.0',
                              'force_model': str(force_model_file(tmp_path / 'model.npz'))},
                      log_dir=tmp_path / 'logs', echo=echo)
    assert 'visualization' in bringup.commands()
    with watching() as probe:
        tf = _TfCollector(probe) if running else None
        wrenches = []
        probe.create_subscription(WrenchStamped, WRENCH_TOPICS[0], wrenches.append, 10)
        bringup.start(timeout=UP)
        try:
            def graph_topics() -> dict[str, list[str]]:
                return dict(probe.get_topic_names_and_types())

            assert wait_until(lambda: set(required) <= set(graph_topics()), WAIT), \
                sorted(set(required) - set(graph_topics()))
            topics = graph_topics()
            for name, kind in required.items():
                assert topics[name] == [kind], (name, topics[name], kind)
            # the pad wrenches flow (not only advertised): the graph's tactile states reach
            # the visualization node
            assert wait_until(lambda: len(wrenches) > 5, WAIT), (len(wrenches), probe.counts)
            assert wrenches[-1].header.frame_id == contract.PAD_FRAMES[0]
            if not running:
                assert not set(ROBOT_STATE_PUBLISHER_TOPICS) & set(topics), sorted(topics)
                lines = [line for line in echo.getvalue().splitlines()
                         if ROBOT_STATE_PUBLISHER_MISSING in line]
                assert lines == [f'[forte_bringup] {ROBOT_STATE_PUBLISHER_MISSING}'], lines
            # the joints of the live joint_states are the URDF's movable joints
            assert wait_until(lambda: probe.counts['joint_states'] > 5, WAIT), probe.counts
            time.sleep(0.2)
            assert len(probe.joint_names) == len(set(probe.joint_names))
            assert set(probe.joint_names) == tree.movable, (probe.joint_names, tree.movable)
            for pad, joints in chains.items():  # complete from the root to each pad
                assert {j for j in joints if j in tree.movable} <= set(probe.joint_names), pad
            if running:
                for pad, joints in chains.items():
                    links = [tree.joints[j].find('child').get('link') for j in joints]
                    assert wait_until(lambda links=links: set(links) <= set(tf.parents), WAIT), (
                        pad, tf.parents)
                    for joint, link in zip(joints, links, strict=True):
                        assert tf.parents[link] == tree.joints[joint].find(
                            'parent').get('link'), (joint, tf.parents[link])
            bringup.check_children()
        finally:
            codes = bringup.stop()
    assert 'visualization' in codes
    assert ('robot_state_publisher' in codes) == running
