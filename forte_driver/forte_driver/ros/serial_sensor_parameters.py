"""Parameters of the serial sensor node: declarations (descriptors, ranges) and the
validation of changes. Used by :mod:`forte_driver.ros.serial_sensor_node`; see the parameter
table in docs/serial_driver.md."""
from __future__ import annotations

from rcl_interfaces.msg import ParameterType, SetParametersResult
from rclpy.node import Node

from forte_ros.contract import BASE_FRAME, SAMPLE_RATE
from forte_ros.parameter_table import ParameterSpec, parameter_table
from forte_ros.parameters import declare_table

#: Every parameter of the node, in the order of declaration (all node-only: their defaults
#: are here). Integer ranges have step 0 (any integer inside).
PARAMETERS: dict[str, ParameterSpec] = parameter_table([
    ParameterSpec('port', str, 'serial device of the sensor board (udev name, see '
                  'forte_driver/udev)', default='/dev/forte_sensor'),
    ParameterSpec('protocol', str, "'binary' (FORTE protocol v1) or 'ascii' (legacy "
                  "T1:..,T6:.. lines)", default='binary'),
    ParameterSpec('baud_rate', int, 'baud rate [bit/s]; ignored by USB CDC devices, used by '
                  'UART bridges', low=9600, high=12000000, integer_step=0, default=2000000),
    ParameterSpec('rtscts', bool, 'hardware flow control (the legacy firmware used RTS/CTS)',
                  default=False),
    ParameterSpec('sample_rate_hz', int, 'scan rate [Hz]: sent with SET_RATE (binary), '
                  'nominal rate (ascii); must divide 1000000', low=1, high=4000,
                  integer_step=0, default=int(SAMPLE_RATE)),
    ParameterSpec('batch_size', int, 'samples per TactileFrames message (a batch also ends '
                  'at every gap)', low=1, high=2000, integer_step=0, default=20),
    ParameterSpec('reliable', bool, 'reliable QoS on tactile/frames (for recording); default '
                  'sensor data QoS', default=False),
    ParameterSpec('frame_id', str, 'frame_id of the published frames (prefix prepended)',
                  default=BASE_FRAME),
    ParameterSpec('prefix', str, "TF prefix prepended to frame_id (e.g. right_; '' = none)",
                  default='', read_only=True),
    ParameterSpec('reconnect_period', float, 'time between attempts to reopen a lost device',
                  's', 0.05, 60.0, default=0.5),
    ParameterSpec('diagnostics_period', float, 'period of /diagnostics messages', 's', 0.1,
                  60.0, default=1.0, read_only=True),
    ParameterSpec('clock_window', float, 'device clock fit window', 's', 1.0, 600.0,
                  default=20.0),
    ParameterSpec('autostart', bool, 'configure and activate without a lifecycle manager '
                  '(retries while the device is absent)', default=False, read_only=True),
    ParameterSpec('error_hold', float, 'a reader error keeps /diagnostics at ERROR this long',
                  's', 0.1, 600.0, default=5.0),
    ParameterSpec('command_timeout', float, 'resend START if not acknowledged within this time',
                  's', 0.05, 10.0, default=0.5),
])


def declare_parameters(node: Node) -> None:
    """Declare every parameter of the serial sensor node (:data:`PARAMETERS`)."""
    declare_table(node, PARAMETERS)


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
