"""ROS 2 shell around :class:`forte_perception.pipeline.PerceptionPipeline`.

Subscribes ``tactile/frames`` (forte_msgs/TactileFrames, sensor-data QoS: best effort, keep
last 50), publishes ``tactile/state`` (forte_msgs/TactileState, reliable, keep last 50) at
every force instant inside an input message and at its end (one state per 20-sample message
at the default 100 Hz; a 200-sample message gives 10 states, so the force rate does not
depend on the driver's batch size), serves ``perception/tare`` (forte_msgs/srv/Tare) and
``perception/reset`` (std_srvs/srv/Trigger), and publishes ``/diagnostics`` at 1 Hz. In
``slip_mode: sequential`` it also subscribes ``gripper/command`` (forte_msgs/ServoCommand):
each change of the commanded angle opens the sequential detector's servo gate
(:mod:`forte_perception.slip.servo_gate`) at the pipeline sample of the command's stamp.

Model identity: the force model's ``metadata['sensor']`` (what ``forte_train_force``
recorded) is checked with :func:`forte_ros.sensor_identity.check_identity`, at load against
the ``sample_rate`` parameter and the contract's channel order (a mismatch refuses the
``model_path``), and again whenever the sensor identifies itself on ``tactile/sensor_info``
(forte_msgs/SensorInfo, latched): another rate, channel order or full scale -> the model is
not used (``force_valid`` false, diagnostics ERROR ``force model refused: ...``); another
device or firmware -> the model is used, diagnostics WARN (recalibrate).

Input checks (each counted, reported in diagnostics, never invented):

- ``first_sequence`` must continue the previous message (``previous first_sequence +
  sample_count``). A jump forward is a gap of that many samples; a jump backwards (driver
  restart, looped replay) is a discontinuity. Both restart the pipeline's median filter,
  contact window and slip detector (see ``forte_perception.pipeline``) and make the next
  state ``data_valid = false``; ``input_gaps`` counts them.
- ``channel_names`` must be the contract's six names (any order: columns are reordered) or
  empty (contract order assumed); ``data`` must hold ``sample_count x 6`` values;
  ``sample_period`` must match ``sample_rate`` within 1 %. Otherwise the message is
  dropped (a gap follows).
- Invalid values (NaN, inf, ``|x| > input_limit``) mask only their channel (see
  ``forte_perception.channel_health``); counted per channel, reported in ``channel_health``
  and per channel in ``/diagnostics`` (ERROR while invalid values arrive, WARN when a
  channel is stuck or railed).
- No input for ``stale_timeout`` seconds: a state with ``data_valid = false`` is published
  every ``stale_timeout`` until input returns.

Header stamp of a state = sample time of the latest input sample used (input stamp +
(sample_count - 1) * sample_period); ``sample_index`` counts the samples received since
the pipeline (re)started (lost samples are not counted).

Threading: ``main`` spins a SingleThreadedExecutor (the cheapest per message). The tare
service is a coroutine that waits for its quiet period on a future completed by the frames
callback, so it never blocks the frames. A lock guards the pipeline, so the node also works
in a MultiThreadedExecutor.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from pathlib import Path

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import Trigger

from forte_msgs.msg import SensorInfo, ServoCommand, TactileFrames, TactileState
from forte_msgs.srv import Tare
from forte_perception.channel_health import channel_report
from forte_perception.force import ForceModel
from forte_perception.pipeline import PerceptionOutput, PerceptionPipeline, PipelineConfig
from forte_ros import run_node
from forte_ros.contract import BASE_FRAME, CHANNEL_NAMES, prefixed, split_ns, stamp_ns
from forte_ros.diagnostics import ERROR, OK, WARN, diagnostic_array, diagnostic_status, node_path
from forte_ros.parameter_table import ParameterSpec, parameter_table, replace_fields
from forte_ros.parameters import declare_table, parameter_update, read_table
from forte_ros.qos import COMMANDS, DIAGNOSTICS, SENSOR_FRAMES, SENSOR_INFO, TACTILE_STATE
from forte_ros.sensor_identity import IdentityCheck, SensorIdentity, check_identity

#: Every parameter of the node, in the order of declaration. Defaults: the fields of
#: :class:`PipelineConfig` (``field``; ``slip.*`` of its ``SlipParams``), the node-only
#: ones here. A change of a parameter with a field restarts the pipeline.
PARAMETERS: dict[str, ParameterSpec] = parameter_table([
    ParameterSpec('model_path', str, 'force model file (.npz written by forte_train_force); '
                  'empty: no force estimate (force_valid false)', default=''),
    ParameterSpec('sample_rate', float, 'expected input sample rate [Hz]; messages with another '
                  'sample_period are dropped', low=1.0, high=1e6, field='fs', read_only=True),
    ParameterSpec('frame_id', str, 'frame_id of tactile/state when the input has none '
                  '(prefix prepended)', default=BASE_FRAME),
    ParameterSpec('prefix', str, "TF prefix prepended to frame_id (e.g. right_; '' = none); "
                  "an input's own frame_id is kept as it is", default='', read_only=True),
    ParameterSpec('stale_timeout', float, 'no input for this long -> publish data_valid false',
                  's', 0.001, 60.0, default=0.1),
    ParameterSpec('diagnostics_period', float, 'period of /diagnostics', 's', 0.05, 60.0,
                  default=1.0, read_only=True),
    ParameterSpec('median_window', int, 'running median length M', 'samples', 1, 201,
                  field='median_window'),
    ParameterSpec('contact_window', int, 'contact window w', 'samples', 2, 20000,
                  field='contact_window'),
    ParameterSpec('contact_threshold', float, 'contact threshold tau, max - min over w '
                  '[normalised units; 0.01 = 0.5 % of the 2.0 span]', low=1e-6, high=2.0,
                  field='contact_threshold'),
    ParameterSpec('tare_duration', float, 'quiet period averaged by a tare', 's', 0.001, 60.0,
                  field='tare_duration'),
    ParameterSpec('auto_tare', bool, 'tare from the first quiet period after (re)start',
                  field='auto_tare'),
    ParameterSpec('force_rate', float, 'force estimates per second; sample_rate / force_rate '
                  'must be an integer', 'Hz', 0.1, 20000.0, field='force_rate'),
    ParameterSpec('slip_window', int, 'slip FFT window N', 'samples', 8, 8192,
                  field='slip.window'),
    ParameterSpec('slip_hop', int, 'samples between slip detector updates (1 = every sample)',
                  low=1, high=8192, field='slip.hop'),
    ParameterSpec('slip_f_min', float, 'slip band lower edge', 'Hz', 0.0, 1e5,
                  field='slip.f_min'),
    ParameterSpec('slip_f_max', float, 'slip band upper edge', 'Hz', 0.0, 1e5,
                  field='slip.f_max'),
    ParameterSpec('slip_history', int, 'PSD history length V', 'updates', 2, 1000,
                  field='slip.history'),
    ParameterSpec('slip_delta', float, 'minimal increment for monotonicity delta', 'dB', -1e3,
                  1e3, field='slip.delta'),
    ParameterSpec('slip_alpha', float, 'minimum group average variance alpha', 'dB^2', -1e3,
                  1e6, field='slip.alpha'),
    ParameterSpec('slip_threshold', float, 'slip threshold T', 'dB^2', -1e3, 1e6,
                  field='slip.threshold'),
    ParameterSpec('slip_mode', str, "slip detector mode: 'sequential' (CUSUM on the fast "
                  'band power per finger, one channel may carry it; wins on the held-out slip '
                  "set, wirings and closed loop), 'robust' (the paper's rule with a "
                  "quantisation floor, level-shift veto, one finger alone) or 'paper' (the "
                  "paper's algorithm bit for bit)", field='slip.mode'),
    ParameterSpec('slip_single_threshold', float, "robust mode: a finger may flag slip alone "
                  'when its group average exceeds this (at least slip_threshold)', 'dB^2',
                  -1e3, 1e6, field='slip.single_threshold'),
    ParameterSpec('slip_single_min_rising', int, 'robust mode: ... and at least this many of '
                  'its channels rise monotonically with a moving variance of at least '
                  'slip_alpha', low=1, high=3, field='slip.single_min_rising'),
    ParameterSpec('slip_veto_ratio', float, 'robust mode: a flag is vetoed when, on every '
                  'finger, the level shift exceeds this times the 10-50 Hz amplitude its PSD '
                  'rise implies', low=0.0, high=1e6, field='slip.veto_ratio'),
    ParameterSpec('slip_sequential_threshold', float, 'sequential mode: CUSUM alarm '
                  'threshold h (higher: fewer false alarms, later flags)', 'dB s', 1e-6, 1e3,
                  field='slip.sequential_threshold'),
    ParameterSpec('slip_sequential_drift', float, 'sequential mode: CUSUM drift k, half the '
                  'band-power rise it is tuned to', 'dB', 1e-3, 1e3,
                  field='slip.sequential_drift'),
    ParameterSpec('slip_sequential_single_offset', float, "sequential mode: a finger's input "
                  "is the larger of its channels' mean excess and its largest channel's excess "
                  'less this', 'dB', 0.0, 1e3, field='slip.sequential_single_offset'),
    ParameterSpec('input_limit', float, 'largest valid |raw value| [normalised units; the '
                  'protocol clips at +-1024 counts = +-1.0]; beyond it, or NaN/inf, a value is '
                  'invalid: its channel is masked, the others continue', low=1e-3, high=1e6,
                  field='input_limit'),
    ParameterSpec('stuck_duration', float, 'a channel exactly constant this long is reported '
                  'stuck (WARN, not invalidating)', 's', 0.01, 3600.0, field='stuck_duration'),
])


def build_config(values: dict) -> PipelineConfig:
    """The :class:`PipelineConfig` of parameter values (name -> value; parameters without a
    field are ignored, missing ones keep the dataclass default).

    Raises
    ------
    ValueError
        The configuration is unusable (the reason).
    TypeError
        A value cannot be converted to its parameter's kind.
    """
    config = replace_fields(PipelineConfig(), PARAMETERS, values)
    config.validate()
    return config


def expected_sensor(sample_rate: float) -> SensorIdentity:
    """What the node expects before the sensor identifies itself: its ``sample_rate``
    parameter [Hz] and the contract's channel order and full scale, any device."""
    return SensorIdentity(source='', device_id='', sample_rate=sample_rate)


