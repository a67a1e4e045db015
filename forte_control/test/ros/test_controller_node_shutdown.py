"""grasp_controller_node, as its real executable, stops cleanly on SIGINT and SIGTERM, also
in the middle of a grasp: the running goal is ended (arm stopped, grip held) before its
executor is stopped, the process exits with code 0 within a few seconds and prints no
traceback."""
from __future__ import annotations

import signal

import pytest
from geometry_msgs.msg import TwistStamped
from rclpy.action import ActionClient
from sensor_msgs.msg import JointState

from forte_msgs.action import Grasp
from forte_msgs.msg import GraspState
from forte_ros import call_in_executor
from forte_ros.qos import COMMANDS, GRASP_STATE
from forte_ros.testing import NodeProcess, Probe, wait_until

STATUS_ABORTED = 6  # action_msgs/msg/GoalStatus (not a declared dependency of forte_control)
CONTROLLER = 'grasp_controller_node'  # found as ros2 run finds it (forte_ros.testing)


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_idle_controller_stops_cleanly(signum):
    with Probe('controller_shutdown_probe') as probe:
        probe.count(GraspState, 'grasp/state', GRASP_STATE)
        with NodeProcess([CONTROLLER]) as process:
            assert wait_until(lambda: probe.counts['grasp/state'] >= 5, 40.0), process.output
            process.stop_cleanly(signum)


def test_a_running_grasp_is_ended_before_the_process_exits():
    with Probe('controller_grasp_probe') as probe:
        joints = probe.node.create_publisher(JointState, 'joint_states', COMMANDS)

        def publish_joints() -> None:  # an open gripper that never closes: CLOSING lasts
            message = JointState(name=['forte_left_finger_joint', 'forte_right_finger_joint'],
                                 position=[0.6, 0.6])
            message.header.stamp = probe.node.get_clock().now().to_msg()
            joints.publish(message)

        probe.node.create_timer(0.02, publish_joints)
        arm: list[float] = []
        probe.node.create_subscription(TwistStamped, 'arm/cmd_vel',
                                       lambda m: arm.append(m.twist.linear.z), COMMANDS)
        client = ActionClient(probe.node, Grasp, 'grasp')
        feedback: list = []
        with NodeProcess([CONTROLLER]) as process:
            assert client.wait_for_server(timeout_sec=40.0), process.output
            goal = Grasp.Goal(controller=Grasp.Goal.ON_OFF, timeout=60.0)
            sent = call_in_executor(probe.executor, client.send_goal_async, goal,
                                    feedback.append)
            assert wait_until(sent.done, 20.0)
            handle = sent.result()
            assert handle.accepted, process.output
            result = call_in_executor(probe.executor, handle.get_result_async)
            assert wait_until(lambda: len(feedback) >= 3, 20.0), process.output
            process.stop_cleanly(signal.SIGINT)
            assert wait_until(result.done, 5.0), 'the goal got no result'
        assert result.result().status == STATUS_ABORTED
        assert result.result().result.outcome == Grasp.Result.CANCELED
        assert arm and arm[-1] == 0.0, 'the arm was not stopped'
        client.destroy()
