"""Parameters of the serial sensor node: declarations (descriptors, ranges) and the
validation of changes. Used by :mod:`forte_driver.ros.serial_sensor_node`; see the parameter
table in docs/serial_driver.md."""
from __future__ import annotations

from rcl_interfaces.msg import ParameterType, SetParametersResult

from forte_ros.contract import SAMPLE_RATE
from forte_ros.parameters import parameter_descriptor

#: Every parameter of the node: name -> (default, description, (low, high) range or None,
#: read only). A range is an integer range for an integer default, else a floating point
#: range; the table's order is the order of declaration.
PARAMETERS: dict[str, tuple[object, str, tuple[float, float] | None, bool]] = {
    'port': ('/dev/forte_sensor',
             'serial device of the sensor board (udev name, see forte_driver/udev)',
             None, False),
    'protocol': ('binary', "'binary' (FORTE protocol v1) or 'ascii' (legacy T1:..,T6:.. lines)",
                 None, False),
    'baud_rate': (2000000, 'baud rate [bit/s]; ignored by USB CDC devices, used by UART '
                  'bridges', (9600, 12000000), False),
    'rtscts': (False, 'hardware flow control (the legacy firmware used RTS/CTS)', None, False),
    'sample_rate_hz': (int(SAMPLE_RATE), 'scan rate [Hz]: sent with SET_RATE (binary), nominal '
                       'rate (ascii); must divide 1000000', (1, 4000), False),
    'batch_size': (20, 'samples per TactileFrames message (a batch also ends at every gap)',
                   (1, 2000), False),
    'reliable': (False, 'reliable QoS on tactile/frames (for recording); default sensor data '
                 'QoS', None, False),
    'frame_id': ('forte_base_link', 'frame_id of the published frames', None, False),
    'reconnect_period': (0.5, 'time between attempts to reopen a lost device [s]',
                         (0.05, 60.0), False),
    'diagnostics_period': (1.0, 'period of /diagnostics messages [s]', (0.1, 60.0), True),
    'clock_window': (20.0, 'device clock fit window [s]', (1.0, 600.0), False),
    'autostart': (False, 'configure and activate without a lifecycle manager (retries while '
                  'the device is absent)', None, True),
    'error_hold': (5.0, 'a reader error keeps /diagnostics at ERROR this long [s]',
                   (0.1, 600.0), False),
    'command_timeout': (0.5, 'resend START if not acknowledged within this time [s]',
                        (0.05, 10.0), False),
}


def declare_parameters(node) -> None:
    """Declare every parameter of the serial sensor node (:data:`PARAMETERS`)."""
    for name, (default, description, bounds, read_only) in PARAMETERS.items():
        node.declare_parameter(name, default,
                               parameter_descriptor(description, default, bounds, read_only,
                                                    integer_step=0))


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
