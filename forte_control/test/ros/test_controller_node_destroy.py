"""A grasp controller node destroyed in-process leaves nothing behind in the DDS domain.

rclpy's ``Node.destroy_node`` does not destroy action servers; one left alive keeps the node
and its context's participant alive until the garbage collector runs, and its ``grasp``
server stays discoverable with no executor to answer. A later action client in the same
process and domain (``colcon test`` runs a package's tests in one pytest process) then
takes it for a live server and loses its goal. The controller's ``destroy_node`` destroys
its action servers first.
"""
from __future__ import annotations

import rclpy
from rclpy.action import ActionClient
from rclpy.context import Context

from forte_control.ros.grasp_controller_node import GraspControllerNode
from forte_control.ros.gripper_command_servers import gripper_actions
from forte_msgs.action import Grasp
from forte_ros.testing import Probe, wait_until


def test_destroyed_controller_serves_no_action_any_more():
    context = Context()
    rclpy.init(context=context)
    controller = None
    try:
        controller = GraspControllerNode(context=context)
        with Probe('controller_destroy_probe') as probe:
            clients = [ActionClient(probe.node, Grasp, 'grasp')] + [
                ActionClient(probe.node, action.action_type, action.name)
                for action in gripper_actions()]
            try:
                # discovered first: the check below is not won by a slow discovery
                assert all(client.wait_for_server(timeout_sec=20.0) for client in clients)
                controller.destroy_node()
                controller.destroy_node()  # a second call does nothing
                rclpy.try_shutdown(context=context)
                assert wait_until(lambda: not any(client.server_is_ready()
                                                  for client in clients), 10.0), \
                    'an action server of the destroyed controller is still discoverable'
            finally:
                for client in clients:
                    client.destroy()
    finally:
        if controller is not None:
            controller.destroy_node()
        rclpy.try_shutdown(context=context)
