"""Parameter descriptors of the FORTE nodes: one way to turn a table entry into one.

Every node declares its parameters from a table (name, default, description, inclusive
range, read-only); these helpers build the ``rcl_interfaces/ParameterDescriptor`` of an
entry, so the mapping from a range to ``IntegerRange`` / ``FloatingPointRange`` is written
once.
"""
from __future__ import annotations

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

__all__ = ['parameter_descriptor', 'with_range']


def with_range(descriptor: ParameterDescriptor, low: float, high: float, integer: bool,
               integer_step: int = 1) -> ParameterDescriptor:
    """Set the inclusive range ``[low, high]`` of a numeric parameter on ``descriptor``.

    Parameters
    ----------
    descriptor : rcl_interfaces.msg.ParameterDescriptor
        Modified in place and returned.
    low, high : float
        Inclusive bounds, in the parameter's unit.
    integer : bool
        An ``IntegerRange`` (with ``integer_step``; 0 and 1 both admit every integer) rather
        than a ``FloatingPointRange`` (step 0: any value inside).
    integer_step : int
        Step of an integer range.
    """
    if integer:
        descriptor.integer_range = [IntegerRange(from_value=int(low), to_value=int(high),
                                                 step=integer_step)]
    else:
        descriptor.floating_point_range = [FloatingPointRange(
            from_value=float(low), to_value=float(high), step=0.0)]
    return descriptor


def parameter_descriptor(description: str, default: object,
                         bounds: tuple[float, float] | None = None, read_only: bool = False,
                         integer_step: int = 1) -> ParameterDescriptor:
    """The descriptor of a parameter whose type is that of ``default``.

    A range applies to numbers only: an ``int`` default gets an ``IntegerRange``, a ``float``
    default a ``FloatingPointRange``; a ``bool`` or text default gets none.
    """
    descriptor = ParameterDescriptor(description=description, read_only=read_only)
    if bounds is None or isinstance(default, (bool, str)):
        return descriptor
    return with_range(descriptor, bounds[0], bounds[1], isinstance(default, int), integer_step)
