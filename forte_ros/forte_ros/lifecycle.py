"""Lifecycle behaviour shared by the FORTE managed nodes.

rclpy 7.1.6 (ROS 2 Jazzy) serves ``<node>/change_state`` with
``LifecycleNodeMixin.__on_change_state``, which calls
``_state_machine.trigger_transition_by_id`` without checking that the transition starts at
the current state. A request that is invalid there (a second ``configure`` sent by a stale
launch on the same domain, ``activate`` while unconfigured) raises ``RCLError`` inside the
service callback; the executor re-raises it and the node process dies. A request naming
the transition by an invalid *label* is already answered ``success=false``.

:class:`ForteLifecycleNode` wraps that one service callback of its own instance (rclpy is
not patched): a transition that does not start at the current primary state is refused
(``success=false``) with a warning, and the node keeps running. It also gives the node
runner (:mod:`forte_ros.node_runner`) a :meth:`ForteLifecycleNode.prepare_shutdown` that
brings the node down through its own state machine.
"""
from __future__ import annotations

from typing import Any

from rclpy.lifecycle import LifecycleNode, TransitionCallbackReturn

#: Primary states from which the ``shutdown`` transition exists.
SHUTDOWN_FROM = ('unconfigured', 'inactive', 'active')


def available_transitions(node: LifecycleNode) -> dict[int, str]:
    """Transitions that start at the node's current state.

    Parameters
    ----------
    node : rclpy.lifecycle.LifecycleNode
        Any lifecycle node.

    Returns
    -------
    dict
        ``{transition id: transition label}``.
    """
    return {description[0]: description[1]
            for description in node._state_machine.available_transitions}


def current_state_label(node: LifecycleNode) -> str:
    """Label of the node's current lifecycle state (``'active'``, ``'finalized'``, ...)."""
    return node._state_machine.current_state[1]


def shut_down_lifecycle(node: LifecycleNode) -> TransitionCallbackReturn | None:
    """Take the shutdown transition from the current primary state (runs ``on_shutdown``).

    Parameters
    ----------
    node : rclpy.lifecycle.LifecycleNode
        Node to finalise. Nothing is done if it is already finalized or not in a primary
        state from which ``shutdown`` exists.

    Returns
    -------
    TransitionCallbackReturn or None
        What ``on_shutdown`` returned, or None if no transition was taken. Errors are
        logged, never raised: this runs while a process stops.
    """
    label = current_state_label(node)
    if label not in SHUTDOWN_FROM:
        return None
    try:
        result = node.trigger_shutdown()
    except Exception as error:  # noqa: BLE001 - a stopping process must not die here
        node.get_logger().error(f'shutdown transition from {label} failed: {error}')
        return None
    if result != TransitionCallbackReturn.SUCCESS:
        node.get_logger().error(f'shutdown transition from {label}: on_shutdown returned '
                                f'{result.to_label()}')
    return result


class ForteLifecycleNode(LifecycleNode):
    """A LifecycleNode that refuses invalid change_state requests and finalises cleanly.

    Parameters
    ----------
    node_name : str
        Name of the node.
    **kwargs
        Passed to :class:`rclpy.lifecycle.LifecycleNode`.

    Attributes
    ----------
    refused_transitions : int
        Number of change_state requests refused because they were invalid here.
    """

    def __init__(self, node_name: str, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.refused_transitions = 0
        service = getattr(self, '_service_change_state', None)
        if service is not None:  # None with enable_communication_interface=False
            self._rclpy_change_state = service.callback
            service.callback = self._on_change_state_request

    def _on_change_state_request(self, request: Any, response: Any) -> Any:
        """change_state service callback: refuse what does not start at the current state."""
        label = current_state_label(self)
        available = available_transitions(self)
        wanted = request.transition.label
        if wanted:
            valid = wanted in available.values()
            name = repr(wanted)
        else:
            valid = request.transition.id in available
            name = f'id {request.transition.id}'
        if valid:
            try:
                return self._rclpy_change_state(request, response)
            except RuntimeError as error:  # RCLError: the state changed under the request
                reason = str(error).splitlines()[0]
        else:
            reason = f'valid from {label}: {sorted(set(available.values())) or "none"}'
        self.refused_transitions += 1
        self.get_logger().warning(
            f'change_state: transition {name} refused in state {label} ({reason}); '
            'the node keeps running')
        response.success = False
        return response

    def prepare_shutdown(self) -> None:
        """Bring the node down through its state machine (``on_shutdown`` runs).

        Called by :class:`forte_ros.node_runner.NodeRunner` after spinning stopped and
        before the node is destroyed and the context shut down; safe to call again.
        """
        shut_down_lifecycle(self)
