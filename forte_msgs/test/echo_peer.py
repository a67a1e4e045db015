"""A peer process for the forte_msgs tests: echoes every message type, serves action and services.

Run as a script (``python echo_peer.py``) by the tests, so that messages cross a real process
boundary over DDS. For every message type ``T`` in :data:`MESSAGE_TYPES` it subscribes to
``echo_in/T`` and republishes the received message unchanged on ``echo_out/T``. It serves
the ``grasp`` action (two feedback messages, then a result derived from the goal), the
``perception/tare`` and ``grasp/reset_fault`` services, and answers cancel requests.
It exits when its standard input closes (the test ending) or on SIGTERM.
"""
from __future__ import annotations

import sys
import threading
import time

import rclpy
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from forte_msgs.action import Grasp
from forte_msgs.msg import (
    GraspState,
    SensorInfo,
    ServoCommand,
    SimGroundTruth,
    TactileFrames,
    TactileState,
)
from forte_msgs.srv import ResetFault, Tare

MESSAGE_TYPES = (TactileFrames, TactileState, ServoCommand, GraspState, SimGroundTruth,
                 SensorInfo)
RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


class EchoPeer(Node):
    """Echo node: republishes every forte_msgs message and serves the action and services."""

    def __init__(self) -> None:
        super().__init__('forte_msgs_echo_peer')
        group = ReentrantCallbackGroup()
        self._echo_publishers = {}
        for message_type in MESSAGE_TYPES:
            name = message_type.__name__
            publisher = self.create_publisher(message_type, f'echo_out/{name}', RELIABLE)
            self._echo_publishers[name] = publisher
            self.create_subscription(
                message_type, f'echo_in/{name}', publisher.publish, RELIABLE, callback_group=group)
        self.create_service(Tare, 'perception/tare', self._on_tare, callback_group=group)
        self.create_service(
            ResetFault, 'grasp/reset_fault', self._on_reset_fault, callback_group=group)
        self._action_server = ActionServer(
            self, Grasp, 'grasp', self._execute,
            goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=group)

    def _on_tare(self, request: Tare.Request, response: Tare.Response) -> Tare.Response:
        response.success = request.duration > 0.0
        response.message = 'ok' if response.success else 'duration must be positive'
        response.baseline = [request.duration * (channel + 1) for channel in range(6)]
        return response

    def _on_reset_fault(self, _request, response: ResetFault.Response) -> ResetFault.Response:
        response.success = True
        response.cleared_flags = GraspState.FAULT_STALE_PERCEPTION | GraspState.FAULT_FORCE_LIMIT
        response.message = 'cleared'
        return response

    def _on_goal(self, goal: Grasp.Goal) -> GoalResponse:
        valid = goal.controller in (Grasp.Goal.FORTE, Grasp.Goal.NO_SLIP, Grasp.Goal.ON_OFF)
        return GoalResponse.ACCEPT if valid else GoalResponse.REJECT

    def _execute(self, goal_handle) -> Grasp.Result:
        goal: Grasp.Goal = goal_handle.request
        result = Grasp.Result()
        for step in range(40):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                result.outcome = Grasp.Result.CANCELED
                return result
            if step < 2:
                feedback = Grasp.Feedback()
                feedback.state = GraspState.LIFTING
                feedback.estimated_force = goal.initial_force
                feedback.slip_events = step
                goal_handle.publish_feedback(feedback)
            if goal.timeout < 1.0 and step >= 2:  # short goals finish after the feedback
                break
            time.sleep(0.05)
        goal_handle.succeed()
        result.outcome = Grasp.Result.LIFTED
        result.final_force = 2.0 * goal.initial_force
        result.lift_height = goal.lift_distance
        result.slip_events = 2
        return result


def main() -> None:
    rclpy.init()
    node = EchoPeer()
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    threading.Thread(target=lambda: (sys.stdin.read(), rclpy.try_shutdown()), daemon=True).start()
    print('ready', flush=True)
    try:
        executor.spin()
    except Exception:  # noqa: BLE001 (shutdown while spinning ends the peer)
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
