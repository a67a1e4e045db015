"""The grasp controller's ROS parameters, declared from :mod:`forte_control.parameters`.

Descriptors (description with unit, ``FloatingPointRange`` / ``IntegerRange``, allowed
choices, read-only) are built from the same table whose ranges
:meth:`ControllerParams.problems` enforces, so what ``ros2 param describe`` shows is what
the state machine accepts. The lift verification's thresholds (:class:`LiftCheckParams`)
are the node's ``lift_check.*`` parameters (a ``lift_check:`` block in the YAML).
"""
from __future__ import annotations

from dataclasses import fields

from rcl_interfaces.msg import (
    ParameterDescriptor,
    ParameterType,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_control.parameters import (
    CONTROLLER_PARAMETERS,
    LIFT_CHECK_PARAMETERS,
    LIFT_CHECK_PREFIX,
    NODE_PARAMETERS,
    ParameterSpec,
)
from forte_control.state_machine import ControllerParams
from forte_control.state_machine.lift_check import LiftCheckParams
from forte_ros.parameters import with_range

#: Names of the ControllerParams fields, in field order.
CONTROLLER_FIELDS = [item.name for item in fields(ControllerParams)]
#: Names of the LiftCheckParams fields, in field order (node names: ``lift_check.<field>``).
LIFT_CHECK_FIELDS = [item.name for item in fields(LiftCheckParams)]

#: (dataclass, its fields, the table, prefix of the node names) of each parameter group.
_GROUPS = ((ControllerParams, CONTROLLER_FIELDS, CONTROLLER_PARAMETERS, ''),
           (LiftCheckParams, LIFT_CHECK_FIELDS, LIFT_CHECK_PARAMETERS, LIFT_CHECK_PREFIX))

_TYPES = {float: ParameterType.PARAMETER_DOUBLE, int: ParameterType.PARAMETER_INTEGER,
          bool: ParameterType.PARAMETER_BOOL, str: ParameterType.PARAMETER_STRING,
          list: ParameterType.PARAMETER_STRING_ARRAY}


def descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    """The ``ParameterDescriptor`` of one table entry.

    Parameters
    ----------
    spec : ParameterSpec
        Table entry.

    Returns
    -------
    rcl_interfaces.msg.ParameterDescriptor
        Description with the unit, type, read-only flag, inclusive range of a number
        (``FloatingPointRange`` or ``IntegerRange``, step 0 / 1) and, for a text with
        choices, ``additional_constraints`` listing them.
    """
    result = ParameterDescriptor(name=spec.name, type=_TYPES[spec.kind],
                                 description=spec.full_description(), read_only=spec.read_only)
    if spec.choices:
        result.additional_constraints = f'one of {spec.range_text()}'
    elif spec.low is not None and spec.high is not None:
        with_range(result, spec.low, spec.high, integer=spec.kind is int)
    return result


def declare_parameters(node: Node) -> None:
    """Declare every controller parameter on ``node``.

    The state machine's and the lift verification's parameters default to the
    :class:`ControllerParams` and :class:`LiftCheckParams` defaults; the node-only ones to
    their table default.

    Raises
    ------
    KeyError
        A dataclass field has no entry in the parameter table.
    """
    for kind, names, table, prefix in _GROUPS:
        defaults = kind()
        for name in names:
            if prefix + name not in table:
                raise KeyError(f'{kind.__name__}.{name} has no entry in the parameter table '
                               '(forte_control.parameters)')
            spec = table[prefix + name]
            node.declare_parameter(spec.name, spec.kind(getattr(defaults, name)),
                                   descriptor(spec))
    for spec in NODE_PARAMETERS.values():
        default = list(spec.default) if spec.kind is list else spec.default
        node.declare_parameter(spec.name, default, descriptor(spec))


def read_controller_params(node: Node) -> ControllerParams:
    """The :class:`ControllerParams` given by the node's current parameter values."""
    return ControllerParams(**{name: CONTROLLER_PARAMETERS[name].kind(
        node.get_parameter(name).value) for name in CONTROLLER_FIELDS})


def read_lift_check(node: Node) -> LiftCheckParams:
    """The :class:`LiftCheckParams` given by the node's ``lift_check.*`` parameter values."""
    return LiftCheckParams(**{name: LIFT_CHECK_PARAMETERS[LIFT_CHECK_PREFIX + name].kind(
        node.get_parameter(LIFT_CHECK_PREFIX + name).value) for name in LIFT_CHECK_FIELDS})


def parameter_changes(parameters: list[Parameter]
                      ) -> tuple[dict[str, object], dict[str, object], str]:
    """The dataclass fields a parameter update changes, converted to the field types.

    Parameters
    ----------
    parameters : list of rclpy.parameter.Parameter
        The update (as given to an on-set-parameters callback).

    Returns
    -------
    controller : dict
        :class:`ControllerParams` field name -> new value.
    lift_check : dict
        :class:`LiftCheckParams` field name -> new value.
    error : str
        Empty, or the reason a value cannot be converted (then both dicts are empty).
    """
    changes: tuple[dict[str, object], dict[str, object]] = ({}, {})
    for parameter in parameters:
        for group, (_, _, table, prefix) in zip(changes, _GROUPS):
            spec = table.get(parameter.name)
            if spec is None:
                continue
            try:
                group[parameter.name[len(prefix):]] = spec.kind(parameter.value)
            except (TypeError, ValueError) as error:
                return {}, {}, f'{parameter.name}: {error}'
    return changes[0], changes[1], ''
