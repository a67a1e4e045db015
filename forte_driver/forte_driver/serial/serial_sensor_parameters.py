"""Parameters of the serial sensor node: declarations (descriptors, ranges) and the
validation of changes. Used by :mod:`forte_driver.serial.serial_sensor_node`; see the parameter
table in docs/serial_driver.md."""
from __future__ import annotations

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)


def declare_parameters(node) -> None:
    """Declare every parameter of the serial sensor node (descriptors with ranges)."""
    def describe(text: str, **extra) -> ParameterDescriptor:
        return ParameterDescriptor(description=text, **extra)

    node.declare_parameter('port', '/dev/forte_sensor', describe(
        'serial device of the sensor board (udev name, see forte_driver/udev)'))
    node.declare_parameter('protocol', 'binary', describe(
        "'binary' (FORTE protocol v1) or 'ascii' (legacy T1:..,T6:.. lines)"))
    node.declare_parameter('baud_rate', 2000000, describe(
        'baud rate [bit/s]; ignored by USB CDC devices, used by UART bridges',
        integer_range=[IntegerRange(from_value=9600, to_value=12000000, step=0)]))
    node.declare_parameter('rtscts', False, describe(
        'hardware flow control (the legacy firmware used RTS/CTS)'))
    node.declare_parameter('sample_rate_hz', 2000, describe(
        'scan rate [Hz]: sent with SET_RATE (binary), nominal rate (ascii); '
        'must divide 1000000',
        integer_range=[IntegerRange(from_value=1, to_value=4000, step=0)]))
    node.declare_parameter('batch_size', 20, describe(
        'samples per TactileFrames message (a batch also ends at every gap)',
        integer_range=[IntegerRange(from_value=1, to_value=2000, step=0)]))
    node.declare_parameter('reliable', False, describe(
        'reliable QoS on tactile/frames (for recording); default sensor data QoS'))
    node.declare_parameter('frame_id', 'forte_base_link', describe(
        'frame_id of the published frames'))
    node.declare_parameter('reconnect_period', 0.5, describe(
        'time between attempts to reopen a lost device [s]',
        floating_point_range=[FloatingPointRange(from_value=0.05, to_value=60.0, step=0.0)]))
    node.declare_parameter('diagnostics_period', 1.0, describe(
        'period of /diagnostics messages [s]', read_only=True,
        floating_point_range=[FloatingPointRange(from_value=0.1, to_value=60.0, step=0.0)]))
    node.declare_parameter('clock_window', 20.0, describe(
        'device clock fit window [s]',
        floating_point_range=[FloatingPointRange(from_value=1.0, to_value=600.0, step=0.0)]))
    node.declare_parameter('autostart', False, describe(
        'configure and activate without a lifecycle manager (retries while the device '
        'is absent)', read_only=True))
    node.declare_parameter('error_hold', 5.0, describe(
        'a reader error keeps /diagnostics at ERROR this long [s]',
        floating_point_range=[FloatingPointRange(from_value=0.1, to_value=600.0, step=0.0)]))
    node.declare_parameter('command_timeout', 0.5, describe(
        'resend START if not acknowledged within this time [s]',
        floating_point_range=[FloatingPointRange(from_value=0.05, to_value=10.0, step=0.0)]))


def validate_parameters(parameters, state_label: str) -> SetParametersResult:
    """Accept or refuse a parameter change (only while unconfigured), with the reason."""
    for parameter in parameters:
        name, value = parameter.name, parameter.value
        if state_label != 'unconfigured':
            return SetParametersResult(
                successful=False,
                reason=f'{name}: change parameters only while unconfigured '
                       f'(now {state_label}); deactivate and clean up first')
        if name == 'protocol' and value not in ('binary', 'ascii'):
            return SetParametersResult(
                successful=False, reason=f"protocol must be 'binary' or 'ascii', not {value!r}")
        if name == 'sample_rate_hz' and (
                parameter.type_ != ParameterType.PARAMETER_INTEGER or value < 1
                or 1_000_000 % value != 0):
            return SetParametersResult(
                successful=False,
                reason=f'sample_rate_hz must be a positive integer dividing 1000000 '
                       f'(e.g. 2000), got {value!r}')
        if name in ('port', 'frame_id') and not value:
            return SetParametersResult(successful=False, reason=f'{name} must not be empty')
    return SetParametersResult(successful=True)
