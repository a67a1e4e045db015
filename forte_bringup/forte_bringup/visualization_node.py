"""Live views for RViz: per-pad force wrenches and, where available, markers.

Thin ROS shell over :mod:`forte_bringup.visualization`:

* subscribes ``tactile/state`` (forte_msgs/TactileState) and ``grasp/state``
  (forte_msgs/GraspState), with the QoS of docs/contracts.md;
* publishes, at most ``max_rate`` times per second on a tactile state,
  ``visualization/left_pad_wrench`` and ``visualization/right_pad_wrench``
  (geometry_msgs/WrenchStamped, reliable, keep last 10): the force the pad applies to the
  object along its ``+x`` [N], in ``<prefix>forte_left_pad`` / ``<prefix>forte_right_pad``,
  stamped with the tactile state's sample time (RViz's Wrench display draws it as an
  arrow);
* publishes ``visualization/markers`` (visualization_msgs/MarkerArray) on the same updates
  and on every grasp state, when the visualization_msgs package can be imported: force
  arrows (namespace ``force``), slip highlights (``slip``), the grasp-state text
  (``grasp_state``), all frame-locked and stamped 0 (the latest transform). Without
  visualization_msgs (a machine where the package is not installed) the node says so in one
  log line at start and publishes the wrenches only.

Run: ``ros2 run forte_bringup forte_visualization --ros-args -p prefix:=right_``.
"""
from __future__ import annotations

import math
import time
from typing import Any

from geometry_msgs.msg import Point, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_bringup.visualization import (
    PAD_SIDES,
    Arrow,
    GraspSnapshot,
    Highlight,
    Label,
    SlipLatch,
    TactileSnapshot,
    View,
    VisualizationConfig,
    compose,
)
from forte_msgs.msg import GraspState, TactileState
from forte_ros import run_node
from forte_ros.parameter_table import ParameterSpec, parameter_table, replace_fields
from forte_ros.parameters import declare_table, parameter_update, read_table
from forte_ros.qos import GRASP_STATE, TACTILE_STATE, reliable

try:  # optional: without it the node publishes the wrenches only
    from visualization_msgs.msg import Marker, MarkerArray
except ImportError:  # pragma: no cover - depends on the installation
    Marker = MarkerArray = None

#: Topics (relative, remappable): per-pad wrenches (left, right) and the marker array.
WRENCH_TOPICS = tuple(f'visualization/{side}_pad_wrench' for side in PAD_SIDES)
MARKER_TOPIC = 'visualization/markers'
#: QoS of the outputs: reliable, keep last 10 (RViz subscribes reliable, depth 5).
OUTPUT_QOS = reliable(10)
#: The one log line of a node without visualization_msgs.
NO_MARKERS = ('visualization_msgs is not installed: publishing the per-pad wrenches only '
              f'({", ".join(WRENCH_TOPICS)}), no {MARKER_TOPIC}')

#: Every parameter of the node; defaults are those of VisualizationConfig.
PARAMETERS = parameter_table([
    ParameterSpec('prefix', str, "TF prefix of the gripper's frames, e.g. right_ (the pad "
                  "and base frames of the outputs; '' = none)", field='prefix',
                  read_only=True),
    ParameterSpec('arrow_scale', float, 'marker arrow length per newton of pad force', 'm/N',
                  1e-4, 1.0, field='arrow_scale'),
    ParameterSpec('max_arrow_length', float, 'longest marker arrow (larger forces are drawn '
                  'at this length)', 'm', 0.001, 2.0, field='max_arrow_length'),
    ParameterSpec('slip_hold', float, 'how long a slip flag stays shown', 's', 0.0, 10.0,
                  field='slip_hold'),
    ParameterSpec('max_rate', float, 'most wrench / marker updates per second (tactile '
                  'states in between are folded into the next one)', 'Hz', 0.1, 1000.0,
                  field='max_rate'),
    ParameterSpec('label_height', float, 'letter height of the grasp-state text', 'm', 0.001,
                  0.5, field='label_height'),
    ParameterSpec('label_offset', float, 'height of the grasp-state text above the gripper '
                  "body's origin (along its +z)", 'm', -2.0, 2.0, field='label_offset'),
])


def tactile_snapshot(message: TactileState) -> TactileSnapshot:
    """The fields of a TactileState that :func:`~forte_bringup.visualization.compose` uses."""
    return TactileSnapshot(
        force=float(message.force), force_valid=bool(message.force_valid),
        contact=(bool(message.contact[0]), bool(message.contact[1])),
        slip=bool(message.slip), slip_active=bool(message.slip_active),
        finger_variance=(float(message.finger_variance[0]),
                         float(message.finger_variance[1])))


def grasp_snapshot(message: GraspState) -> GraspSnapshot:
    """The fields of a GraspState that :func:`~forte_bringup.visualization.compose` uses."""
    return GraspSnapshot(
        state=int(message.state), controller=int(message.controller),
        last_outcome=int(message.last_outcome), target_force=float(message.target_force),
        estimated_force=float(message.estimated_force), force_valid=bool(message.force_valid),
        slip_events=int(message.slip_events), fault_flags=int(message.fault_flags),
        message=str(message.message))


def wrench_messages(view: View, stamp: Any) -> list[WrenchStamped]:
    """One WrenchStamped per pad (left, right) of ``view``, stamped ``stamp``
    (builtin_interfaces/Time)."""
    out = []
    for pad in view.pads:
        message = WrenchStamped()
        message.header.stamp = stamp
        message.header.frame_id = pad.frame
        message.wrench.force.x, message.wrench.force.y, message.wrench.force.z = (
            float(value) for value in pad.force)
        out.append(message)
    return out


