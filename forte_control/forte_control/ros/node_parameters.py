"""The grasp controller's ROS parameters, declared from :mod:`forte_control.parameters`.

The tables are declared and read with the helpers every FORTE node uses
(:mod:`forte_ros.parameters`), so what ``ros2 param describe`` shows (description with
unit, ``FloatingPointRange``, allowed choices, read-only) is the range
:meth:`ControllerParams.problems` enforces. The lift verification's thresholds
(:class:`LiftCheckParams`) are the node's ``lift_check.*`` parameters (a ``lift_check:``
block in the YAML).
"""
from __future__ import annotations

from dataclasses import fields

from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_control.parameters import (
    CONTROLLER_PARAMETERS,
    LIFT_CHECK_PARAMETERS,
    NODE_PARAMETERS,
)
from forte_control.state_machine import ControllerParams
from forte_control.state_machine.lift_check import LiftCheckParams
from forte_ros.parameter_table import replace_fields
from forte_ros.parameters import declare_table, parameter_update, read_table

#: Names of the ControllerParams fields, in field order.
CONTROLLER_FIELDS = [item.name for item in fields(ControllerParams)]

#: (dataclass, its parameter table) of each parameter group whose defaults are fields.
_GROUPS = ((ControllerParams, CONTROLLER_PARAMETERS), (LiftCheckParams, LIFT_CHECK_PARAMETERS))


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
    for kind, table in _GROUPS:
        missing = [item.name for item in fields(kind)
                   if item.name not in {spec.field for spec in table.values()}]
        if missing:
            raise KeyError(f'{kind.__name__} fields {missing} have no entry in the parameter '
                           'table (forte_control.parameters)')
        declare_table(node, table, kind())
    declare_table(node, NODE_PARAMETERS)


def read_controller_params(node: Node) -> ControllerParams:
    """The :class:`ControllerParams` given by the node's current parameter values."""
    return replace_fields(ControllerParams(), CONTROLLER_PARAMETERS,
                          read_table(node, CONTROLLER_PARAMETERS))


def read_lift_check(node: Node) -> LiftCheckParams:
    """The :class:`LiftCheckParams` given by the node's ``lift_check.*`` parameter values."""
    return replace_fields(LiftCheckParams(), LIFT_CHECK_PARAMETERS,
                          read_table(node, LIFT_CHECK_PARAMETERS))


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
        Empty, or the reason a value is refused (cannot be converted, or outside its range
        or choices; then both dicts are empty).
    """
    changes = []
    for _, table in _GROUPS:
        values, error = parameter_update(parameters, table)
        if error:
            return {}, {}, error
        changes.append({table[name].field: value for name, value in values.items()})
    return changes[0], changes[1], ''
