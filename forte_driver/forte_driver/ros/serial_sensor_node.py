"""Lifecycle node: the FORTE tactile sensor board on a serial port -> tactile/frames.

Thin ROS shell around :mod:`forte_driver.serial.protocol` (decoding, drop/corruption accounting,
batching) and :mod:`forte_driver.serial.clock_sync` (device clock -> ROS time).

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
diagnostics. No exception escapes the reader thread: each step (read, decode/assemble/
stamp, publish) is guarded, an unexpected exception is counted (``reader_errors``), logged
(throttled) and reported as ERROR in /diagnostics for ``error_hold`` seconds, and the
stream goes on. If the thread ends anyway, the supervisor restarts it (at most 5 times a
minute, then it deactivates the node with ERROR): never active and silently idle.

Topics: ``tactile/frames`` (forte_msgs/TactileFrames, sensor-data QoS or reliable with
``reliable:=true``), ``tactile/sensor_info`` (forte_msgs/SensorInfo, latched: the board's
answer to IDENTIFY, again when SET_RATE changes its rate), ``/diagnostics``
(diagnostic_msgs/DiagnosticArray).
"""
from __future__ import annotations

import array
import threading
import time
from dataclasses import dataclass

import serial
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.time import Time

from forte_driver.ros.serial_sensor_parameters import declare_parameters, validate_parameters
from forte_driver.serial import protocol
from forte_driver.serial.protocol import Ack, Command, Info, Status
from forte_driver.serial.reader_health import ERROR, WARN, ReaderHealth, diagnostics_level
from forte_driver.serial.sensor_stream import SensorStream, StampedBatch
from forte_msgs.msg import SensorInfo, TactileFrames
from forte_ros import ForteLifecycleNode, diagnostics, publish_quietly, run_node
from forte_ros.contract import CHANNEL_NAMES, prefixed
from forte_ros.qos import DIAGNOSTICS, SENSOR_INFO, frames_profile

FRAMES_TOPIC = 'tactile/frames'
DIAGNOSTICS_TOPIC = '/diagnostics'
SENSOR_INFO_TOPIC = 'tactile/sensor_info'
#: StreamAssembler counters reported in /diagnostics under their attribute names.
ASSEMBLER_COUNTERS = ('samples', 'dropped_frames', 'corrupt_frames', 'implausible_frames',
                      'duplicate_frames', 'late_frames', 'device_overruns', 'restarts')


@dataclass
class _Window:
    """Counters of the current diagnostics period."""

    samples: int = 0
    started_ns: int = 0


