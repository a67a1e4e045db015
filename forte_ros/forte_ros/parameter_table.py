"""The one shape of a FORTE node's parameter table: :class:`ParameterSpec`.

Pure Python (no rclpy), so that a pure core can check values against the same entries the
node declares (``forte_control``'s state machine does) and the offline tools can read the
defaults. :mod:`forte_ros.parameters` turns a table into ROS declarations and reads the
values back; nothing else declares a FORTE parameter.

A table is a ``dict`` name -> :class:`ParameterSpec` (build it with :func:`parameter_table`).
An entry's default is either its own (``default``, node-only parameters) or the default of
a field of the core dataclass the node builds (``field``, a dotted path such as
``'slip.window'``), so a default is written once, in the core; :func:`replace_fields` builds
the core dataclass back from parameter values through the same paths. Bounds are inclusive
at both ends, as ``FloatingPointRange`` / ``IntegerRange`` are.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ['ParameterSpec', 'field_default', 'parameter_table', 'range_problems',
           'replace_fields']


@dataclass(frozen=True)
class ParameterSpec:
    """One parameter: what it means, where its default lives and which values it may take.

    Parameters
    ----------
    name : str
        Parameter name on the node (``'lift_check.drop_force'`` for a nested YAML block).
    kind : type
        ``float``, ``int``, ``bool``, ``str`` or ``list`` (a list of strings).
    description : str
        One line for ``ros2 param describe`` (without the unit: :meth:`full_description`
        appends it).
    unit : str
        Unit, e.g. ``'rad/s'``; empty for dimensionless values, flags, text, and for
        descriptions that state their unit themselves.
    low, high : float, optional
        Inclusive range of a number; ``None`` for flags and text.
    integer_step : int
        Step of an integer range (0 and 1 both admit every integer in it).
    choices : tuple of str
        The allowed values of a text parameter (empty: any text).
    default : object, optional
        Default of a node-only parameter. ``None`` when ``field`` gives it.
    field : str, optional
        Dotted path of the core dataclass field whose default is this parameter's default
        (e.g. ``'slip.window'`` of :class:`forte_perception.pipeline.PipelineConfig`).
    read_only : bool
        The node refuses changes after start-up.
    """

    name: str
    kind: type
    description: str
    unit: str = ''
    low: float | None = None
    high: float | None = None
    integer_step: int = 1
    choices: tuple[str, ...] = ()
    default: Any = None
    field: str | None = None
    read_only: bool = False

    def accepts(self, value: object) -> bool:
        """True if ``value`` is inside the range / among the choices (type not checked)."""
        if self.choices:
            return value in self.choices
        if self.low is None or self.high is None:
            return True
        return isinstance(value, int | float) and math.isfinite(value) \
            and self.low <= value <= self.high

    def range_text(self) -> str:
        """The allowed values as text, e.g. ``'[0.001, 3.0] rad/s'`` or ``"'either' | 'both'"``."""
        if self.choices:
            return ' | '.join(repr(choice) for choice in self.choices)
        if self.low is None or self.high is None:
            return ''
        return f'[{self.low:g}, {self.high:g}]' + (f' {self.unit}' if self.unit else '')

    def full_description(self) -> str:
        """Description with unit, as shown by ``ros2 param describe``."""
        return self.description + (f' [{self.unit}]' if self.unit else '')

    def problem(self, value: object) -> str:
        """Why ``value`` is refused (range or choices), or ``''`` if it is accepted."""
        if self.accepts(value):
            return ''
        if self.choices:
            return f'{self.name} must be one of {self.range_text()}, got {value!r}'
        return f'{self.name}={value} outside {self.range_text()}'

    def convert(self, value: object) -> Any:
        """``value`` as :attr:`kind` (a ``list`` for a list of strings).

        Raises
        ------
        TypeError, ValueError
            ``value`` cannot be converted.
        """
        return list(value) if self.kind is list else self.kind(value)

    def default_from(self, defaults: object | None = None) -> Any:
        """The default value: :attr:`default`, or the :attr:`field` of ``defaults`` (an
        instance of the core dataclass), converted to :attr:`kind`.

        Raises
        ------
        ValueError
            The default is a field and ``defaults`` is ``None``.
        AttributeError
            :attr:`field` is not a field of ``defaults`` (a stale table entry).
        """
        if self.field is None:
            value = self.default
        elif defaults is None:
            raise ValueError(f'{self.name}: its default is the field {self.field!r} of the '
                             'core dataclass, and no dataclass instance was given')
        else:
            value = field_default(defaults, self.field)
        return self.convert(value)


def field_default(instance: object, path: str) -> Any:
    """The value at dotted ``path`` of a (nested) dataclass ``instance``.

    Raises
    ------
    AttributeError
        A part of ``path`` is not a field (a stale table entry fails loudly).
    """
    value = instance
    for part in path.split('.'):
        if not dataclasses.is_dataclass(value) or part not in {
                item.name for item in dataclasses.fields(value)}:
            raise AttributeError(f'{type(value).__name__} has no field {part!r} ({path})')
        value = getattr(value, part)
    return value


def parameter_table(specs: Iterable[ParameterSpec]) -> dict[str, ParameterSpec]:
    """``{name: spec}`` of ``specs`` in their order; a repeated name raises ``ValueError``."""
    table: dict[str, ParameterSpec] = {}
    for spec in specs:
        if spec.name in table:
            raise ValueError(f'parameter {spec.name!r} is in the table twice')
        table[spec.name] = spec
    return table


def range_problems(tables: Iterable[Mapping[str, ParameterSpec]],
                   values: Mapping[str, object]) -> list[str]:
    """Reasons why values are outside their parameter's range or choices.

    Parameters
    ----------
    tables : iterable of mapping
        Parameter tables; a name is looked up in each in turn.
    values : mapping
        Parameter name -> value; names in no table are ignored.

    Returns
    -------
    list of str
        One reason per refused value (:meth:`ParameterSpec.problem`); empty when all fit.
    """
    tables = list(tables)
    out = []
    for name, value in values.items():
        spec = next((table[name] for table in tables if name in table), None)
        if spec is not None and (reason := spec.problem(value)):
            out.append(reason)
    return out


def replace_fields(instance: Any, table: Mapping[str, ParameterSpec],
                   values: Mapping[str, object]) -> Any:
    """A copy of the (nested, possibly frozen) dataclass ``instance`` with the fields of the
    parameters in ``values`` replaced.

    Parameters
    ----------
    instance : dataclass instance
        The core dataclass (e.g. its defaults, or the configuration in use).
    table : mapping
        Parameter table; an entry's :attr:`ParameterSpec.field` names the field it sets.
    values : mapping
        Parameter name -> value, converted with :meth:`ParameterSpec.convert`; names not in
        the table, and entries without a field (node-only parameters), are ignored.

    Returns
    -------
    dataclass instance
        The new instance (``instance`` itself is not modified).

    Raises
    ------
    AttributeError
        A field path of the table is not a field of ``instance``.
    TypeError, ValueError
        A value cannot be converted to its parameter's kind.
    """
    by_field = {table[name].field: table[name].convert(value) for name, value in values.items()
                if name in table and table[name].field is not None}
    return _replace_paths(instance, by_field)


def _replace_paths(instance: Any, values: Mapping[str, object]) -> Any:
    """``instance`` with the values at dotted field paths replaced (nested dataclasses are
    replaced in turn)."""
    own: dict[str, object] = {}
    nested: dict[str, dict[str, object]] = {}
    for path, value in values.items():
        head, _, rest = path.partition('.')
        field_default(instance, head)  # a stale path raises AttributeError
        if rest:
            nested.setdefault(head, {})[rest] = value
        else:
            own[head] = value
    for head, inner in nested.items():
        own[head] = _replace_paths(getattr(instance, head), inner)
    return dataclasses.replace(instance, **own) if own else instance
