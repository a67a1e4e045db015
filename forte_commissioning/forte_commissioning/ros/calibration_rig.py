"""The force calibration rig over ROS: the procedure's hardware interface in a node.

:class:`RosCalibrationRig` implements :class:`forte_commissioning.force_calibration.
CalibrationRig` with the topics of docs/contracts.md plus the load cell:

- ``tactile/frames`` (forte_msgs/TactileFrames), ``joint_states`` (sensor_msgs/JointState),
  the load cell (geometry_msgs/WrenchStamped, ``load_cell_topic``, one component times a
  sign: :func:`forte_commissioning.load_cell.wrench_component`) and, when it exists,
  ``tactile/sensor_info`` (forte_msgs/SensorInfo, latched) are received serialized, written
  as they are to the session's MCAP bag and decoded for the recording;
- ``gripper/command`` (forte_msgs/ServoCommand) is published (and written to the bag). The
  grasp controller must not command the gripper meanwhile: launch the calibration without
  it (calibrate_force.launch.py does), or leave it idle (an idle controller publishes
  nothing);
- simulation mode: a fresh calibration scene per trial through the sim node's lifecycle
  (deactivate, cleanup, set ``scene``/``object``/``seed``/``trial``, configure, activate);
  messages that were still on their way from the previous scene are discarded;
- operator prompts: a log line and the ``~/continue`` service (std_srvs/Trigger); with
  ``auto_continue`` the procedure goes on by itself after ``auto_continue_delay`` (headless).

Every wait is an rclpy future completed by a subscription or a timer, awaited by the
procedure's task on a SingleThreadedExecutor: no callback blocks.
"""
from __future__ import annotations

import time

from geometry_msgs.msg import WrenchStamped
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.task import Future
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from forte_commissioning.force_calibration import RigError, StaleSensor
from forte_commissioning.force_plan import TrialPlan
from forte_commissioning.load_cell import wrench_component
from forte_commissioning.trial_recording import RecordingBuffer
from forte_driver.replay.bags import BagWriter, TopicSpec
from forte_msgs.msg import SensorInfo, ServoCommand, TactileFrames
from forte_ros.contract import CHANNEL_NAMES, stamp_ns
from forte_ros.qos import COMMANDS, LOAD_CELL, SENSOR_INFO, reliable
from forte_ros.sensor_identity import SensorIdentity

__all__ = ['RosCalibrationRig']

#: Reliable history of the frame and load-cell subscriptions: several seconds of a
#: simulation at 8x real time, so a busy moment of this process loses nothing [messages].
QUEUE_DEPTH = 5000
#: Longest wait for the load cell to cover a trial's last frame (it may lag the frames on a
#: busy machine; after this the trial is dropped as not covered) [s].
LOAD_WAIT = 5.0
#: Simulation: after the scene stops, its messages still queued are discarded until none
#: arrived for this long [s] (however far behind the subscriptions are).
DRAIN_TIME = 0.1


