"""A stand-in for an arm's bringup (not a test module): what a UR or Franka bringup owns.

Run as ``python stand_in_arm.py <prefix>``: one process, two nodes in the root namespace, as
an arm's bringup names them:

- ``/robot_state_publisher``: ``/robot_description`` (std_msgs/String, reliable + transient
  local) holding a two-link arm whose ``tool0`` carries FORTE (forte_description's macro
  with ``<prefix>``). Not its TF: tf2_msgs has no wheel here; the test checks that FORTE
  publishes none;
- ``/joint_state_broadcaster``: ``/joint_states`` of the arm's two joints (10 Hz).

``python stand_in_arm.py --as-robot-state-publisher --ros-args ...`` stands in for
robot_state_publisher itself where it is not installed (test_launch_beside_arm.py registers
it in an ament prefix of its own): a node named as the launch names it, publishing its
``robot_description`` parameter on ``robot_description`` (reliable + transient local).

Used by test_launch_beside_arm.py; the folder of the test files is on ``sys.path``.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from forte_bringup.robot_model import MACRO_XACRO, urdf_folder

ARM_JOINTS = ('shoulder_joint', 'elbow_joint')
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def arm_urdf(prefix: str) -> str:
    """The stand-in arm's URDF with FORTE on ``tool0`` (the macro, ``prefix``)."""
    import xacro

    text = f'''<?xml version="1.0"?>
<robot name="stand_in_arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="{urdf_folder() / MACRO_XACRO}"/>
  <link name="base_link"/>
  <link name="upper_arm"/>
  <link name="forearm"/>
  <link name="tool0"/>
  <joint name="shoulder_joint" type="revolute">
    <parent link="base_link"/><child link="upper_arm"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="2"/>
  </joint>
  <joint name="elbow_joint" type="revolute">
    <parent link="upper_arm"/><child link="forearm"/><origin xyz="0 0 0.4"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="2"/>
  </joint>
  <joint name="tool0_joint" type="fixed">
    <parent link="forearm"/><child link="tool0"/><origin xyz="0 0 0.3"/>
  </joint>
  <xacro:forte_gripper prefix="{prefix}" parent="tool0"/>
</robot>
'''
    with tempfile.NamedTemporaryFile('w', suffix='.urdf.xacro', delete=False) as handle:
        handle.write(text)
    try:
        return xacro.process_file(handle.name).toprettyxml(indent='  ')
    finally:
        Path(handle.name).unlink()


def robot_state_publisher() -> None:
    """The stand-in robot_state_publisher (its node name and namespace from --ros-args)."""
    rclpy.init(args=sys.argv)
    node = Node('robot_state_publisher')
    node.declare_parameter('robot_description', '')
    description = node.create_publisher(String, 'robot_description', LATCHED)
    description.publish(String(data=node.get_parameter('robot_description').value))
    _spin([node])


def _spin(nodes: list[Node]) -> None:
    executor = SingleThreadedExecutor()
    for node in nodes:
        executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()


def main() -> None:
    if '--as-robot-state-publisher' in sys.argv:
        robot_state_publisher()
        return
    prefix = sys.argv[1] if len(sys.argv) > 1 else ''
    rclpy.init()
    state_publisher = Node('robot_state_publisher')
    broadcaster = Node('joint_state_broadcaster')
    description = state_publisher.create_publisher(String, '/robot_description', LATCHED)
    description.publish(String(data=arm_urdf(prefix)))
    joints = broadcaster.create_publisher(JointState, '/joint_states', 10)

    def tick() -> None:
        message = JointState(name=list(ARM_JOINTS), position=[0.0, 0.0])
        message.header.stamp = broadcaster.get_clock().now().to_msg()
        joints.publish(message)

    broadcaster.create_timer(0.1, tick)
    _spin([state_publisher, broadcaster])


if __name__ == '__main__':
    main()