def _marker(marker_type: type, frame: str, namespace: str, marker_id: int, visible: bool
            ) -> Any:
    marker = marker_type()
    marker.header.frame_id = frame
    marker.ns = namespace
    marker.id = marker_id
    marker.action = marker_type.ADD if visible else marker_type.DELETE
    marker.frame_locked = True
    marker.pose.orientation.w = 1.0
    return marker


def _colour(marker: Any, rgba: tuple[float, float, float, float]) -> None:
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = (float(v) for v in rgba)


def arrow_marker(marker_type: type, arrow: Arrow, marker_id: int) -> Any:
    """An ARROW marker (two points) of ``arrow`` in namespace ``force``."""
    marker = _marker(marker_type, arrow.frame, 'force', marker_id, arrow.visible)
    marker.type = marker_type.ARROW
    marker.points = [Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))
                     for p in (arrow.start, arrow.end)]
    marker.scale.x = arrow.shaft_diameter
    marker.scale.y = arrow.head_diameter
    marker.scale.z = arrow.head_length
    _colour(marker, arrow.colour)
    return marker


def highlight_marker(marker_type: type, highlight: Highlight, marker_id: int) -> Any:
    """A SPHERE marker of ``highlight`` in namespace ``slip``."""
    marker = _marker(marker_type, highlight.frame, 'slip', marker_id, highlight.visible)
    marker.type = marker_type.SPHERE
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (
        float(v) for v in highlight.centre)
    marker.scale.x = marker.scale.y = marker.scale.z = highlight.diameter
    _colour(marker, highlight.colour)
    return marker


def label_marker(marker_type: type, label: Label) -> Any:
    """A TEXT_VIEW_FACING marker of ``label`` in namespace ``grasp_state``."""
    marker = _marker(marker_type, label.frame, 'grasp_state', 0, True)
    marker.type = marker_type.TEXT_VIEW_FACING
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (
        float(v) for v in label.position)
    marker.scale.z = label.height
    marker.text = label.text
    _colour(marker, label.colour)
    return marker


def marker_array(view: View, marker_type: type, array_type: type) -> Any:
    """The markers of ``view``: two force arrows, two slip highlights, the label.

    Parameters
    ----------
    view : View
        What to draw.
    marker_type, array_type : type
        ``visualization_msgs.msg.Marker`` and ``MarkerArray`` (parameters, so that the
        conversion is testable where the package is not installed).
    """
    markers = [arrow_marker(marker_type, arrow, i) for i, arrow in enumerate(view.arrows)]
    markers += [highlight_marker(marker_type, h, i) for i, h in enumerate(view.highlights)]
    markers.append(label_marker(marker_type, view.label))
    return array_type(markers=markers)


class VisualizationNode(Node):
    """Per-pad wrenches and markers of the latest tactile and grasp states (module
    docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('forte_visualization', **kwargs)
        declare_table(self, PARAMETERS, VisualizationConfig())
        self.config: VisualizationConfig = replace_fields(
            VisualizationConfig(), PARAMETERS, read_table(self, PARAMETERS))
        self._latch = SlipLatch(self.config.slip_hold)
        self._tactile: TactileSnapshot | None = None
        self._grasp: GraspSnapshot | None = None
        self._slipping = False
        self._stamp = None
        self._last_update = -math.inf
        self._wrench_publishers = [self.create_publisher(WrenchStamped, topic, OUTPUT_QOS)
                                   for topic in WRENCH_TOPICS]
        self._marker_publisher = (None if MarkerArray is None else
                                  self.create_publisher(MarkerArray, MARKER_TOPIC, OUTPUT_QOS))
        self.create_subscription(TactileState, 'tactile/state', self._on_tactile,
                                 TACTILE_STATE)
        self.create_subscription(GraspState, 'grasp/state', self._on_grasp, GRASP_STATE)
        self.add_on_set_parameters_callback(self._on_parameters)
        if self._marker_publisher is None:
            self.get_logger().info(NO_MARKERS)

    def _on_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        values, reason = parameter_update(parameters, PARAMETERS)
        if reason:
            return SetParametersResult(successful=False, reason=reason)
        self.config = replace_fields(self.config, PARAMETERS, values)
        self._latch.hold = self.config.slip_hold
        return SetParametersResult(successful=True)

    @property
    def markers_enabled(self) -> bool:
        """True when visualization_msgs was importable (markers are published)."""
        return self._marker_publisher is not None

    def view(self) -> View:
        """What the latest tactile and grasp states draw (:func:`compose`)."""
        return compose(self._tactile, self._grasp, self._slipping, self.config)

    def _on_tactile(self, message: TactileState) -> None:
        now = time.monotonic()
        self._tactile = tactile_snapshot(message)
        self._slipping = self._latch.update(self._tactile.slip, now)
        self._stamp = message.header.stamp
        if now - self._last_update < 1.0 / self.config.max_rate:
            return
        self._last_update = now
        view = self.view()
        for publisher, wrench in zip(self._wrench_publishers, wrench_messages(view, self._stamp)):
            publisher.publish(wrench)
        self._publish_markers(view)

    def _on_grasp(self, message: GraspState) -> None:
        self._grasp = grasp_snapshot(message)
        self._publish_markers(self.view())

    def _publish_markers(self, view: View) -> None:
        if self._marker_publisher is not None:
            self._marker_publisher.publish(marker_array(view, Marker, MarkerArray))


def main(args: list[str] | None = None) -> int:
    """Entry point ``forte_visualization``."""
    return run_node(VisualizationNode, args, name='forte_visualization')


if __name__ == '__main__':
    raise SystemExit(main())