class RosCalibrationRig:
    """The calibration rig over ROS (module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        The procedure's node (subscriptions, services and timers are created on it).
    settings : dict
        The node's parameters (``load_cell_topic``, ``load_cell_axis``, ``load_cell_sign``,
        ``frames_reliable``, ``stale_timeout``, ``ready_timeout``, ``simulation``,
        ``sim_node``, ``auto_continue``, ``auto_continue_delay``).
    bag_path : Path or None
        Folder of this run's MCAP bag (None: no bag).
    """

    def __init__(self, node: Node, settings: dict, bag_path=None) -> None:
        self.node = node
        self.settings = settings
        self.simulation = bool(settings['simulation'])
        self.buffer: RecordingBuffer | None = None
        self._joint: float | None = None
        self._identity: dict | None = None
        self._last_frame_wall: float | None = None
        self._last_load_wall: float | None = None
        self._load_messages = 0
        self._load_nonfinite = 0
        self._received = 0
        self._discarding = False
        self._waits: list[tuple[str, int, Future, float]] = []
        self._continue: Future | None = None
        self.bag = BagWriter(bag_path) if bag_path is not None else None
        frames_qos = reliable(QUEUE_DEPTH) if settings['frames_reliable'] else QoSProfile(
            depth=QUEUE_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT)
        self._subscribe(TactileFrames, 'tactile/frames', frames_qos, self._on_frames,
                        'forte_msgs/msg/TactileFrames', bool(settings['frames_reliable']))
        self._subscribe(JointState, 'joint_states', COMMANDS, self._on_joint,
                        'sensor_msgs/msg/JointState', True)
        self.load_topic = node.resolve_topic_name(settings['load_cell_topic'])
        own = {node.resolve_topic_name(name): kind for name, kind in (
            ('tactile/frames', 'TactileFrames'), ('joint_states', 'sensor_msgs/msg/JointState'),
            ('gripper/command', 'ServoCommand'), ('tactile/sensor_info', 'SensorInfo'))}
        if self.load_topic in own:
            raise ValueError(f'refused: bad load-cell topic: {self.load_topic} carries '
                             f'{own[self.load_topic]}, not geometry_msgs/msg/WrenchStamped')
        self._subscribe(WrenchStamped, self.load_topic, LOAD_CELL, self._on_load,
                        'geometry_msgs/msg/WrenchStamped', True)
        self._subscribe(SensorInfo, 'tactile/sensor_info', SENSOR_INFO, self._on_sensor_info,
                        'forte_msgs/msg/SensorInfo', True, True)
        self.frames_topic = node.resolve_topic_name('tactile/frames')
        self._command_publisher = node.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
        self._command_topic = self._command_publisher.topic_name
        self._bag_topic(self._command_topic, 'forte_msgs/msg/ServoCommand', True, False, 10)
        node.create_service(Trigger, '~/continue', self._on_continue)
        self._timer = node.create_timer(0.05, self._check_waits)
        sim = settings['sim_node'].rstrip('/')
        self._change_state = node.create_client(ChangeState, f'{sim}/change_state')
        self._get_state = node.create_client(GetState, f'{sim}/get_state')
        self._set_parameters = node.create_client(SetParameters, f'{sim}/set_parameters')

    # ------------------------------------------------------------------ subscriptions
    def _subscribe(self, message_type, topic, qos, handler, type_name, reliable_qos,
                   transient=False) -> str:
        subscription = self.node.create_subscription(
            message_type, topic, lambda data: self._receive(data, message_type, handler,
                                                             subscription.topic_name),
            qos, raw=True)
        self._bag_topic(subscription.topic_name, type_name, reliable_qos, transient, qos.depth)
        return subscription.topic_name

    def _bag_topic(self, topic, type_name, reliable_qos, transient, depth) -> None:
        if self.bag is not None:
            self.bag.add_topic(TopicSpec(topic, type_name, reliable=reliable_qos,
                                         transient_local=transient, depth=depth))

    def _receive(self, data: bytes, message_type, handler, topic: str) -> None:
        self._received += 1
        if self.bag is not None and not self.bag.closed:
            self.bag.write(topic, self.node.get_clock().now().nanoseconds, data)
        handler(deserialize_message(data, message_type))

    def _on_frames(self, message: TactileFrames) -> None:
        if self._discarding:
            return
        self._last_frame_wall = time.monotonic()
        if self.buffer is None:
            return
        if tuple(message.channel_names) != CHANNEL_NAMES:
            self.buffer.add_problem(f'frames with channel order {list(message.channel_names)}')
            return
        self.buffer.add_frames(stamp_ns(message.header.stamp), message.first_sequence,
                               message.sample_period, message.data)
        self._resolve('frames', self.buffer.count)

    def _on_joint(self, message: JointState) -> None:
        if self._discarding or not message.position:
            return
        self._joint = float(message.position[0])
        if self.buffer is not None:
            self.buffer.add_joint(stamp_ns(message.header.stamp), self._joint)
        self._resolve('joint', 1)

    def _on_load(self, message: WrenchStamped) -> None:
        if self._discarding:
            return
        force = message.wrench.force
        value = wrench_component((force.x, force.y, force.z), self.settings['load_cell_axis'],
                                 float(self.settings['load_cell_sign']))
        self._load_messages += 1
        if value != value:
            self._load_nonfinite += 1
            return
        self._last_load_wall = time.monotonic()
        if self.buffer is not None:
            stamp = stamp_ns(message.header.stamp)
            self.buffer.add_load(stamp, value)
            self._resolve('load', stamp)

    def _on_sensor_info(self, message: SensorInfo) -> None:
        self._identity = SensorIdentity.from_message(message).to_dict()

    def _on_continue(self, request, response):
        if self._continue is not None and not self._continue.done():
            self._continue.set_result(True)
            response.success, response.message = True, 'continuing'
        else:
            response.success, response.message = False, 'the procedure is not waiting'
        return response

    # ------------------------------------------------------------------ waits
    def _wait(self, kind: str, target: int) -> Future:
        future = Future()
        self._waits.append((kind, target, future, time.monotonic()))
        return future

    def _resolve(self, kind: str, value: int) -> None:
        for wait in list(self._waits):
            if wait[0] == kind and value >= wait[1]:
                self._waits.remove(wait)
                wait[2].set_result(True)

    def _check_waits(self) -> None:
        """Timer: fail a frame wait on a stale sensor; time out the others."""
        now = time.monotonic()
        stale = float(self.settings['stale_timeout'])
        for wait in list(self._waits):
            kind, _, future, started = wait
            if kind == 'frames':
                last = max(self._last_frame_wall or started, started)
                if now - last > stale:
                    self._waits.remove(wait)
                    future.set_exception(StaleSensor(
                        f'stale sensor: no tactile frame on {self.frames_topic} for '
                        f'{now - last:.2f} s (stale_timeout {stale:g} s)'))
            elif kind == 'sleep' and now >= started:
                self._waits.remove(wait)
                future.set_result(True)
            elif kind in ('load', 'joint') and now - started > LOAD_WAIT:
                self._waits.remove(wait)
                future.set_result(False)

    async def _sleep(self, seconds: float) -> None:
        future = Future()
        self._waits.append(('sleep', 0, future, time.monotonic() + seconds))
        await future

    # ------------------------------------------------------------------ rig interface
    @property
    def joint_position(self) -> float | None:
        """Latest joint position report [rad]."""
        return self._joint

    def command(self, angle: float, profile_velocity: float = 0.0) -> None:
        """Publish a ServoCommand (and write it to the bag)."""
        message = ServoCommand()
        message.header.stamp = self.node.get_clock().now().to_msg()
        message.position = float(angle)
        message.profile_velocity = float(profile_velocity)
        self._command_publisher.publish(message)
        if self.bag is not None and not self.bag.closed:
            self.bag.write(self._command_topic, self.node.get_clock().now().nanoseconds,
                           serialize_message(message))

    def start_recording(self) -> RecordingBuffer:
        self.buffer = RecordingBuffer()
        return self.buffer

    def stop_recording(self) -> None:
        self.buffer = None

    async def wait_samples(self, count: int) -> None:
        if self.buffer is not None and self.buffer.count >= count:
            return
        await self._wait('frames', count)

    async def wait_load_cell(self, time_ns: int) -> bool:
        last = self.buffer.last_load_time_ns if self.buffer is not None else None
        if last is not None and last >= time_ns:
            return True
        return bool(await self._wait('load', time_ns))

    async def prompt(self, message: str) -> None:
        if self.simulation:
            self.node.get_logger().info(f'{message} (simulation: the scene does it)')
            return
        if self.settings['auto_continue']:
            delay = float(self.settings['auto_continue_delay'])
            self.node.get_logger().warning(f'OPERATOR: {message}; continuing by itself in '
                                           f'{delay:g} s (auto_continue)')
            await self._sleep(delay)
            return
        service = self.node.resolve_service_name('~/continue')
        self.node.get_logger().warning(
            f'OPERATOR: {message}: ros2 service call {service} std_srvs/srv/Trigger')
        self._continue = Future()
        await self._continue
        self._continue = None

    def sensor_identity(self) -> dict | None:
        return self._identity

    # ------------------------------------------------------------------ readiness
    async def check_ready(self) -> None:
        """Wait up to ``ready_timeout`` for fresh frames and load-cell samples, joint states
        and a gripper listening to the commands.

        Raises
        ------
        RigError
            With what is wrong: no or stale frames, no load-cell publisher, a publisher of
            another type, messages that never arrive (QoS) or carry no finite value.
        """
        timeout = float(self.settings['ready_timeout'])
        stale = float(self.settings['stale_timeout'])
        deadline = time.monotonic() + timeout
        while True:
            now = time.monotonic()
            frames_fresh = self._last_frame_wall is not None and now - self._last_frame_wall < stale
            load_fresh = self._last_load_wall is not None and now - self._last_load_wall < stale
            # a command published before the gripper's subscription matched is lost
            # (volatile QoS): the gripper must be listening before the first move
            listening = self._command_publisher.get_subscription_count() > 0
            if frames_fresh and load_fresh and self._joint is not None and listening:
                return
            if now > deadline:
                break
            await self._sleep(0.05)
        if not frames_fresh:
            raise RigError(self._frames_problem(now, timeout))
        if not load_fresh:
            raise RigError(self._load_problem(now, timeout))
        if self._joint is None:
            raise RigError('no joint_states from the gripper: is its driver (or the '
                           'simulation) running?')
        raise RigError(f'nothing subscribes to {self._command_topic}: is the gripper driver '
                       '(or the simulation) running?')

    def _frames_problem(self, now: float, timeout: float) -> str:
        if self._last_frame_wall is None:
            publishers = self.node.count_publishers(self.frames_topic)
            return (f'refused: stale sensor: no tactile frame on {self.frames_topic} within '
                    f'{timeout:g} s '
                    f'({publishers} publisher(s)): start the sensor driver (or the simulation)'
                    f'{"; check frames_reliable against its QoS" if publishers else ""}')
        return (f'refused: stale sensor: the last tactile frame on {self.frames_topic} is '
                f'{now - self._last_frame_wall:.1f} s old')

    def _load_problem(self, now: float, timeout: float) -> str:
        topic = self.load_topic
        types = dict(self.node.get_topic_names_and_types()).get(topic, [])
        wanted = 'geometry_msgs/msg/WrenchStamped'
        others = [kind for kind in types if kind != wanted]
        if others:
            return (f'refused: bad load-cell topic: {topic} carries {", ".join(others)}, not '
                    f'{wanted}: set load_cell_topic (or remap) to the load cell\'s wrench')
        if self._load_nonfinite and self._last_load_wall is None:
            return (f'refused: bad load-cell data: {self._load_nonfinite} message(s) on {topic} '
                    f'without a finite force.{self.settings["load_cell_axis"]}')
        if self._last_load_wall is not None:
            return (f'refused: stale load cell: the last sample on {topic} is '
                    f'{now - self._last_load_wall:.1f} s old')
        publishers = self.node.count_publishers(topic)
        if not publishers:
            return (f'refused: no load-cell data: nothing publishes {topic} within {timeout:g} '
                    's: start the load-cell driver, or set load_cell_topic (or remap)')
        return (f'refused: no load-cell data: {publishers} publisher(s) on {topic} but no '
                f'message within {timeout:g} s (a best-effort publisher? this subscription '
                'is reliable)')

    # ------------------------------------------------------------------ simulation
    async def new_scene(self, plan: TrialPlan, search: bool) -> None:
        """Simulation: a fresh calibration scene for ``plan`` (lifecycle); robot: nothing."""
        if not self.simulation:
            return
        for client in (self._change_state, self._get_state, self._set_parameters):
            waited = 0.0
            while not client.service_is_ready():
                if waited > float(self.settings['ready_timeout']):
                    raise RigError(f'simulation: {client.srv_name} is not available: is the '
                                   f'sim node {self.settings["sim_node"]} running?')
                await self._sleep(0.05)
                waited += 0.05
        self.node.get_logger().debug(f'simulation: new scene {plan.indentor} seed {plan.seed}')
        self._discarding = True
        self._joint = None
        state = (await self._get_state.call_async(GetState.Request())).current_state.id
        if state == State.PRIMARY_STATE_ACTIVE:
            await self._transition(Transition.TRANSITION_DEACTIVATE)
            state = State.PRIMARY_STATE_INACTIVE
        await self._drain()
        if state == State.PRIMARY_STATE_INACTIVE:
            await self._transition(Transition.TRANSITION_CLEANUP)
        request = SetParameters.Request()
        request.parameters = [Parameter(name, value=value).to_parameter_msg() for name, value in (
            ('scene', 'calibration'), ('object', plan.indentor), ('seed', int(plan.seed)),
            ('trial', int(plan.trial)))]
        results = (await self._set_parameters.call_async(request)).results
        refused = [result.reason for result in results if not result.successful]
        if refused:
            raise RigError(f'simulation: the sim node refused the scene: {"; ".join(refused)}')
        await self._transition(Transition.TRANSITION_CONFIGURE)
        self._discarding = False
        self._last_frame_wall = None
        await self._transition(Transition.TRANSITION_ACTIVATE)
        self.node.get_logger().debug('simulation: scene active')
        if not await self._wait('joint', 1):
            raise RigError('simulation: no joint_states after the scene started')

    async def _drain(self) -> None:
        """Discard what the stopped scene sent until nothing arrived for DRAIN_TIME."""
        while True:
            before = self._received
            await self._sleep(DRAIN_TIME)
            if self._received == before:
                return

    async def _transition(self, transition: int) -> None:
        request = ChangeState.Request()
        request.transition.id = transition
        response = await self._change_state.call_async(request)
        if not response.success:
            raise RigError(f'simulation: the sim node refused lifecycle transition '
                           f'{transition}')

    def close(self) -> None:
        """Finish the bag (idempotent)."""
        if self.bag is not None:
            self.bag.close()
