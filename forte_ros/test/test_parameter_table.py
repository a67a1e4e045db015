"""The one parameter-table shape and its ROS helpers: known answers, then a real node.

:mod:`forte_ros.parameter_table` (pure) against hand-written answers: the descriptor of an
entry (float range, integer range with a step, choices, read-only), defaults taken from a
nested dataclass field (and a stale field path failing loudly), a repeated name refused,
the texts of :func:`range_problems`, :func:`replace_fields`. Then
:mod:`forte_ros.parameters` on a real rclpy node: :func:`declare_table` declares, rclpy
serves the descriptors, :func:`read_table` reads back (overrides included) and
:func:`parameter_update` refuses what the table refuses.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import pytest
import rclpy
from rcl_interfaces.msg import ParameterType, SetParametersResult
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_ros.parameter_table import (
    ParameterSpec,
    field_default,
    parameter_table,
    range_problems,
    replace_fields,
)
from forte_ros.parameters import declare_table, parameter_update, read_table, spec_descriptor


@dataclass(frozen=True)
class Window:
    """A nested core dataclass (as ``SlipParams`` in ``PipelineConfig``)."""

    window: int = 400
    mode: str = 'robust'


@dataclass(frozen=True)
class Core:
    """A core dataclass holding defaults."""

    rate: float = 2000.0
    slip: Window = field(default_factory=Window)


TABLE = parameter_table([
    ParameterSpec('rate', float, 'sample rate', 'Hz', 1.0, 1e6, field='rate', read_only=True),
    ParameterSpec('slip_window', int, 'FFT window', 'samples', 8, 8192, field='slip.window'),
    ParameterSpec('slip_mode', str, 'detector mode', choices=('paper', 'robust'),
                  field='slip.mode'),
    ParameterSpec('direction', int, 'servo direction', low=-1, high=1, integer_step=2,
                  default=-1),
    ParameterSpec('frame_id', str, 'frame of the output', default='forte_base_link'),
    ParameterSpec('topics', list, 'topics to replay', default=('tactile/frames',)),
    ParameterSpec('autostart', bool, 'start at once', default=False, read_only=True),
])


def ranges(descriptor) -> tuple[list, list]:
    """(floating point, integer) ranges of a descriptor as (from, to, step) tuples."""
    return ([(r.from_value, r.to_value, r.step) for r in descriptor.floating_point_range],
            [(r.from_value, r.to_value, r.step) for r in descriptor.integer_range])


def test_descriptors_have_known_answers():
    rate = spec_descriptor(TABLE['rate'])
    assert (rate.name, rate.type, rate.description, rate.read_only) == (
        'rate', ParameterType.PARAMETER_DOUBLE, 'sample rate [Hz]', True)
    assert ranges(rate) == ([(1.0, 1e6, 0.0)], [])
    window = spec_descriptor(TABLE['slip_window'])
    assert window.description == 'FFT window [samples]' and not window.read_only
    assert ranges(window) == ([], [(8, 8192, 1)])
    direction = spec_descriptor(TABLE['direction'])
    assert ranges(direction) == ([], [(-1, 1, 2)])
    mode = spec_descriptor(TABLE['slip_mode'])
    assert mode.type == ParameterType.PARAMETER_STRING
    assert mode.additional_constraints == "one of 'paper' | 'robust'"
    assert ranges(mode) == ([], [])
    frame = spec_descriptor(TABLE['frame_id'])
    assert frame.additional_constraints == '' and ranges(frame) == ([], [])
    autostart = spec_descriptor(TABLE['autostart'])
    assert autostart.read_only and autostart.type == ParameterType.PARAMETER_BOOL
    assert spec_descriptor(TABLE['topics']).type == ParameterType.PARAMETER_STRING_ARRAY


def test_defaults_come_from_the_dataclass_or_the_table():
    core = Core(rate=1000, slip=Window(window=256))
    assert TABLE['slip_window'].default_from(core) == 256
    assert TABLE['slip_mode'].default_from(Core()) == 'robust'
    rate = TABLE['rate'].default_from(core)
    assert rate == 1000.0 and isinstance(rate, float)       # converted to the kind
    assert TABLE['direction'].default_from() == -1
    assert TABLE['topics'].default_from() == ['tactile/frames']  # a list for ROS
    with pytest.raises(ValueError, match='no dataclass instance'):
        TABLE['slip_window'].default_from(None)
    stale = ParameterSpec('slip_size', int, 'renamed field', field='slip.size')
    with pytest.raises(AttributeError, match=r"Window has no field 'size' \(slip.size\)"):
        stale.default_from(Core())
    with pytest.raises(AttributeError, match="no field 'window'"):
        field_default(Core(), 'window')


def test_a_repeated_name_is_refused():
    entry = ParameterSpec('rate', float, 'sample rate', default=1.0)
    with pytest.raises(ValueError, match="parameter 'rate' is in the table twice"):
        parameter_table([entry, ParameterSpec('other', int, 'x', default=0), entry])


def test_range_problems_texts():
    other = parameter_table([ParameterSpec('lift', float, 'lift height', 'm', 0.0, 0.5,
                                           default=0.03)])
    problems = range_problems((TABLE, other), {
        'slip_window': 4, 'slip_mode': 'fancy', 'lift': 0.7, 'rate': float('nan'),
        'frame_id': 'anything', 'not_a_parameter': -1})
    assert problems == ['slip_window=4 outside [8, 8192] samples',
                        "slip_mode must be one of 'paper' | 'robust', got 'fancy'",
                        'lift=0.7 outside [0, 0.5] m',
                        'rate=nan outside [1, 1e+06] Hz']
    assert range_problems((TABLE, other), {'slip_window': 8192, 'lift': 0.0}) == []
    assert TABLE['direction'].problem(1) == ''


def test_replace_fields_builds_a_nested_dataclass():
    core = Core()
    changed = replace_fields(core, TABLE, {'slip_window': 512.0, 'rate': 100, 'frame_id': 'x',
                                           'unknown': 3})
    assert changed == Core(rate=100.0, slip=Window(window=512))
    assert isinstance(changed.slip.window, int) and core == Core()   # original unchanged
    assert replace_fields(core, TABLE, {'frame_id': 'x'}) is core    # node-only: no field
    stale = parameter_table([ParameterSpec('size', int, 'x', field='slip.size')])
    with pytest.raises(AttributeError, match='size'):
        replace_fields(core, stale, {'size': 3})


@pytest.fixture
def node():
    """A bare rclpy node in a context of its own, the table declared with one override."""
    context = Context()
    rclpy.init(context=context)
    overrides = [Parameter('slip_window', value=1024), Parameter('frame_id', value='tool0')]
    created = Node('forte_table_probe', context=context, parameter_overrides=overrides)
    declare_table(created, TABLE, Core())
    yield created
    created.destroy_node()
    rclpy.shutdown(context=context)


def test_declare_and_read_back_on_a_real_node(node):
    assert read_table(node, TABLE) == {
        'rate': 2000.0, 'slip_window': 1024, 'slip_mode': 'robust', 'direction': -1,
        'frame_id': 'tool0', 'topics': ['tactile/frames'], 'autostart': False}
    assert read_table(node, TABLE, ['direction']) == {'direction': -1}
    served = dict(zip(TABLE, node.describe_parameters(list(TABLE))))
    assert ranges(served['direction']) == ([], [(-1, 1, 2)])
    assert served['slip_mode'].additional_constraints == "one of 'paper' | 'robust'"
    assert served['rate'].read_only and served['rate'].description == 'sample rate [Hz]'
    # rclpy enforces the descriptors: range, integer step, read-only
    assert not node.set_parameters([Parameter('slip_window', value=4)])[0].successful
    assert not node.set_parameters([Parameter('direction', value=0)])[0].successful
    assert not node.set_parameters([Parameter('rate', value=100.0)])[0].successful
    assert node.set_parameters([Parameter('direction', value=1)])[0].successful
    assert read_table(node, TABLE, ['direction']) == {'direction': 1}


def test_parameter_update_refuses_what_the_table_refuses(node):
    values, reason = parameter_update(
        [Parameter('slip_window', value=256), Parameter('use_sim_time', value=True)], TABLE)
    assert (values, reason) == ({'slip_window': 256}, '')
    values, reason = parameter_update([Parameter('slip_mode', value='fancy')], TABLE)
    assert values == {} and reason == "slip_mode must be one of 'paper' | 'robust', got 'fancy'"
    values, reason = parameter_update([Parameter('slip_window', value='many')], TABLE)
    assert values == {} and reason.startswith('slip_window: invalid literal')
    # in a callback, as the nodes use it: the choice a descriptor only lists is refused
    node.add_on_set_parameters_callback(
        lambda parameters: _result(parameter_update(parameters, TABLE)[1]))
    refused = node.set_parameters([Parameter('slip_mode', value='fancy')])[0]
    assert not refused.successful and 'must be one of' in refused.reason
    assert node.set_parameters([Parameter('slip_mode', value='paper')])[0].successful
    assert read_table(node, TABLE, ['slip_mode']) == {'slip_mode': 'paper'}


def _result(reason: str) -> SetParametersResult:
    """A ``SetParametersResult`` refusing with ``reason`` (accepting when it is empty)."""
    return SetParametersResult(successful=not reason, reason=reason)
