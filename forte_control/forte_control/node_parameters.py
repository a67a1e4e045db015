"""The grasp controller's ROS parameters, declared from :mod:`forte_control.parameters`.

Descriptors (description with unit, ``FloatingPointRange`` / ``IntegerRange``, allowed
choices, read-only) are built from the same table whose ranges
:meth:`ControllerParams.problems` enforces, so what ``ros2 param describe`` shows is what
the state machine accepts.
"""
from __future__ import annotations

from dataclasses import fields

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_control.parameters import CONTROLLER_PARAMETERS, NODE_PARAMETERS, ParameterSpec
from forte_control.state_machine import ControllerParams

#: Names of the ControllerParams fields, in field order.
CONTROLLER_FIELDS = [item.name for item in fields(ControllerParams)]

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
        if spec.kind is int:
            result.integer_range = [IntegerRange(from_value=int(spec.low),
                                                 to_value=int(spec.high), step=1)]
        else:
            result.floating_point_range = [FloatingPointRange(
                from_value=float(spec.low), to_value=float(spec.high), step=0.0)]
    return result


def declare_parameters(node: Node) -> None:
    """Declare every controller parameter on ``node`` (state machine and node-only ones).

    The state machine's parameters default to the :class:`ControllerParams` defaults.

    Raises
    ------
    KeyError
        A :class:`ControllerParams` field has no entry in the parameter table.
    """
    defaults = ControllerParams()
    for name in CONTROLLER_FIELDS:
        if name not in CONTROLLER_PARAMETERS:
            raise KeyError(f'ControllerParams.{name} has no entry in '
                           'forte_control.parameters.CONTROLLER_PARAMETERS')
        spec = CONTROLLER_PARAMETERS[name]
        node.declare_parameter(name, spec.kind(getattr(defaults, name)), descriptor(spec))
    for spec in NODE_PARAMETERS.values():
        default = list(spec.default) if spec.kind is list else spec.default
        node.declare_parameter(spec.name, default, descriptor(spec))


def read_controller_params(node: Node) -> ControllerParams:
    """The :class:`ControllerParams` given by the node's current parameter values."""
    return ControllerParams(**{name: CONTROLLER_PARAMETERS[name].kind(
        node.get_parameter(name).value) for name in CONTROLLER_FIELDS})


def controller_changes(parameters: list[Parameter]) -> tuple[dict[str, object], str]:
    """The ControllerParams fields a parameter update changes, converted to field types.

    Parameters
    ----------
    parameters : list of rclpy.parameter.Parameter
        The update (as given to an on-set-parameters callback).

    Returns
    -------
    changes : dict
        Field name -> new value (other parameters are left out).
    error : str
        Empty, or the reason a value cannot be converted (then ``changes`` is empty).
    """
    changes: dict[str, object] = {}
    for parameter in parameters:
        spec = CONTROLLER_PARAMETERS.get(parameter.name)
        if spec is None:
            continue
        try:
            changes[parameter.name] = spec.kind(parameter.value)
        except (TypeError, ValueError) as error:
            return {}, f'{parameter.name}: {error}'
    return changes, ''
