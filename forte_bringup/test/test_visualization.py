"""The pure visualization core: pad forces, slip latch, grasp text, arrows and markers data.

No ROS graph: :mod:`forte_bringup.visualization` on hand-made snapshots, its constants
against forte_msgs/GraspState, and the node module's message conversion with stand-in
marker classes (visualization_msgs is not installed on every machine).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import pytest
from geometry_msgs.msg import Pose, Vector3
from std_msgs.msg import ColorRGBA, Header

from forte_bringup import visualization as vis
from forte_msgs.msg import GraspState, TactileState

TOUCH = vis.TactileSnapshot(force=2.5, force_valid=True, contact=(True, True))


def test_both_pads_carry_the_grip_force_along_their_normal():
    left, right = vis.pad_forces(TOUCH, prefix='right_')
    assert (left.frame, right.frame) == ('right_forte_left_pad', 'right_forte_right_pad')
    assert left.force == right.force == (2.5, 0.0, 0.0)
    assert left.magnitude == right.magnitude == 2.5
    assert left.in_contact and not left.slipping


@pytest.mark.parametrize('tactile, expected', [
    (vis.TactileSnapshot(2.5, False, (True, True)), (0.0, 0.0)),        # invalid estimate
    (vis.TactileSnapshot(math.nan, True, (True, True)), (0.0, 0.0)),    # NaN
    (vis.TactileSnapshot(-0.3, True, (True, True)), (0.0, 0.0)),        # below zero
    (vis.TactileSnapshot(1.5, True, (True, False)), (1.5, 0.0)),        # right not touching
    (vis.TactileSnapshot(1.5, True, (False, True)), (0.0, 1.5)),
])
def test_no_force_without_a_valid_estimate_or_contact(tactile, expected):
    assert tuple(pad.force[0] for pad in vis.pad_forces(tactile)) == expected


def test_slip_marks_only_the_pads_in_contact():
    left, right = vis.pad_forces(vis.TactileSnapshot(1.0, True, (True, False)), slipping=True)
    assert left.slipping and not right.slipping


def test_the_slip_latch_holds_a_flag_for_its_hold_time():
    latch = vis.SlipLatch(0.5)
    assert not latch.update(False, 0.0)
    assert latch.update(True, 1.0)
    assert latch.update(False, 1.4)
    assert latch.update(False, 1.5)
    assert not latch.update(False, 1.51)
    assert vis.SlipLatch(0.0).update(True, 3.0)   # hold 0: shown for the state itself
    with pytest.raises(ValueError):
        vis.SlipLatch(-1.0)


def test_the_names_match_the_grasp_state_constants():
    states = {name: getattr(GraspState, name) for name in vis.STATE_NAMES}
    assert [states[name] for name in vis.STATE_NAMES] == list(range(len(vis.STATE_NAMES)))
    outcomes = [getattr(GraspState, 'OUTCOME_' + name) for name in vis.OUTCOME_NAMES]
    assert outcomes == list(range(len(vis.OUTCOME_NAMES)))
    message_faults = {name[len('FAULT_'):]: getattr(GraspState, name) for name in dir(GraspState)
                      if name.startswith('FAULT_') and name != 'FAULT_NONE'}
    assert dict(vis.FAULT_FLAGS) == message_faults
    assert vis.FAULT_STATE == GraspState.FAULT
    assert (TactileState.LEFT, TactileState.RIGHT) == (0, 1)  # pad order


def test_fault_names():
    assert vis.fault_names(0) == []
    assert vis.fault_names(GraspState.FAULT_FORCE_LIMIT | GraspState.FAULT_SERVO) == [
        'FORCE_LIMIT', 'SERVO']
    assert vis.fault_names(128 | 1) == ['STALE_PERCEPTION', 'BIT_128']


def test_grasp_text():
    lifting = vis.GraspSnapshot(state=GraspState.LIFTING, controller=0, target_force=2.0,
                                estimated_force=1.8, force_valid=True, slip_events=1)
    assert vis.grasp_text(lifting, TOUCH, slipping=True) == \
        'LIFTING (FORTE)\nforce 1.80 N / target 2.00 N\nSLIP  events 1'
    fault = vis.GraspSnapshot(state=GraspState.FAULT, controller=2,
                              fault_flags=GraspState.FAULT_STALE_PERCEPTION,
                              message='perception stale for 0.6 s')
    assert vis.grasp_text(fault) == ('FAULT (ON_OFF)\nforce n/a / target 0.00 N\nno slip  '
                                     'events 0\nfault: STALE_PERCEPTION\nperception stale '
                                     'for 0.6 s')
    done = vis.GraspSnapshot(state=GraspState.DONE, last_outcome=GraspState.OUTCOME_LIFTED)
    assert vis.grasp_text(done).splitlines()[-1] == 'last: LIFTED'
    undecided = vis.TactileSnapshot(1.0, True, (True, True), slip_active=False)
    assert vis.grasp_text(None, undecided) == 'no grasp state\nforce 1.00 N\nslip n/a'
    assert vis.grasp_text(vis.GraspSnapshot(state=42)).startswith('#42 (FORTE)')


def test_compose_draws_arrows_highlights_and_the_label():
    config = vis.VisualizationConfig(prefix='left_', arrow_scale=0.02, max_arrow_length=0.1)
    view = vis.compose(vis.TactileSnapshot(3.0, True, (True, False)), None, True, config)
    left, right = view.arrows
    assert left.frame == 'left_forte_left_pad' and left.visible
    assert left.end == pytest.approx((0.06, 0.0, 0.0)) and left.colour == vis.SLIP_COLOUR
    assert not right.visible
    assert [h.visible for h in view.highlights] == [True, False]
    assert view.label.frame == 'left_forte_base_link'
    assert view.label.position == (0.0, 0.0, config.label_offset)
    strong = vis.compose(vis.TactileSnapshot(30.0, True, (True, True)), None, False, config)
    assert strong.arrows[0].end[0] == 0.1 and strong.arrows[0].colour == vis.FORCE_COLOUR
    fault = vis.compose(None, vis.GraspSnapshot(state=GraspState.FAULT), False)
    assert fault.label.colour == vis.FAULT_TEXT_COLOUR
    assert not any(arrow.visible for arrow in fault.arrows)
    assert fault.pads[0].force == (0.0, 0.0, 0.0)


class FakeMarker:
    """The fields of visualization_msgs/Marker that the node sets (the package is missing
    on a bare machine)."""

    ARROW, SPHERE, TEXT_VIEW_FACING = 0, 2, 9
    ADD, DELETE = 0, 2

    def __init__(self) -> None:
        self.header, self.pose, self.scale, self.color = Header(), Pose(), Vector3(), ColorRGBA()
        self.ns, self.id, self.type, self.action = '', 0, 0, 0
        self.points, self.text, self.frame_locked = [], '', False


def test_the_node_turns_a_view_into_markers():
    node = pytest.importorskip('forte_bringup.visualization_node')
    view = vis.compose(TOUCH, vis.GraspSnapshot(state=GraspState.HOLDING), True)
    array = node.marker_array(view, FakeMarker, lambda markers: SimpleNamespace(markers=markers))
    kinds = [(m.ns, m.id, m.type, m.action) for m in array.markers]
    assert kinds == [('force', 0, 0, 0), ('force', 1, 0, 0), ('slip', 0, 2, 0),
                     ('slip', 1, 2, 0), ('grasp_state', 0, 9, 0)]
    arrow = array.markers[0]
    assert arrow.header.frame_id == 'forte_left_pad' and arrow.frame_locked
    assert [(p.x, p.y, p.z) for p in arrow.points] == [(0, 0, 0), pytest.approx((0.025, 0, 0))]
    assert array.markers[-1].text.startswith('HOLDING (FORTE)')
    assert array.markers[-1].header.frame_id == 'forte_base_link'
    quiet = vis.compose(None, None, False)
    actions = [m.action for m in node.marker_array(
        quiet, FakeMarker, lambda markers: SimpleNamespace(markers=markers)).markers]
    assert actions == [FakeMarker.DELETE] * 4 + [FakeMarker.ADD]
    wrenches = node.wrench_messages(view, Header().stamp)
    assert [(w.header.frame_id, w.wrench.force.x) for w in wrenches] == [
        ('forte_left_pad', 2.5), ('forte_right_pad', 2.5)]


def test_the_markers_are_valid_visualization_msgs():
    msg = pytest.importorskip('visualization_msgs.msg')
    node = pytest.importorskip('forte_bringup.visualization_node')
    view = vis.compose(TOUCH, vis.GraspSnapshot(state=GraspState.LIFTING), False)
    array = node.marker_array(view, msg.Marker, msg.MarkerArray)
    assert isinstance(array, msg.MarkerArray) and len(array.markers) == 5
    arrow, text = array.markers[0], array.markers[-1]
    assert (arrow.type, arrow.action) == (msg.Marker.ARROW, msg.Marker.ADD)
    assert arrow.scale.x > 0 and arrow.color.a == 1.0 and arrow.pose.orientation.w == 1.0
    assert text.type == msg.Marker.TEXT_VIEW_FACING and text.scale.z == view.label.height
