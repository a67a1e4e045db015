"""ROS side of the FORTE parameter tables: declare a table on a node, read it back.

Every node keeps its parameters in one table of :class:`forte_ros.parameter_table.
ParameterSpec` entries (built with :func:`forte_ros.parameter_table.parameter_table`). This
module is the only place that turns an entry into an ``rcl_interfaces/ParameterDescriptor``
(:func:`spec_descriptor`) and declares it (:func:`declare_table`), so the mapping from an
entry's range to ``FloatingPointRange`` / ``IntegerRange`` and the declaration loop are
written once. :func:`read_table` gives the current values converted to each entry's kind;
:func:`parameter_update` checks a parameter update in an on-set-parameters callback.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_ros.parameter_table import ParameterSpec

__all__ = ['declare_table', 'parameter_update', 'read_table', 'spec_descriptor']

#: ``ParameterType`` of each :attr:`ParameterSpec.kind`.
PARAMETER_TYPES = {float: ParameterType.PARAMETER_DOUBLE, int: ParameterType.PARAMETER_INTEGER,
                   bool: ParameterType.PARAMETER_BOOL, str: ParameterType.PARAMETER_STRING,
                   list: ParameterType.PARAMETER_STRING_ARRAY}


def spec_descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    """The ``ParameterDescriptor`` of one table entry.

    Parameters
    ----------
    spec : ParameterSpec
        Table entry.

    Returns
    -------
    rcl_interfaces.msg.ParameterDescriptor
        Name, type, description with the unit (:meth:`ParameterSpec.full_description`) and
        read-only flag; for a number with ``low`` and ``high``, its inclusive range (an
        ``IntegerRange`` with :attr:`ParameterSpec.integer_step` for an ``int``, else a
        ``FloatingPointRange`` with step 0: any value inside); for a text with choices,
        ``additional_constraints`` listing them (``"one of 'either' | 'both'"``).
    """
    descriptor = ParameterDescriptor(name=spec.name, type=PARAMETER_TYPES[spec.kind],
                                     description=spec.full_description(),
                                     read_only=spec.read_only)
    if spec.choices:
        descriptor.additional_constraints = f'one of {spec.range_text()}'
    elif spec.low is not None and spec.high is not None:
        if spec.kind is int:
            descriptor.integer_range = [IntegerRange(
                from_value=int(spec.low), to_value=int(spec.high), step=spec.integer_step)]
        elif spec.kind is float:
            descriptor.floating_point_range = [FloatingPointRange(
                from_value=float(spec.low), to_value=float(spec.high), step=0.0)]
    return descriptor


def declare_table(node: Node, table: Mapping[str, ParameterSpec],
                  defaults: object | None = None) -> None:
    """Declare every entry of ``table`` on ``node``, in the table's order.

    Parameters
    ----------
    node : rclpy.node.Node
        The node (a parameter override given at start-up replaces the default).
    table : mapping
        Parameter name -> :class:`ParameterSpec`.
    defaults : dataclass instance, optional
        The core dataclass whose fields hold the defaults of the entries with a
        :attr:`ParameterSpec.field`; needed only when the table has such entries.

    Raises
    ------
    ValueError
        An entry's default is a field and ``defaults`` is ``None``.
    AttributeError
        An entry's field is not a field of ``defaults`` (a stale table entry).
    """
    for spec in table.values():
        node.declare_parameter(spec.name, spec.default_from(defaults), spec_descriptor(spec))


def read_table(node: Node, table: Mapping[str, ParameterSpec],
               names: Iterable[str] | None = None) -> dict[str, Any]:
    """The node's current values of the table's parameters, converted to their kinds.

    Parameters
    ----------
    node : rclpy.node.Node
        A node on which ``table`` was declared (:func:`declare_table`).
    table : mapping
        Parameter name -> :class:`ParameterSpec`.
    names : iterable of str, optional
        Only these parameters (default: every entry, in the table's order).

    Returns
    -------
    dict
        Parameter name -> value (``float``, ``int``, ``bool``, ``str`` or ``list``).
    """
    return {name: table[name].convert(node.get_parameter(name).value)
            for name in (table if names is None else names)}


def parameter_update(parameters: Iterable[Parameter], table: Mapping[str, ParameterSpec]
                     ) -> tuple[dict[str, Any], str]:
    """The values a parameter update gives the table's parameters, or why it is refused.

    For an on-set-parameters callback: rclpy has already checked the types and numeric
    ranges against the descriptors; this converts each value to its entry's kind and
    checks it with :meth:`ParameterSpec.problem` (which also covers the choices of a text,
    which a descriptor only lists).

    Parameters
    ----------
    parameters : iterable of rclpy.parameter.Parameter
        The update; parameters not in ``table`` are ignored.
    table : mapping
        Parameter name -> :class:`ParameterSpec`.

    Returns
    -------
    values : dict
        Parameter name -> converted value of every parameter of ``table`` in the update
        (empty when refused).
    reason : str
        Empty, or why the first refused value is refused (then ``values`` is empty).
    """
    values: dict[str, Any] = {}
    for parameter in parameters:
        spec = table.get(parameter.name)
        if spec is None:
            continue
        try:
            value = spec.convert(parameter.value)
        except (TypeError, ValueError) as error:
            return {}, f'{parameter.name}: {error}'
        problem = spec.problem(value)
        if problem:
            return {}, problem
        values[parameter.name] = value
    return values, ''
