"""Lifecycle node: the FORTE tactile sensor board on a serial port -> tactile/frames.

Thin ROS shell around :mod:`forte_driver.protocol` (decoding, drop/corruption accounting,
batching) and :mod:`forte_driver.clock_sync` (device clock -> ROS time).

Lifecycle
---------
- configure: open the port (``port``, default the udev name ``/dev/forte_sensor``), start
  the reader thread; binary protocol: STOP (in case it still streams) and IDENTIFY.
- activate: binary: SET_RATE and START (resent until acknowledged); publish batches.
- deactivate: STOP, publish the partial batch, stop publishing.
- cleanup / shutdown: stop the reader thread, close the port.
- device lost while active (read/write error, cable pulled): the node deactivates itself,
  retries opening ``port`` every ``reconnect_period`` seconds and re-activates when the
  device is back.

Threads: one reader thread owns all reads (never an executor callback), decodes and
publishes; executor callbacks only write short commands, run the supervisor and publish
diagnostics.

Topics: ``tactile/frames`` (forte_msgs/TactileFrames, sensor-data QoS or reliable with
``reliable:=true``), ``/diagnostics`` (diagnostic_msgs/DiagnosticArray).
"""
from __future__ import annotations

import array
import threading
import time
from dataclasses import dataclass

import serial
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from rclpy.time import Time

from forte_driver import protocol
from forte_driver.clock_sync import ClockSync
from forte_driver.protocol import (
    Ack,
    AsciiLineDecoder,
    AsciiSample,
    Command,
    CorruptFrame,
    FrameDecoder,
    Info,
    Sample,
    Status,
    StreamAssembler,
)
from forte_msgs.msg import TactileFrames
from forte_ros import ForteLifecycleNode, publish_quietly, run_node

FRAMES_TOPIC = 'tactile/frames'
DIAGNOSTICS_TOPIC = '/diagnostics'


@dataclass
class _Window:
    """Counters of the current diagnostics period."""

    samples: int = 0
    latency_sum_s: float = 0.0
    latency_max_s: float = 0.0
    latency_count: int = 0
    started_ns: int = 0