def model_check(model: ForceModel | None, sensor: SensorIdentity) -> IdentityCheck:
    """:func:`check_identity` of ``model``'s ``metadata['sensor']`` (none: nothing to check)."""
    if model is None:
        return IdentityCheck()
    return check_identity(model.metadata.get('sensor', {}), sensor)


def load_model(path: str, sample_rate: float | None = None) -> ForceModel | None:
    """The model at ``path`` ('' = none); raises ValueError with a reason, also when the
    model was trained at another rate than ``sample_rate`` [Hz] or on another channel order."""
    if not path:
        return None
    if not Path(path).is_file():
        raise ValueError(f'model_path {path!r}: no such file')
    try:
        model = ForceModel.load(path)
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(f'model_path {path!r}: {exc}') from exc
    if sample_rate is not None:
        refusals = model_check(model, expected_sensor(sample_rate)).refusals
        if refusals:
            raise ValueError(f'model_path {path!r} refused: ' + '; '.join(refusals))
    return model


class PerceptionNode(Node):
    """The FORTE perception node (see the module docstring)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('perception', **kwargs)
        declare_table(self, PARAMETERS, PipelineConfig())

        self._lock = threading.RLock()
        self._sample_rate = float(self.get_parameter('sample_rate').value)
        config = build_config(read_table(self, PARAMETERS))  # raises: bad YAML stops the node
        model = load_model(str(self.get_parameter('model_path').value), self._sample_rate)
        self._pipeline = PerceptionPipeline(config, None)
        self._model: ForceModel | None = None      # the configured model, used or refused
        self._sensor: SensorIdentity | None = None  # from tactile/sensor_info
        self._identity = IdentityCheck()
        self._prefix = str(self.get_parameter('prefix').value)   # read-only
        self._frame_id = prefixed(str(self.get_parameter('frame_id').value), self._prefix)
        self._stale_timeout = float(self.get_parameter('stale_timeout').value)
        self._expected_sequence: int | None = None
        self._gap_offset = 0  # gaps counted by pipelines before a reset
        self._last_input = time.monotonic()
        self._stale_published = False
        self._tare_future: Future | None = None
        self.counters = {
            'messages': 0, 'samples': 0, 'sequence_gaps': 0, 'lost_samples': 0,
            'sequence_resets': 0, 'rejected_messages': 0, 'slip_messages': 0,
            'stale_states': 0, 'published': 0,
        }
        self._last_reject_reason = ''
        self._driver_counts = (0, 0)  # dropped, corrupt frames reported by the driver
        self._processing = deque(maxlen=2000)  # seconds per message
        self._arrivals = deque(maxlen=4000)  # monotonic arrival times
        self._last_output: PerceptionOutput | None = None
        self._last_stamp = None
        self._health_snapshot = None  # channel counts at the previous diagnostics

        self._group = MutuallyExclusiveCallbackGroup()
        self._service_group = ReentrantCallbackGroup()
        self._state_pub = self.create_publisher(TactileState, 'tactile/state', TACTILE_STATE)
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', DIAGNOSTICS)
        self.create_subscription(TactileFrames, 'tactile/frames', self._on_frames,
                                 SENSOR_FRAMES, callback_group=self._group)
        self.create_subscription(SensorInfo, 'tactile/sensor_info', self._on_sensor_info,
                                 SENSOR_INFO, callback_group=self._group)
        self._servo_subscription = None
        self._last_servo_position: float | None = None
        self._follow_servo()
        self._use_model(model)
        self.create_service(Tare, 'perception/tare', self._on_tare,
                            callback_group=self._service_group)
        self.create_service(Trigger, 'perception/reset', self._on_reset,
                            callback_group=self._service_group)
        self._stale_timer = self.create_timer(self._stale_timeout, self._check_stale,
                                              callback_group=self._group)
        self.create_timer(float(self.get_parameter('diagnostics_period').value),
                          self._publish_diagnostics, callback_group=self._group)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(
            f'perception up: fs={self._sample_rate:g} Hz, force model '
            f'{"loaded" if model is not None else "none"}, slip N={config.slip.window} '
            f'hop={config.slip.hop}')

    # ------------------------------------------------------------------ parameters
    def _on_set_parameters(self, parameters) -> SetParametersResult:
        with self._lock:
            changes, reason = parameter_update(parameters, PARAMETERS)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
            config = None
            if any(PARAMETERS[name].field is not None for name in changes):
                try:
                    config = build_config({**read_table(self, PARAMETERS), **changes})
                except (ValueError, TypeError) as exc:
                    return SetParametersResult(successful=False, reason=str(exc))
            model_change = 'model_path' in changes
            model = self._model
            if model_change:
                try:
                    model = load_model(changes['model_path'], self._sample_rate)
                except ValueError as exc:
                    return SetParametersResult(successful=False, reason=str(exc))
            stale = changes.get('stale_timeout')
            # all checks passed: apply
            if config is not None:
                self._gap_offset += self._pipeline.gaps
                self._pipeline.config = config
                self._pipeline.reset()
                self._follow_servo()
                self.get_logger().info('pipeline parameters changed: pipeline restarted')
            if model_change:
                self._use_model(model)
                self.get_logger().info(
                    f'force model {"loaded" if model is not None else "removed"}')
            if stale is not None:
                self._stale_timeout = stale
                self._stale_timer.cancel()
                self._stale_timer = self.create_timer(stale, self._check_stale,
                                                      callback_group=self._group)
            if 'frame_id' in changes:
                self._frame_id = prefixed(str(changes['frame_id']), self._prefix)
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ model identity
    def _use_model(self, model: ForceModel | None) -> None:
        """Check ``model`` against the sensor (its identity once known, else what the node
        expects) and use it unless refused (caller holds the lock or is the constructor)."""
        self._model = model
        sensor = self._sensor or expected_sensor(self._sample_rate)
        self._identity = model_check(model, sensor)
        self._pipeline.set_model(model if self._identity.usable else None)
        for reason in self._identity.refusals:
            self.get_logger().error(f'force model refused: {reason}')
        for warning in self._identity.warnings:
            self.get_logger().warning(f'force model: {warning}')

    def _on_sensor_info(self, message: SensorInfo) -> None:
        try:
            sensor = SensorIdentity.from_message(message)
        except ValueError as exc:
            self.get_logger().error(f'tactile/sensor_info ignored: {exc}')
            return
        with self._lock:
            if sensor == self._sensor:
                return
            self._sensor = sensor
            self.get_logger().info(
                f'sensor {sensor.device_id or "(unknown)"} ({sensor.source}, firmware '
                f'{sensor.firmware or "unknown"}, {sensor.sample_rate:g} Hz)')
            self._use_model(self._model)

    # ------------------------------------------------------------------ frames
    def _reject(self, reason: str) -> None:
        self.counters['rejected_messages'] += 1
        self._last_reject_reason = reason
        self._pipeline.mark_gap()
        self._expected_sequence = None
        self.get_logger().warn(f'tactile/frames message dropped: {reason}',
                               throttle_duration_sec=1.0)

    def _frames_array(self, msg: TactileFrames) -> np.ndarray | None:
        count = int(msg.sample_count)
        names = list(msg.channel_names)
        width = len(names) if names else 6
        data = np.asarray(msg.data, dtype=np.float64)
        if data.size != count * width:
            self._reject(f'data has {data.size} values, expected {count} x {width}')
            return None
        frames = data.reshape(count, width)
        if names and tuple(names) != CHANNEL_NAMES:
            if sorted(names) != sorted(CHANNEL_NAMES) or len(set(names)) != 6:
                self._reject(f'unknown channel_names {names}')
                return None
            frames = frames[:, [names.index(c) for c in CHANNEL_NAMES]]
        if count and msg.sample_period > 0 and \
                abs(msg.sample_period * self._sample_rate - 1.0) > 0.01:
            self._reject(f'sample_period {msg.sample_period} s does not match sample_rate '
                         f'{self._sample_rate} Hz')
            return None
        return frames

    def _follow_servo(self) -> None:
        """Subscribe to ``gripper/command`` once the sequential mode needs it: its servo
        gate (forte_perception.slip.servo_gate) vetoes alarms after each command change."""
        if self._servo_subscription is None and self._pipeline.config.slip.mode == 'sequential':
            self._servo_subscription = self.create_subscription(
                ServoCommand, 'gripper/command', self._on_servo_command, COMMANDS,
                callback_group=self._group)

    def _on_servo_command(self, msg: ServoCommand) -> None:
        """A changed servo command, mapped to the pipeline sample at its stamp (the stamp of
        the latest processed sample is known; no stamp: the next sample), with the time the
        servo needs for the step at the command's profile velocity (unknown for the first
        command and for the driver's default speed, 0)."""
        with self._lock:
            previous = self._last_servo_position
            if msg.position == previous:
                return
            self._last_servo_position = msg.position
            motion = (abs(msg.position - previous) / msg.profile_velocity
                      if previous is not None and msg.profile_velocity > 0 else None)
            sample = None
            stamp = stamp_ns(msg.header.stamp)
            if self._last_stamp is not None and stamp > 0:
                ahead = (stamp - self._last_stamp[0]) * 1e-9 * self._sample_rate
                sample = self._pipeline.samples_seen - 1 + int(round(ahead))
            self._pipeline.servo_moved(sample, motion)

    def _on_frames(self, msg: TactileFrames) -> None:
        t0 = time.perf_counter()
        now = time.monotonic()
        with self._lock:
            self._arrivals.append(now)
            self._last_input = now
            self._stale_published = False
            self.counters['messages'] += 1
            self._driver_counts = (int(msg.dropped_frames), int(msg.corrupt_frames))
            first = int(msg.first_sequence)
            count = int(msg.sample_count)
            if self._expected_sequence is not None and first != self._expected_sequence:
                if first > self._expected_sequence:
                    self.counters['sequence_gaps'] += 1
                    self.counters['lost_samples'] += first - self._expected_sequence
                else:
                    self.counters['sequence_resets'] += 1
                self._pipeline.mark_gap()
            frames = self._frames_array(msg)
            if frames is None:
                return
            self._expected_sequence = first + count
            if count == 0:
                return
            self.counters['samples'] += count
            period = msg.sample_period if msg.sample_period > 0 else 1.0 / self._sample_rate
            start_ns = stamp_ns(msg.header.stamp)
            frame_id = msg.header.frame_id or self._frame_id
            states = []
            # one state per force instant inside the message (and one at its end), so the
            # force is published at force_rate whatever the input batch size
            step = self._pipeline.config.force_step
            done = self._pipeline.samples_seen
            ends = (np.flatnonzero((done + np.arange(1, count + 1)) % step == 0) + 1).tolist()
            if not ends or ends[-1] != count:
                ends.append(count)
            begin = 0
            for end in ends:
                out = self._pipeline.process(frames[begin:end])
                sample_ns = start_ns + int(round((end - 1) * period * 1e9))
                states.append(self._to_message(out, sample_ns, frame_id))
                if out.slip:
                    self.counters['slip_messages'] += 1
                begin = end
            self._last_output = out
            self._last_stamp = (sample_ns, frame_id)
            result = self._pipeline.tare_result
            if result is not None and self._tare_future is not None and \
                    not self._tare_future.done():
                self._tare_future.set_result(result)
        for state in states:
            self._state_pub.publish(state)
        self.counters['published'] += len(states)
        self._processing.append(time.perf_counter() - t0)

    def _to_message(self, out: PerceptionOutput, sample_ns: int, frame_id: str,
                    valid: bool | None = None) -> TactileState:
        msg = TactileState()
        msg.header.stamp.sec, msg.header.stamp.nanosec = split_ns(sample_ns)
        msg.header.frame_id = frame_id
        msg.sample_index = max(0, int(out.sample_index))
        msg.force = float(out.force)
        msg.force_valid = bool(out.force_valid)
        msg.contact = [bool(c) for c in out.contact]
        msg.slip = bool(out.slip)
        msg.slip_active = bool(out.slip_active)
        # fixed-size float64 arrays take float64 numpy arrays as they are (the generated
        # setter checks only dtype and size, not every value as it does for a list)
        msg.psd_max_db = np.asarray(out.psd_max_db, dtype=np.float64)
        msg.finger_variance = np.asarray(out.finger_variance, dtype=np.float64)
        msg.slip_updates = int(out.slip_updates)
        msg.slipping = bool(out.slipping)
        msg.finger_slipping = [bool(f) for f in out.finger_slipping]
        msg.slip_excess = np.asarray(out.slip_excess, dtype=np.float64)
        msg.filtered = np.asarray(out.filtered, dtype=np.float64)
        msg.tared = bool(out.tared)
        msg.data_valid = bool(out.data_valid if valid is None else valid)
        msg.input_gaps = int(self._gap_offset + out.input_gaps)
        msg.channel_health = np.asarray(out.channel_health, dtype=np.uint8)
        return msg

    def _check_stale(self) -> None:
        with self._lock:
            age = time.monotonic() - self._last_input
            if age < self._stale_timeout or self._last_output is None:
                return
            out = self._last_output
            sample_ns, frame_id = self._last_stamp
            state = self._to_message(out, sample_ns, frame_id, valid=False)
            state.slip = False
            state.force_valid = False
            self.counters['stale_states'] += 1
            self._stale_published = True
        self._state_pub.publish(state)

    # ------------------------------------------------------------------ services
    async def _on_tare(self, request: Tare.Request, response: Tare.Response) -> Tare.Response:
        """Start a tare; the response is sent when the quiet period is complete (the
        coroutine waits on a future completed by the frames callback, so the executor keeps
        processing frames meanwhile)."""
        duration = float(request.duration)
        with self._lock:
            if duration == 0.0:
                duration = float(self._pipeline.config.tare_duration)
            ok, reason = self._pipeline.request_tare(duration)
            if ok:
                if self._tare_future is not None and not self._tare_future.done():
                    self._tare_future.set_result(None)  # superseded
                future = Future()
                self._tare_future = future
        if not ok:
            response.success = False
            response.message = reason
            return response
        limit = duration + 2.0 + 5.0 * self._stale_timeout

        def expire() -> None:
            timer.cancel()
            if not future.done():
                future.set_result(None)

        timer = self.create_timer(limit, expire, callback_group=self._group)
        result = await future
        timer.cancel()
        self.destroy_timer(timer)
        if result is None:
            response.success = False
            response.message = (f'no complete quiet period within {limit:.1f} s (no input, '
                                'or superseded by another request)')
            return response
        response.success = bool(result.success)
        response.message = result.message
        response.baseline = [float(v) for v in result.baseline] if result.success else []
        return response

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        with self._lock:
            self._gap_offset += self._pipeline.gaps
            self._pipeline.reset()
            self._expected_sequence = None
        response.success = True
        response.message = 'pipeline restarted (filters, detector, means, baseline)'
        return response

    # ------------------------------------------------------------------ diagnostics
    def _publish_diagnostics(self) -> None:
        with self._lock:
            now = time.monotonic()
            recent = [t for t in self._arrivals if now - t <= 1.0]
            rate = float(len(recent))
            proc = np.asarray(self._processing) * 1e6
            out = self._last_output
            stale = now - self._last_input > self._stale_timeout
            level, message = OK, 'ok'
            if self._identity.refusals:
                level, message = ERROR, 'force model refused: ' + self._identity.refusals[0]
            elif out is None:
                level, message = WARN, 'no input yet'
            elif stale:
                level, message = ERROR, 'input stale'
            elif not out.tared:
                level, message = WARN, 'not tared yet'
            elif self._pipeline.model is None:
                level, message = WARN, 'no force model'
            elif self._identity.warnings:
                level, message = WARN, self._identity.warnings[0]
            trained = self._model.metadata.get('sensor', {}) if self._model else {}
            values = {
                'input messages/s': f'{rate:.1f}',
                'tared': str(bool(out.tared) if out else False),
                'force model': ('refused' if self._identity.refusals else
                                'loaded' if self._pipeline.model is not None else 'none'),
                'model trained on device': str(trained.get('device_id', 'unrecorded')),
                'sensor device': self._sensor.device_id if self._sensor else 'unidentified',
                'sensor firmware': self._sensor.firmware if self._sensor else '',
                'last reject reason': self._last_reject_reason,
                'processing p50 [us]': f'{np.percentile(proc, 50):.0f}' if proc.size else '',
                'processing p99 [us]': f'{np.percentile(proc, 99):.0f}' if proc.size else '',
                'rows with invalid values': str(out.rejected_samples if out else 0),
                'input gaps': str(self._gap_offset + (out.input_gaps if out else 0)),
                'driver dropped frames': str(self._driver_counts[0]),
                'driver corrupt frames': str(self._driver_counts[1]),
            }
            values.update({k.replace('_', ' '): str(v) for k, v in self.counters.items()})
            status = diagnostic_status(f'{node_path(self)}: pipeline', level, message, values,
                                       hardware_id='forte')
            statuses = [status] + self._channel_statuses()
        self._diag_pub.publish(diagnostic_array(self.get_clock().now().to_msg(), statuses))

    def _channel_statuses(self) -> list[DiagnosticStatus]:
        """One status per channel: ERROR if invalid values arrived since the previous
        diagnostics, WARN if stuck or railed, with the counts (caller holds the lock)."""
        reports, self._health_snapshot = channel_report(
            self._pipeline.health, self._health_snapshot, self._sample_rate)
        return [diagnostic_status(f'{node_path(self)}: channel {name}', bytes([level]), message,
                                  values, hardware_id='forte')
                for name, (level, message, values) in zip(CHANNEL_NAMES, reports, strict=True)]


def main(args: list[str] | None = None) -> int:
    """Entry point ``perception_node``: spin until SIGINT/SIGTERM, then stop cleanly."""
    return run_node(PerceptionNode, args)


if __name__ == '__main__':
    raise SystemExit(main())


__all__ = ['PerceptionNode', 'build_config', 'expected_sensor', 'load_model', 'main',
           'model_check']
