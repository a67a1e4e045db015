"""The grasp controller's parameter descriptors and the ``problems()`` checks agree.

For every parameter of the state machine (``ControllerParams``) and of the lift
verification (``LiftCheckParams``, node names ``lift_check.<field>``), the range the node
advertises (its ``ParameterDescriptor``, as ``ros2 param describe`` shows it and as rclpy
enforces it) and the range ``problems()`` enforces are the same: both accept each bound and
both refuse a value just outside it. Text parameters list the same choices.
"""
from __future__ import annotations

from dataclasses import fields, replace

import pytest
import rclpy
from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_control.ros.grasp_controller_node import GraspControllerNode
from forte_control.state_machine import ControllerParams
from forte_control.state_machine.lift_check import LiftCheckParams

#: node parameter name -> (defaults of its dataclass, field name)
GROUPS = {prefix + item.name: (defaults, item.name)
          for defaults, prefix in ((ControllerParams(), ''), (LiftCheckParams(), 'lift_check.'))
          for item in fields(defaults)}
DEFAULTS = {name: getattr(defaults, field) for name, (defaults, field) in GROUPS.items()}
NUMBERS = [name for name, value in DEFAULTS.items() if isinstance(value, float)]
TEXTS = [name for name, value in DEFAULTS.items() if isinstance(value, str)]


@pytest.fixture(scope='module')
def controller():
    """A grasp controller node in a context of its own (never spun: only its parameters).

    Destroyed with its action servers and its context shut down at the end of the module:
    nothing of it stays in the DDS domain that later tests of this process share.
    """
    context = Context()
    rclpy.init(context=context)
    try:
        node = GraspControllerNode(context=context)
        try:
            yield node
        finally:
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


@pytest.fixture(scope='module')
def descriptors(controller) -> dict[str, ParameterDescriptor]:
    return dict(zip(DEFAULTS, controller.describe_parameters(list(DEFAULTS))))


@pytest.fixture(scope='module')
def range_checker(controller, descriptors):
    """A bare node with the controller's descriptors: rclpy's own range check, alone."""
    node = Node('descriptor_probe', context=controller.context)
    for name, descriptor in descriptors.items():
        node.declare_parameter(name, DEFAULTS[name], descriptor)
    yield node
    node.destroy_node()


def descriptor_accepts(node: Node, name: str, value: float) -> bool:
    """rclpy's verdict on ``value`` under the descriptor (the value is restored after)."""
    result = node.set_parameters([Parameter(name, value=value)])[0]
    node.set_parameters([Parameter(name, value=DEFAULTS[name])])
    return result.successful


def problems_refuse_range(name: str, value: object) -> bool:
    """True if ``problems()`` refuses ``value`` of ``name`` as out of its range / choices."""
    defaults, field = GROUPS[name]
    problems = replace(defaults, **{field: value}).problems()
    return any(p.startswith((f'{name}=', f'{name} must be one of')) and
               (' outside ' in p or 'must be one of' in p) for p in problems)


def just_outside(bound: float, direction: float) -> float:
    """A value beyond ``bound`` (by 0.1 %, or 1e-9 at zero), outside rclpy's tolerance."""
    step = abs(bound) * 1e-3 if bound != 0.0 else 1e-9
    return bound + direction * step


def test_every_number_has_a_range_and_its_default_inside(descriptors):
    for name in NUMBERS:
        descriptor = descriptors[name]
        assert descriptor.type == ParameterType.PARAMETER_DOUBLE, name
        assert len(descriptor.floating_point_range) == 1, f'{name} has no range'
        span = descriptor.floating_point_range[0]
        assert span.from_value < span.to_value, name
        assert span.from_value <= DEFAULTS[name] <= span.to_value, name
        assert descriptor.description, name


@pytest.mark.parametrize('name', NUMBERS)
def test_descriptor_and_problems_agree_at_both_bounds(name, descriptors, range_checker):
    span = descriptors[name].floating_point_range[0]
    for bound, direction in ((span.from_value, -1.0), (span.to_value, 1.0)):
        outside = just_outside(bound, direction)
        assert descriptor_accepts(range_checker, name, bound), (name, bound)
        assert not problems_refuse_range(name, bound), \
            f'{name}={bound}: the descriptor accepts it, problems() refuses it'
        assert not descriptor_accepts(range_checker, name, outside), (name, outside)
        assert problems_refuse_range(name, outside), \
            f'{name}={outside}: the descriptor refuses it, problems() accepts it'


@pytest.mark.parametrize('name', NUMBERS)
def test_the_node_refuses_what_problems_refuses(name, controller, descriptors):
    """Through the node's own parameter interface: bound accepted or refused only by a
    relation to another parameter, just outside refused, value unchanged."""
    span = descriptors[name].floating_point_range[0]
    for bound, direction in ((span.from_value, -1.0), (span.to_value, 1.0)):
        outside = just_outside(bound, direction)
        result = controller.set_parameters([Parameter(name, value=outside)])[0]
        assert not result.successful, (name, outside)
        assert controller.get_parameter(name).value == DEFAULTS[name]
        result = controller.set_parameters([Parameter(name, value=bound)])[0]
        assert result.successful or 'outside' not in result.reason, (name, result.reason)
        controller.set_parameters([Parameter(name, value=DEFAULTS[name])])
    assert controller.get_parameter(name).value == DEFAULTS[name]


@pytest.mark.parametrize('name', TEXTS)
def test_text_choices_agree(name, descriptors):
    constraint = descriptors[name].additional_constraints
    assert constraint.startswith('one of '), name
    choices = [part.strip().strip("'") for part in constraint[len('one of '):].split('|')]
    assert DEFAULTS[name] in choices
    for choice in choices:
        assert not problems_refuse_range(name, choice), (name, choice)
    assert problems_refuse_range(name, 'not-a-choice')


def test_units_are_part_of_the_descriptions(descriptors):
    assert '[rad/s]' in descriptors['closing_speed'].description
    assert '[N]' in descriptors['max_force'].description
    assert '[s]' in descriptors['perception_timeout'].description
    assert '[m/s]' in descriptors['lift_speed'].description
    assert '[A]' in descriptors['max_current'].description
    assert '[m]' in descriptors['lift_check.probe_distance'].description


def test_positive_quantities_refuse_zero(descriptors):
    """Speeds, caps and timeouts that must be positive say so in their range."""
    for name in ('closing_speed', 'lift_speed', 'max_force', 'perception_timeout',
                 'timeout', 'max_current', 'slip_increment', 'lift_check.wrench_timeout',
                 'lift_check.balance_window', 'lift_check.probe_window'):
        assert descriptors[name].floating_point_range[0].from_value > 0.0, name
        assert problems_refuse_range(name, 0.0), name