class SerialSensorNode(ForteLifecycleNode):
    """Managed driver of the FORTE sensor board (binary protocol v1 or legacy ASCII)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('serial_sensor_node', **kwargs)
        self._declare_parameters()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._state_label = 'unconfigured'
        self._lock = threading.Lock()          # counters, assembler, clock
        self._publish_lock = threading.Lock()  # keeps batches in order across threads
        self._autostart_pending = bool(self.get_parameter('autostart').value)
        self._port_lock = threading.Lock()     # the serial port object
        self._port: serial.Serial | None = None
        self._reader: threading.Thread | None = None
        self._reader_stop = threading.Event()
        self._device_lost = threading.Event()
        self._publishing = False
        self._auto_reactivate = False
        self._last_reconnect_attempt = 0.0
        self._frames_publisher = None
        #: publishes dropped because the process was stopping (``late_publishes``)
        self.late = {'late_publishes': 0}
        self._diagnostics_publisher = self.create_publisher(
            DiagnosticArray, DIAGNOSTICS_TOPIC,
            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
        self._token = 0
        self._start_token: int | None = None
        self._start_sent_at = 0.0
        self._start_acknowledged = False
        self._rate_acknowledged_hz: int | None = None
        self._info: Info | None = None
        self._reconnects = 0
        self._published_batches = 0
        self._published_samples = 0
        self._last_error = ''
        self._window = _Window()
        self._reset_stream_state()
        self._supervisor = self.create_timer(0.1, self._supervise)
        self._diagnostics_timer = self.create_timer(
            self.get_parameter('diagnostics_period').value, self._publish_diagnostics)

    @property
    def lifecycle_state(self) -> str:
        """Current lifecycle state label: unconfigured, inactive, active or finalized."""
        return self._state_label

    @property
    def counters(self) -> dict[str, int]:
        """Cumulative stream counters (the same numbers as in the messages/diagnostics)."""
        with self._lock:
            decoder = self._decoder if self._binary else self._ascii
            return {'received_samples': self._assembler.samples,
                    'published_samples': self._published_samples,
                    'published_batches': self._published_batches,
                    'dropped_frames': self._assembler.dropped_frames,
                    'corrupt_frames': self._assembler.corrupt_frames,
                    'device_overruns': self._assembler.device_overruns,
                    'discarded_bytes': decoder.discarded_bytes,
                    'reconnects': self._reconnects}

    # ---- parameters ---------------------------------------------------------------------

    def _declare_parameters(self) -> None:
        def describe(text: str, **extra) -> ParameterDescriptor:
            return ParameterDescriptor(description=text, **extra)

        self.declare_parameter('port', '/dev/forte_sensor', describe(
            'serial device of the sensor board (udev name, see forte_driver/udev)'))
        self.declare_parameter('protocol', 'binary', describe(
            "'binary' (FORTE protocol v1) or 'ascii' (legacy T1:..,T6:.. lines)"))
        self.declare_parameter('baud_rate', 2000000, describe(
            'baud rate [bit/s]; ignored by USB CDC devices, used by UART bridges',
            integer_range=[IntegerRange(from_value=9600, to_value=12000000, step=0)]))
        self.declare_parameter('rtscts', False, describe(
            'hardware flow control (the legacy firmware used RTS/CTS)'))
        self.declare_parameter('sample_rate_hz', 2000, describe(
            'scan rate [Hz]: sent with SET_RATE (binary), nominal rate (ascii); '
            'must divide 1000000',
            integer_range=[IntegerRange(from_value=1, to_value=4000, step=0)]))
        self.declare_parameter('batch_size', 20, describe(
            'samples per TactileFrames message (a batch also ends at every gap)',
            integer_range=[IntegerRange(from_value=1, to_value=2000, step=0)]))
        self.declare_parameter('reliable', False, describe(
            'reliable QoS on tactile/frames (for recording); default sensor data QoS'))
        self.declare_parameter('frame_id', 'forte_base_link', describe(
            'frame_id of the published frames'))
        self.declare_parameter('reconnect_period', 0.5, describe(
            'time between attempts to reopen a lost device [s]',
            floating_point_range=[FloatingPointRange(from_value=0.05, to_value=60.0, step=0.0)]))
        self.declare_parameter('diagnostics_period', 1.0, describe(
            'period of /diagnostics messages [s]', read_only=True,
            floating_point_range=[FloatingPointRange(from_value=0.1, to_value=60.0, step=0.0)]))
        self.declare_parameter('clock_window', 20.0, describe(
            'device clock fit window [s]',
            floating_point_range=[FloatingPointRange(from_value=1.0, to_value=600.0, step=0.0)]))
        self.declare_parameter('autostart', False, describe(
            'configure and activate without a lifecycle manager (retries while the device '
            'is absent)', read_only=True))
        self.declare_parameter('command_timeout', 0.5, describe(
            'resend START if not acknowledged within this time [s]',
            floating_point_range=[FloatingPointRange(from_value=0.05, to_value=10.0, step=0.0)]))

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        for parameter in parameters:
            name, value = parameter.name, parameter.value
            if self._state_label != 'unconfigured':
                return SetParametersResult(
                    successful=False,
                    reason=f'{name}: change parameters only while unconfigured '
                           f'(now {self._state_label}); deactivate and clean up first')
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

    # ---- stream state ----------------------------------------------------------------------

    def _reset_stream_state(self) -> None:
        batch_size = self.get_parameter('batch_size').value
        self._binary = self.get_parameter('protocol').value == 'binary'
        self._rate_hz = self.get_parameter('sample_rate_hz').value
        self._period_us = 1_000_000 // self._rate_hz
        bytes_per_sample = protocol.SAMPLE_FRAME_SIZE if self._binary else 64
        self._read_size = bytes_per_sample * batch_size
        # one batch period plus margin, at most 50 ms (bounds the stop latency)
        self._read_timeout = min(0.05, 1.5 * batch_size / self._rate_hz)
        self._decoder = FrameDecoder()
        self._ascii = AsciiLineDecoder()
        self._assembler = StreamAssembler(batch_size)
        self._clock_sync = ClockSync(window_s=self.get_parameter('clock_window').value)

    # ---- lifecycle ----------------------------------------------------------------------

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._reset_stream_state()
        reliable = self.get_parameter('reliable').value
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=50,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.VOLATILE)
        self._frames_publisher = self.create_lifecycle_publisher(TactileFrames, FRAMES_TOPIC, qos)
        if not self._open_port():
            self.destroy_lifecycle_publisher(self._frames_publisher)
            self._frames_publisher = None
            return TransitionCallbackReturn.FAILURE
        self._reader_stop.clear()
        self._reader = threading.Thread(target=self._read_loop, name='forte-serial-reader',
                                        daemon=True)
        self._reader.start()
        if self._binary:
            self._send_command(Command.STOP)
            self._send_command(Command.IDENTIFY)
        self._state_label = 'inactive'
        self.get_logger().info(f'configured: {self.get_parameter("port").value} '
                               f'({self.get_parameter("protocol").value})')
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self._port is None:
            self.get_logger().error('activate: the device is not connected')
            return TransitionCallbackReturn.FAILURE
        with self._lock:
            self._assembler.start_session()
            self._assembler.take_batches()
            self._window = _Window(started_ns=self.get_clock().now().nanoseconds)
        self._start_acknowledged = not self._binary
        if self._binary:
            self._send_command(Command.SET_RATE, self._rate_hz)
            self._send_start()
        self._publishing = True
        self._auto_reactivate = False
        self._state_label = 'active'
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self._binary:
            self._send_command(Command.STOP)
        with self._publish_lock:
            with self._lock:
                self._assembler.flush()
                batches = self._assembler.take_batches()
            self._publish_batches(batches)
            self._publishing = False
        self._state_label = 'inactive'
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._shutdown_io()
        self._state_label = 'unconfigured'
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self._publishing and self._binary:
            self._send_command(Command.STOP)
        self._publishing = False
        self._shutdown_io()
        self._state_label = 'finalized'
        self.get_logger().info(f'shut down from {state.label}: reader stopped, port closed')
        return TransitionCallbackReturn.SUCCESS

    def _shutdown_io(self) -> None:
        self._auto_reactivate = False
        self._reader_stop.set()
        if self._reader is not None:
            self._reader.join(timeout=2.0)
            self._reader = None
        self._close_port()
        if self._frames_publisher is not None:
            self.destroy_lifecycle_publisher(self._frames_publisher)
            self._frames_publisher = None

    # ---- port -------------------------------------------------------------------------

    def _open_port(self) -> bool:
        port_name = self.get_parameter('port').value
        try:
            port = serial.Serial(port_name, baudrate=self.get_parameter('baud_rate').value,
                                 rtscts=self.get_parameter('rtscts').value,
                                 timeout=self._read_timeout,
                                 write_timeout=0.5, exclusive=True)
            port.reset_input_buffer()
        except (serial.SerialException, OSError, ValueError) as error:
            self._last_error = f'cannot open {port_name}: {error}'
            return False
        with self._lock:
            self._decoder.reset()
            self._ascii.reset()
            self._clock_sync.reset()
            self._assembler.start_session()
        with self._port_lock:
            self._port = port
        self._device_lost.clear()
        return True

    def _close_port(self) -> None:
        with self._port_lock:
            port, self._port = self._port, None
        if port is not None:
            try:
                port.close()
            except (serial.SerialException, OSError):
                pass

    def _lose_device(self, error: Exception) -> None:
        self._last_error = f'device lost: {error}'
        self._close_port()
        self._device_lost.set()

    def _send_command(self, command: Command, argument: int = 0) -> int:
        self._token = (self._token + 1) % 256
        data = protocol.encode_command(command, self._token, argument)
        with self._port_lock:
            port = self._port
            if port is None:
                return self._token
            try:
                port.write(data)
            except (serial.SerialException, OSError) as error:
                self._last_error = f'write failed: {error}'
        return self._token

    def _send_start(self) -> None:
        self._start_acknowledged = False
        self._start_token = self._send_command(Command.START)
        self._start_sent_at = time.monotonic()

    # ---- reader thread ---------------------------------------------------------------------

    def _read_loop(self) -> None:
        while not self._reader_stop.is_set():
            port = self._port
            if port is None:
                time.sleep(0.02)
                continue
            try:
                # wait for one batch worth of bytes (a batch cannot be published earlier,
                # so this adds no latency) or the port timeout; take all that is there
                data = port.read(max(self._read_size, port.in_waiting))
            except (serial.SerialException, OSError, TypeError, AttributeError) as error:
                if not self._reader_stop.is_set() and self._port is port:
                    self._lose_device(error)
                continue
            if not data:
                continue
            received_ns = self.get_clock().now().nanoseconds
            with self._publish_lock:
                batches = self._decode(data, received_ns)
                if self._publishing:
                    self._publish_batches(batches)

    def _decode(self, data: bytes, received_ns: int) -> list:
        with self._lock:
            assembler = self._assembler
            if self._binary:
                newest_time_us = None
                for item in self._decoder.feed(data):
                    if isinstance(item, Sample):
                        assembler.add_sample(item)
                        newest_time_us = item.time_us
                    elif isinstance(item, CorruptFrame):
                        assembler.add_corrupt()
                    elif isinstance(item, Ack):
                        self._on_ack(item)
                    elif isinstance(item, Info):
                        self._info = item
                if newest_time_us is not None:
                    self._clock_sync.add(newest_time_us, received_ns)
                    latency = self._clock_sync.last_latency_s
                    if latency is not None:
                        window = self._window
                        window.latency_sum_s += latency
                        window.latency_count += 1
                        window.latency_max_s = max(window.latency_max_s, latency)
            else:
                items = self._ascii.feed(data)
                lines = sum(1 for item in items if isinstance(item, AsciiSample))
                received_us = received_ns // 1000
                index = 0
                for item in items:
                    if isinstance(item, AsciiSample):
                        # caveat: receive time, the last line of the chunk taken as newest
                        time_us = received_us - (lines - 1 - index) * self._period_us
                        assembler.add_ascii_sample(item, time_us)
                        index += 1
                    else:
                        assembler.add_corrupt()
            batches = assembler.take_batches()
            if not self._publishing:
                return []
            self._window.samples += sum(len(batch.values) for batch in batches)
            return batches

    def _on_ack(self, ack: Ack) -> None:
        if ack.command == Command.START:
            if ack.token == self._start_token and ack.status == Status.OK:
                self._start_acknowledged = True
                self._assembler.start_session(from_zero=True)
            elif ack.status == Status.BUSY:
                # still streaming from an earlier session: stop and start again
                self._send_command(Command.STOP)
                self._send_start()
        elif ack.command == Command.SET_RATE:
            if ack.status == Status.OK:
                self._rate_acknowledged_hz = ack.value
            else:
                self._last_error = (f'SET_RATE {self._rate_hz} Hz refused (status '
                                    f'{ack.status}); device rate {ack.value} Hz')

    def _publish_batches(self, batches) -> None:
        publisher = self._frames_publisher
        if publisher is None or not batches:
            return
        frame_id = self.get_parameter('frame_id').value
        for batch in batches:
            message = TactileFrames()
            if self._binary:
                with self._lock:
                    stamp_ns = self._clock_sync.to_host_ns(batch.device_time_us)
                if stamp_ns is None:
                    continue  # cannot happen: a sample always precedes its batch
                message.device_time_us = batch.device_time_us
            else:
                stamp_ns = batch.device_time_us * 1000
                message.device_time_us = 0
            message.header.stamp = Time(nanoseconds=stamp_ns).to_msg()
            message.header.frame_id = frame_id
            message.first_sequence = batch.first_sequence
            message.sample_period = self._period_us * 1e-6
            message.channel_names = list(protocol.CHANNEL_NAMES)
            message.sample_count = len(batch.values)
            message.data = array.array('d', batch.values.ravel().tobytes())
            message.dropped_frames = self._assembler.dropped_frames
            message.corrupt_frames = self._assembler.corrupt_frames
            if not publish_quietly(publisher, message, self.context, self.late):
                return  # the process is stopping
            self._published_batches += 1
            self._published_samples += len(batch.values)

    # ---- supervisor ----------------------------------------------------------------------

    def _supervise(self) -> None:
        if self._autostart_pending:
            self._autostart()
        if self._device_lost.is_set() and self._state_label == 'active':
            self.get_logger().warning(f'{self._last_error}; deactivating, will reconnect')
            self.trigger_deactivate()
            self._auto_reactivate = True
        if self._state_label == 'inactive' and self._port is None:
            now = time.monotonic()
            if now - self._last_reconnect_attempt >= self.get_parameter('reconnect_period').value:
                self._last_reconnect_attempt = now
                if self._open_port():
                    self._reconnects += 1
                    self.get_logger().info('device back')
                    if self._binary:
                        self._send_command(Command.STOP)
                        self._send_command(Command.IDENTIFY)
                    if self._auto_reactivate:
                        self.trigger_activate()
        if (self._state_label == 'active' and self._binary and not self._start_acknowledged
                and time.monotonic() - self._start_sent_at
                > self.get_parameter('command_timeout').value):
            self._send_start()

    def _autostart(self) -> None:
        now = time.monotonic()
        if self._state_label == 'unconfigured':
            if now - self._last_reconnect_attempt < self.get_parameter('reconnect_period').value:
                return
            self._last_reconnect_attempt = now
            self.trigger_configure()
            if self._state_label == 'unconfigured':
                self.get_logger().warning(f'autostart: {self._last_error}; retrying',
                                          throttle_duration_sec=10.0)
        if self._state_label == 'inactive':
            self._autostart_pending = False
            self.trigger_activate()

    # ---- diagnostics ----------------------------------------------------------------------

    def _publish_diagnostics(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        with self._lock:
            window, self._window = self._window, _Window(started_ns=now_ns)
            assembler = self._assembler
            decoder = self._decoder if self._binary else self._ascii
            model = self._clock_sync.model
            values = {
                'state': self._state_label,
                'port': self.get_parameter('port').value,
                'protocol': self.get_parameter('protocol').value,
                'connected': str(self._port is not None),
                'nominal_rate_hz': str(self._rate_hz),
                'samples_published': str(self._published_samples),
                'batches_published': str(self._published_batches),
                'dropped_frames': str(assembler.dropped_frames),
                'device_overruns': str(assembler.device_overruns),
                'corrupt_frames': str(assembler.corrupt_frames),
                'discarded_bytes': str(decoder.discarded_bytes),
                'sequence_resets': str(assembler.tracker.sequence_resets),
                'reconnects': str(self._reconnects),
                'start_acknowledged': str(self._start_acknowledged),
                'clock_drift_ppm': f'{self._clock_sync.drift_ppm:.2f}',
                'clock_resets': str(self._clock_sync.resets),
            }
            if model is not None:
                values['clock_offset_s'] = f'{model.to_host_ns(0) * 1e-9:.6f}'
            if self._info is not None:
                info = self._info
                values['device_id'] = f'{info.device_id:016x}'
                values['firmware'] = '.'.join(map(str, info.firmware_version))
            if self._last_error:
                values['last_error'] = self._last_error
        elapsed_s = (now_ns - window.started_ns) * 1e-9 if window.started_ns else 0.0
        rate = window.samples / elapsed_s if elapsed_s > 0 else 0.0
        values['achieved_rate_hz'] = f'{rate:.1f}'
        if window.latency_count:
            values['latency_mean_ms'] = f'{1e3 * window.latency_sum_s / window.latency_count:.3f}'
            values['latency_max_ms'] = f'{1e3 * window.latency_max_s:.3f}'
        status = DiagnosticStatus(name=f'{self.get_name()}: tactile sensor',
                                  hardware_id=values.get('device_id', values['port']))
        if self._state_label == 'active' and self._port is None:
            status.level, status.message = DiagnosticStatus.ERROR, 'device lost, reconnecting'
        elif self._state_label == 'inactive' and self._port is None:
            status.level, status.message = DiagnosticStatus.ERROR, 'device not connected'
        elif self._state_label == 'active' and rate < 0.9 * self._rate_hz:
            status.level = DiagnosticStatus.WARN
            status.message = f'rate {rate:.0f} Hz below nominal {self._rate_hz} Hz'
        else:
            status.level, status.message = DiagnosticStatus.OK, self._state_label
        status.values = [KeyValue(key=key, value=value) for key, value in values.items()]
        message = DiagnosticArray()
        message.header.stamp = Time(nanoseconds=now_ns).to_msg()
        message.status = [status]
        publish_quietly(self._diagnostics_publisher, message, self.context, self.late)


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT/SIGTERM; configure/activate it with a lifecycle manager or
    ``-p autostart:=true``. On the signal the node goes through its shutdown transition
    (STOP sent to the device, reader thread joined, port closed)."""
    return run_node(SerialSensorNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