class SerialSensorNode(ForteLifecycleNode):
    """Managed driver of the FORTE sensor board (binary protocol v1 or legacy ASCII)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('serial_sensor_node', **kwargs)
        declare_parameters(self)
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
            DiagnosticArray, DIAGNOSTICS_TOPIC, DIAGNOSTICS)
        self._sensor_info_publisher = self.create_publisher(
            SensorInfo, SENSOR_INFO_TOPIC, SENSOR_INFO)
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
        self._injected_fault: BaseException | None = None
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
            assembler = self._stream.assembler
            return {'received_samples': assembler.samples,
                    'published_samples': self._published_samples,
                    'published_batches': self._published_batches,
                    'dropped_frames': assembler.dropped_frames,
                    'corrupt_frames': assembler.corrupt_frames,
                    'device_overruns': assembler.device_overruns,
                    'discarded_bytes': self._stream.discarded_bytes,
                    'reconnects': self._reconnects}

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        return validate_parameters(parameters, self._state_label)

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
        self._health = ReaderHealth(error_hold_s=self.get_parameter('error_hold').value)
        self._stream = SensorStream(self._binary, batch_size, self._period_us,
                                    self.get_parameter('clock_window').value, self._health)

    # ---- lifecycle ----------------------------------------------------------------------

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._reset_stream_state()
        qos = frames_profile(bool(self.get_parameter('reliable').value))
        self._frames_publisher = self.create_lifecycle_publisher(TactileFrames, FRAMES_TOPIC, qos)
        if not self._open_port():
            self.destroy_lifecycle_publisher(self._frames_publisher)
            self._frames_publisher = None
            return TransitionCallbackReturn.FAILURE
        self._reader_stop.clear()
        self._start_reader()
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
        self._health.clear_failure()
        if not self._reader_alive():
            self._start_reader()
        with self._lock:
            self._stream.assembler.start_session()
            self._stream.assembler.take_batches()
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
                stamped = self._stream.flush()
            self._publish_batches(stamped)
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
            self._stream.reconnected()
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

    def _start_reader(self) -> None:
        self._reader = threading.Thread(target=self._reader_main, name='forte-serial-reader',
                                        daemon=True)
        self._reader.start()

    def _reader_alive(self) -> bool:
        return self._reader is not None and self._reader.is_alive()

    def inject_reader_fault(self, error: BaseException) -> None:
        """Test and drill hook: the reader raises ``error`` while decoding the next chunk.

        An ``Exception`` exercises the per-step guard (counted, reported, the stream goes
        on); a ``BaseException`` such as ``SystemExit`` passes the guard and ends the
        thread, exercising the supervisor's restart.
        """
        self._injected_fault = error

    def _reader_main(self) -> None:
        try:
            self._read_loop()
        except BaseException as error:  # noqa: BLE001 - a bug: recorded, the thread ends
            # and the supervisor restarts it (re-raising would only print it again)
            self._health.record_thread_death(f'{type(error).__name__}: {error}',
                                             time.monotonic())

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
            except Exception as error:  # noqa: BLE001 - never let the reader die
                self._reader_error('read', error)
                continue
            if data:
                self._process_chunk(data)

    def _process_chunk(self, data: bytes) -> None:
        """Decode, stamp and publish one chunk; any exception is a counted reader error
        (publishing errors are caught per message in :meth:`_publish_batches`)."""
        try:
            received_ns = self.get_clock().now().nanoseconds  # before any lock wait
            with self._publish_lock:
                stamped = self._decode(data, received_ns)
                if self._publishing:
                    self._publish_batches(stamped)
        except Exception as error:  # noqa: BLE001 - counted, reported, stream goes on
            self._reader_error('decode', error)

    def _reader_error(self, step: str, error: Exception) -> None:
        with self._lock:
            text = self._health.record_error(step, error, time.monotonic())
        self._last_error = f'reader error: {text}'
        self.get_logger().error(f'{self._last_error} (reader_errors '
                                f'{self._health.reader_errors}); continuing',
                                throttle_duration_sec=5.0)

    def _decode(self, data: bytes, received_ns: int) -> list[StampedBatch]:
        with self._lock:
            if self._injected_fault is not None:
                error, self._injected_fault = self._injected_fault, None
                raise error
            stamped = self._stream.feed(data, received_ns, self._on_control)
            if not self._publishing:
                return []
            self._window.samples += sum(len(batch.values) for batch, _ in stamped)
            return stamped

    def _on_control(self, item: object) -> None:
        if isinstance(item, Ack):
            self._on_ack(item)
        elif isinstance(item, Info):
            self._info = item
            self._publish_identity()

    def _frame_id(self) -> str:
        """``frame_id`` with the node's ``prefix`` prepended."""
        return prefixed(str(self.get_parameter('frame_id').value),
                        str(self.get_parameter('prefix').value))

    def _publish_identity(self) -> None:
        """Latch the board's identity on ``tactile/sensor_info`` (reader thread)."""
        identity = protocol.sensor_identity(self._info, self._rate_acknowledged_hz)
        message = SensorInfo(**identity.to_dict())
        message.header.stamp = self.get_clock().now().to_msg()
        message.header.frame_id = self._frame_id()
        publish_quietly(self._sensor_info_publisher, message, self.context, self.late)

    def _on_ack(self, ack: Ack) -> None:
        if ack.command == Command.START:
            if ack.token == self._start_token and ack.status == Status.OK:
                self._start_acknowledged = True
                self._stream.assembler.start_session(from_zero=True)
            elif ack.status == Status.BUSY:
                # still streaming from an earlier session: stop and start again
                self._send_command(Command.STOP)
                self._send_start()
        elif ack.command == Command.SET_RATE:
            if ack.status == Status.OK:
                changed = ack.value != self._rate_acknowledged_hz
                self._rate_acknowledged_hz = ack.value
                if changed and self._info is not None:
                    self._publish_identity()
            else:
                self._last_error = (f'SET_RATE {self._rate_hz} Hz refused (status '
                                    f'{ack.status}); device rate {ack.value} Hz')

    def _publish_batches(self, stamped: list[StampedBatch]) -> None:
        publisher = self._frames_publisher
        if publisher is None or not stamped:
            return
        frame_id = self._frame_id()
        for batch, stamp_ns in stamped:
            try:
                message = TactileFrames()
                message.device_time_us = batch.device_time_us if self._binary else 0
                message.header.stamp = Time(nanoseconds=stamp_ns).to_msg()
                message.header.frame_id = frame_id
                message.first_sequence = batch.first_sequence
                message.sample_period = self._period_us * 1e-6
                message.channel_names = list(CHANNEL_NAMES)
                message.sample_count = len(batch.values)
                message.data = array.array('d', batch.values.ravel().tobytes())
                message.dropped_frames = self._stream.assembler.dropped_frames
                message.corrupt_frames = self._stream.assembler.corrupt_frames
                if not publish_quietly(publisher, message, self.context, self.late):
                    return  # the process is stopping
            except Exception as error:  # noqa: BLE001 - this batch is lost, counted
                self._reader_error('publish', error)
                continue
            self._published_batches += 1
            self._published_samples += len(batch.values)

    # ---- supervisor ----------------------------------------------------------------------

    def _supervise(self) -> None:
        if self._autostart_pending:
            self._autostart()
        if (self._state_label in ('inactive', 'active') and not self._reader_stop.is_set()
                and not self._health.failed and not self._reader_alive()):
            self._restart_reader()
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

    def _restart_reader(self) -> None:
        """The reader thread ended although it should run (a bug): restart it, or give up
        and deactivate when it keeps dying."""
        if self._health.allow_restart(time.monotonic()):
            self.get_logger().error(f'{self._health.last_error}; restarting the reader '
                                    f'(restart {self._health.reader_restarts})')
            self._start_reader()
            return
        self._last_error = f'reader thread keeps failing: {self._health.last_error}'
        self.get_logger().error(f'{self._last_error}; deactivating')
        if self._state_label == 'active':
            self.trigger_deactivate()

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
            stream = self._stream
            assembler, clock_sync = stream.assembler, stream.clock_sync
            latencies = stream.take_latencies()
            values = {
                'state': self._state_label,
                'port': self.get_parameter('port').value,
                'protocol': self.get_parameter('protocol').value,
                'connected': str(self._port is not None),
                'nominal_rate_hz': str(self._rate_hz),
                'samples_published': str(self._published_samples),
                'batches_published': str(self._published_batches),
                **{name: str(getattr(assembler, name)) for name in ASSEMBLER_COUNTERS},
                'last_rejection': assembler.last_rejection,
                'discarded_bytes': str(stream.discarded_bytes),
                'reader_errors': str(self._health.reader_errors),
                'reader_restarts': str(self._health.reader_restarts),
                'last_reader_error': self._health.last_error,
                'unstamped_samples': str(stream.unstamped_samples),
                'clock_rejected_observations': str(clock_sync.rejected_observations),
                'sequence_resets': str(assembler.tracker.sequence_resets),
                'reconnects': str(self._reconnects),
                'start_acknowledged': str(self._start_acknowledged),
                'clock_drift_ppm': f'{clock_sync.drift_ppm:.2f}',
                'clock_resets': str(clock_sync.resets),
            }
            if clock_sync.model is not None:
                values['clock_offset_s'] = f'{clock_sync.model.to_host_ns(0) * 1e-9:.6f}'
            if self._info is not None:
                info = self._info
                values['device_id'] = f'{info.device_id:016x}'
                values['firmware'] = '.'.join(map(str, info.firmware_version))
            if self._last_error:
                values['last_error'] = self._last_error
        elapsed_s = (now_ns - window.started_ns) * 1e-9 if window.started_ns else 0.0
        rate = window.samples / elapsed_s if elapsed_s > 0 else 0.0
        values['achieved_rate_hz'] = f'{rate:.1f}'
        if latencies:
            values['latency_mean_ms'] = f'{1e3 * sum(latencies) / len(latencies):.3f}'
            values['latency_max_ms'] = f'{1e3 * max(latencies):.3f}'
        level, text = diagnostics_level(
            self._state_label, self._port is not None, rate, self._rate_hz, self._health,
            time.monotonic())
        status = diagnostics.diagnostic_status(
            f'{diagnostics.node_path(self)}: tactile sensor',
            {ERROR: diagnostics.ERROR, WARN: diagnostics.WARN}.get(level, diagnostics.OK),
            text, values, hardware_id=values.get('device_id', values['port']))
        message = diagnostics.diagnostic_array(Time(nanoseconds=now_ns).to_msg(), [status])
        publish_quietly(self._diagnostics_publisher, message, self.context, self.late)


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT/SIGTERM; configure/activate it with a lifecycle manager or
    ``-p autostart:=true``. On the signal the node goes through its shutdown transition
    (STOP sent to the device, reader thread joined, port closed)."""
    return run_node(SerialSensorNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
