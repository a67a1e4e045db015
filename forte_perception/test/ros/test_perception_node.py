"""The perception node over real rclpy/DDS: frames published by another node, states,
services, parameters and diagnostics; online results equal the offline pipeline."""
import threading
import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from forte_msgs.msg import SensorInfo, TactileFrames, TactileState
from forte_msgs.srv import Tare
from forte_perception.force import ForceModel
from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
from forte_perception.ros.perception_node import PerceptionNode
from forte_perception.slip.params import SlipParams
from forte_perception.testing import (
    random_walk,
    ringing_after_a_step,
    slip_bursts,
    tightening_then_slip,
)
from forte_ros.contract import CHANNEL_NAMES
from forte_ros.qos import SENSOR_INFO
from forte_ros.sensor_identity import SIMULATED_SENSOR, SensorIdentity

CHUNK = 20


def stream(n=16000, seed=0):
    """Quiet, a press, two slip bursts; inside the transducer's [-1, 1]."""
    x = 0.2 + slip_bursts(n, seed=seed, onsets=(9000, 13000), growth_db_per_s=450.0) + \
        random_walk(n, seed=seed) * 0.05
    x[6000:7000] += np.linspace(0, 0.05, 1000)[:, None]  # press
    x[7000:] += 0.05
    return x


class Harness:
    """A perception node and a peer node (publisher, subscriber, clients) in one executor."""

    def __init__(self, parameters=()):
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = PerceptionNode(context=self.context, parameter_overrides=list(parameters))
        self.peer = Node('peer', context=self.context)
        self.pub = self.peer.create_publisher(
            TactileFrames, 'tactile/frames',
            QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE))
        self.states: list[TactileState] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.cond = threading.Condition()
        self.peer.create_subscription(TactileState, 'tactile/state', self._on_state,
                                      QoSProfile(depth=1000,
                                                 reliability=ReliabilityPolicy.RELIABLE))
        self.peer.create_subscription(DiagnosticArray, '/diagnostics',
                                      self.diagnostics.append, 10)
        self.tare = self.peer.create_client(Tare, 'perception/tare')
        self.reset = self.peer.create_client(Trigger, 'perception/reset')
        # single-threaded (the tare service is a coroutine): rclpy's MultiThreadedExecutor
        # re-dispatches ready entities in a loop (ros2/rclpy#1223) and hung service calls here
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.peer)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()
        self.sequence = 0
        deadline = time.monotonic() + 10.0
        while self.pub.get_subscription_count() < 1 or \
                self.node.count_publishers('tactile/frames') < 1:
            assert time.monotonic() < deadline, 'discovery timed out'
            time.sleep(0.01)
        time.sleep(0.2)

    def _on_state(self, msg):
        with self.cond:
            self.states.append(msg)
            self.cond.notify_all()

    def wait_states(self, count, timeout=5.0):
        with self.cond:
            assert self.cond.wait_for(lambda: len(self.states) >= count, timeout), \
                f'{len(self.states)} states, expected {count}'

    def message(self, rows, first_sequence=None, names=CHANNEL_NAMES, period=0.0005):
        msg = TactileFrames()
        msg.header.frame_id = 'forte_base_link'
        seq = self.sequence if first_sequence is None else first_sequence
        msg.header.stamp.sec = 100 + seq // 2000
        msg.header.stamp.nanosec = (seq % 2000) * 500_000
        msg.first_sequence = seq
        msg.sample_period = period
        msg.channel_names = list(names)
        msg.sample_count = rows.shape[0]
        msg.data = rows.astype(np.float64).ravel().tolist()
        self.sequence = seq + rows.shape[0]
        return msg

    def send(self, rows, wait=True, **kwargs):
        """Publish one message and (by default) wait for its state (lockstep: no drops)."""
        before = len(self.states)
        self.pub.publish(self.message(rows, **kwargs))
        if wait:
            self.wait_states(before + 1)

    def call(self, client, request, feed=None, timeout=10.0):
        assert client.wait_for_service(timeout_sec=5.0)
        future = client.call_async(request)
        deadline = time.monotonic() + timeout
        rows = iter(feed) if feed is not None else None
        while not future.done():
            assert time.monotonic() < deadline, 'service call timed out'
            if rows is not None:
                chunk = next(rows, None)
                if chunk is not None:
                    self.send(chunk)
                    continue
            time.sleep(0.01)
        return future.result()

    def close(self):
        self.executor.shutdown(timeout_sec=5.0)
        self.thread.join(timeout=5.0)
        self.node.destroy_node()
        self.peer.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture
def model_file(tmp_path):
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.3, 0.3, size=(400, 24))
    model = ForceModel.fit(x, 4.0 + 10.0 * x[:, :6].sum(axis=1), force_range=(0.0, 8.0))
    path = tmp_path / 'force.npz'
    model.save(path)
    return path


def trained_model(path, sensor: dict):
    """The fixture's model with ``metadata['sensor'] = sensor``, saved at ``path``."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.3, 0.3, size=(400, 24))
    model = ForceModel.fit(x, 4.0 + 10.0 * x[:, :6].sum(axis=1), force_range=(0.0, 8.0),
                           metadata={'sensor': sensor})
    model.save(path)
    return path


@pytest.fixture
def harness(request, model_file):
    params = [Parameter('model_path', value=str(model_file)),
              Parameter('stale_timeout', value=30.0)]  # a slow machine is not a stale sensor
    params += list(getattr(request, 'param', []))
    h = Harness(params)
    yield h
    h.close()


@pytest.mark.parametrize('harness, mode', [([], 'sequential'),
                                           ([Parameter('slip_mode', value='paper')], 'paper')],
                         indirect=['harness'], ids=['default', 'paper'])
def test_online_equals_offline(harness, mode, model_file):
    """The node is the offline pipeline, in the sequential slip mode by default and in the
    paper mode one parameter away."""
    x = stream()
    chunks = [x[i:i + CHUNK] for i in range(0, len(x), CHUNK)]
    for chunk in chunks:
        harness.send(chunk)
    assert harness.node._pipeline.config.slip.mode == mode
    offline = PerceptionPipeline(PipelineConfig(slip=SlipParams(mode=mode)),
                                 ForceModel.load(model_file))
    outs = [offline.process(c) for c in chunks]
    assert len(harness.states) == len(outs)
    for state, out in zip(harness.states, outs, strict=True):
        assert state.sample_index == out.sample_index
        np.testing.assert_array_equal(state.psd_max_db, out.psd_max_db)
        np.testing.assert_array_equal(state.finger_variance, out.finger_variance)
        np.testing.assert_array_equal(state.filtered, out.filtered)
        np.testing.assert_array_equal([state.force], [out.force])
        assert (state.slip, state.slip_active, state.force_valid, state.tared) == \
            (out.slip, out.slip_active, out.force_valid, out.tared)
        assert list(state.contact) == list(out.contact)
        assert state.slip_updates == out.slip_updates
        assert (state.slipping, list(state.finger_slipping)) == \
            (out.slipping, list(out.finger_slipping))
        np.testing.assert_array_equal(state.slip_excess, out.slip_excess)
        assert state.data_valid and state.input_gaps == 0
    assert any(s.slip for s in harness.states) and any(s.contact[0] for s in harness.states)
    assert any(s.slipping for s in harness.states)  # the bursts raise the slipping state
    assert sum(s.force_valid for s in harness.states) > 300
    last = harness.states[-1]
    assert last.header.frame_id == 'forte_base_link'
    end = len(x) - 1  # stamp of the last sample: 100 s + 7999.5 ms
    assert last.header.stamp.sec * 10**9 + last.header.stamp.nanosec == \
        100 * 10**9 + end * 500_000


def test_gaps_bad_messages_and_nan(harness):
    x = stream()
    for i in range(0, 3000, CHUNK):
        harness.send(x[i:i + CHUNK])
    assert harness.states[-1].data_valid
    harness.send(x[3000:3020], first_sequence=harness.sequence + 40)  # 40 lost samples
    gap_state = harness.states[-1]
    assert not gap_state.data_valid and gap_state.input_gaps == 1 and not gap_state.slip_active
    harness.send(x[3020:3040])
    assert harness.states[-1].data_valid and harness.states[-1].input_gaps == 1
    assert harness.node.counters['lost_samples'] == 40
    # wrong channel names: dropped (no state), counted, next state invalid
    before = len(harness.states)
    harness.send(x[3040:3060], names=['a', 'b', 'c', 'd', 'e', 'f'], wait=False)
    harness.send(x[3060:3080])
    assert len(harness.states) == before + 1
    assert not harness.states[-1].data_valid
    assert harness.node.counters['rejected_messages'] == 1
    # permuted names are reordered
    perm = [5, 4, 3, 2, 1, 0]
    harness.send(x[3080:3100][:, perm], names=[CHANNEL_NAMES[i] for i in perm])
    assert harness.states[-1].data_valid
    # a NaN masks its channel (no gap, no restart), the state says invalid
    bad = x[3100:3120].copy()
    bad[3, 1] = np.nan
    harness.send(bad)
    assert not harness.states[-1].data_valid
    assert list(harness.states[-1].channel_health) == [0, 5, 0, 0, 0, 0]  # NON_FINITE|MASKED
    assert harness.states[-1].input_gaps == 2  # sequence gap, dropped message
    # backwards jump (driver restart)
    harness.send(x[3120:3140], first_sequence=0)
    assert not harness.states[-1].data_valid
    assert harness.node.counters['sequence_resets'] == 1


def test_tare_and_reset_services(harness):
    x = stream()
    for i in range(0, 5000, CHUNK):
        harness.send(x[i:i + CHUNK])
    assert harness.states[-1].tared  # auto-tare after 2 s
    feed = [x[i:i + CHUNK] for i in range(5000, 6000, CHUNK)]
    result = harness.call(harness.tare, Tare.Request(duration=0.2), feed=feed)
    assert result.success, result.message
    assert len(result.baseline) == 6
    np.testing.assert_allclose(result.baseline, x[5000:5400].mean(axis=0), atol=2e-3)
    # during the press: refused at once
    for i in range(6000, 6500, CHUNK):
        harness.send(x[i:i + CHUNK])
    assert any(harness.states[-1].contact)
    refused = harness.call(harness.tare, Tare.Request(duration=0.0))
    assert not refused.success and 'contact' in refused.message
    reset = harness.call(harness.reset, Trigger.Request())
    assert reset.success
    harness.send(x[6500:6520])
    assert harness.states[-1].sample_index == 19 and not harness.states[-1].tared


def test_parameters_are_validated(harness, tmp_path):
    node = harness.node
    bad = node.set_parameters([Parameter('force_rate', value=300.0)])[0]
    assert not bad.successful and 'integer' in bad.reason
    bad = node.set_parameters([Parameter('slip_hop', value=0)])[0]
    assert not bad.successful
    bad = node.set_parameters_atomically([Parameter('slip_f_min', value=11.0),
                                          Parameter('slip_f_max', value=14.0)])
    assert not bad.successful and 'bin' in bad.reason
    bad = node.set_parameters([Parameter('slip_mode', value='fancy')])[0]
    assert not bad.successful and 'mode' in bad.reason
    bad = node.set_parameters([Parameter('slip_mode', value=1)])[0]
    assert not bad.successful
    assert node._pipeline.config.slip.mode == 'sequential'  # RECOMMENDED_MODE
    bad = node.set_parameters([Parameter('slip_sequential_threshold', value=0.0)])[0]
    assert not bad.successful
    good = node.set_parameters([Parameter('slip_sequential_threshold', value=0.1)])[0]
    assert good.successful and node._pipeline.config.slip.sequential_threshold == 0.1
    bad = node.set_parameters([Parameter('model_path', value=str(tmp_path / 'none.npz'))])[0]
    assert not bad.successful and 'no such file' in bad.reason
    (tmp_path / 'junk.npz').write_bytes(b'not a model')
    bad = node.set_parameters([Parameter('model_path', value=str(tmp_path / 'junk.npz'))])[0]
    assert not bad.successful
    good = node.set_parameters_atomically([Parameter('slip_hop', value=2),
                                           Parameter('force_rate', value=200.0),
                                           Parameter('slip_mode', value='paper')])
    assert good.successful, good.reason
    assert node._pipeline.config.slip.hop == 2 and node._pipeline.config.force_step == 10
    assert node._pipeline.config.slip.mode == 'paper'
    x = stream()
    for i in range(0, 1000, CHUNK):
        harness.send(x[i:i + CHUNK])
    deadline = time.monotonic() + 5.0  # 200 Hz force: two states per 20-sample message
    while harness.states[-1].sample_index < 999 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert [s.sample_index for s in harness.states[-4:]] == [969, 979, 989, 999]
    assert harness.states[-1].slip_updates == (1000 - 400) // 2 + 1


def test_channel_health_in_states_and_diagnostics(harness):
    """A NaN on left_root and an absurd finite value on right_middle: flagged in the states,
    ERROR for exactly those channels in /diagnostics with their counts; the others OK."""
    x = stream()
    for i in range(0, 1000, CHUNK):
        harness.send(x[i:i + CHUNK])
    bad = x[1000:1020].copy()
    bad[4, 2] = np.nan
    bad[9, 4] = 1e160
    bad[10, 4] = 1e160
    harness.send(bad)
    state = harness.states[-1]
    assert not state.data_valid and state.slip_active
    assert list(state.channel_health) == [0, 0, TactileState.HEALTH_NON_FINITE |
                                          TactileState.HEALTH_MASKED, 0,
                                          TactileState.HEALTH_OUT_OF_RANGE |
                                          TactileState.HEALTH_MASKED, 0]
    assert np.isnan(state.psd_max_db[[2, 4]]).all() and not np.isinf(state.psd_max_db).any()
    harness.send(x[1020:1040])
    assert harness.states[-1].data_valid
    assert list(harness.states[-1].channel_health) == [0, 0, 4, 0, 4, 0]
    names = [f'perception: channel {c}' for c in CHANNEL_NAMES]
    # the first diagnostics published after the bad message was processed (one in flight
    # from before may arrive first: take the first that reports an error, within 2 periods)
    before = len(harness.diagnostics)
    deadline = time.monotonic() + 5.0
    found = None
    while found is None:
        assert time.monotonic() < deadline, 'no diagnostics with the error'
        for array in harness.diagnostics[before:before + 2]:
            statuses = {s.name: s for s in array.status}
            assert set(names) <= set(statuses)
            if statuses[names[2]].level == DiagnosticStatus.ERROR:
                found = statuses
                break
        time.sleep(0.05)
    statuses = found
    levels = [statuses[n].level for n in names]
    assert levels == [DiagnosticStatus.OK, DiagnosticStatus.OK, DiagnosticStatus.ERROR,
                      DiagnosticStatus.OK, DiagnosticStatus.ERROR, DiagnosticStatus.OK]
    values = {kv.key: kv.value for kv in statuses[names[4]].values}
    assert values['out-of-range values'] == '2' and values['non-finite values'] == '0'
    values = {kv.key: kv.value for kv in statuses[names[2]].values}
    assert values['non-finite values'] == '1'
    assert harness.node.get_parameter('input_limit').value == 1.0


def test_stale_input_and_diagnostics(harness):
    assert harness.node.set_parameters([Parameter('stale_timeout', value=0.3)])[0].successful
    x = stream()
    for i in range(0, 600, CHUNK):
        harness.send(x[i:i + CHUNK])
    deadline = time.monotonic() + 5.0  # without input, stale states follow
    while not any(not s.data_valid and s.sample_index == 599 for s in harness.states):
        assert time.monotonic() < deadline, 'no stale state'
        time.sleep(0.02)
    assert all(s.data_valid for s in harness.states if s.sample_index < 599)
    # a report published while the stream was still arriving counts part of it: every report
    # must be consistent, and one published after the last message (1 Hz) must count it all
    deadline = time.monotonic() + 5.0
    counts = []
    while (len(counts) == 0 or counts[-1] != (30, 600)) and time.monotonic() < deadline:
        time.sleep(0.05)
        counts = []
        for array in list(harness.diagnostics):
            status = array.status[0]
            assert status.name == 'perception: pipeline'
            values = {kv.key: kv.value for kv in status.values}
            counts.append((int(values['messages']), int(values['samples'])))
    assert counts and counts[-1] == (30, 600), counts
    assert all(samples == CHUNK * messages for messages, samples in counts), counts
    assert counts == sorted(counts), counts


def test_entry_point_process_runs_and_stops_cleanly(tmp_path, model_file):
    """`python -m forte_perception.ros.perception_node` (what `perception_node` runs) in its own
    process: states come back over DDS, parameters from the command line, SIGINT exits 0."""
    import os
    import signal
    import subprocess
    import sys
    proc = subprocess.Popen(
        [sys.executable, '-m', 'forte_perception.ros.perception_node', '--ros-args',
         '-p', f'model_path:={model_file}', '-p', 'tare_duration:=0.5',
         '-p', 'stale_timeout:=30.0'],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=dict(os.environ))
    context = rclpy.Context()
    rclpy.init(context=context)
    peer = Node('peer_of_process', context=context)
    got = []
    peer.create_subscription(TactileState, 'tactile/state', got.append,
                             QoSProfile(depth=500, reliability=ReliabilityPolicy.RELIABLE))
    pub = peer.create_publisher(TactileFrames, 'tactile/frames',
                                QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE))
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(peer)
    try:
        deadline = time.monotonic() + 30.0
        while pub.get_subscription_count() < 1 or peer.count_publishers('tactile/state') < 1:
            assert time.monotonic() < deadline, 'node process did not come up'
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic() + 0.5  # let both endpoints finish matching
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        x = stream()
        helper = Harness.__new__(Harness)  # only for message construction
        helper.sequence = 0
        for k, i in enumerate(range(0, 3000, CHUNK)):  # lockstep: the input is best effort
            pub.publish(Harness.message(helper, x[i:i + CHUNK]))
            deadline = time.monotonic() + 5.0
            while len(got) < k + 1:
                assert time.monotonic() < deadline, f'no state for message {k}'
                executor.spin_once(timeout_sec=0.01)
        assert got[-1].sample_index == 2999 and got[-1].data_valid
        assert got[-1].tared and got[-1].force_valid  # tared after 0.5 s, model loaded
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            out, _ = proc.communicate(timeout=20)
        finally:
            if proc.poll() is None:
                proc.kill()
        executor.shutdown()
        peer.destroy_node()
        rclpy.shutdown(context=context)
    assert proc.returncode == 0, out
    assert 'perception up' in out


def test_large_messages_give_a_state_per_force_instant(harness):
    """A 200-sample message yields 10 states (force at 100 Hz whatever the batch size), equal
    to the pipeline fed in 20-sample pieces."""
    x = stream()
    before = len(harness.states)
    harness.pub.publish(harness.message(x[:200]))
    harness.wait_states(before + 10)
    states = harness.states[before:]
    assert [s.sample_index for s in states] == list(range(19, 200, 20))
    stamps = [s.header.stamp.sec * 10**9 + s.header.stamp.nanosec for s in states]
    assert np.all(np.diff(stamps) == 10_000_000)  # 10 ms apart
    harness.send(x[200:207])  # an unaligned message: one state at its end
    assert harness.states[-1].sample_index == 206
    before = len(harness.states)
    harness.pub.publish(harness.message(x[207:260]))  # force instants at 219, 239, 259
    harness.wait_states(before + 3)
    assert [s.sample_index for s in harness.states[before:]] == [219, 239, 259]


def pipeline_status(harness, after: int, timeout: float = 5.0) -> DiagnosticStatus:
    """The pipeline status of the first /diagnostics received after ``after`` arrays."""
    deadline = time.monotonic() + timeout
    while len(harness.diagnostics) <= after:
        assert time.monotonic() < deadline, 'no diagnostics'
        time.sleep(0.05)
    return harness.diagnostics[after].status[0]


def test_a_model_trained_at_another_rate_is_refused(harness, tmp_path):
    slow = trained_model(tmp_path / 'slow.npz', dict(SIMULATED_SENSOR.to_dict(),
                                                     sample_rate=1000.0))
    result = harness.node.set_parameters([Parameter('model_path', value=str(slow))])[0]
    assert not result.successful and '1000 Hz' in result.reason
    assert harness.node._pipeline.model is not None  # the previous model stays


def test_the_sensor_identity_decides_whether_the_model_is_used(harness, tmp_path):
    """A model trained on the simulator: on a board it is used with a WARN (recalibrate);
    on a board whose channel order differs it is refused (force_valid false, ERROR)."""
    sim_model = trained_model(tmp_path / 'sim.npz', SIMULATED_SENSOR.to_dict())
    assert harness.node.set_parameters(
        [Parameter('model_path', value=str(sim_model))])[0].successful
    board = SensorIdentity(source='serial', device_id='00000000c0ffee01', firmware='1.0.0',
                           protocol_version=1, adc_bits=12)
    info = harness.peer.create_publisher(SensorInfo, 'tactile/sensor_info', SENSOR_INFO)
    info.publish(SensorInfo(**board.to_dict()))
    x = stream()
    for i in range(0, 4000, CHUNK):
        harness.send(x[i:i + CHUNK])
    assert harness.states[-1].force_valid
    status = pipeline_status(harness, len(harness.diagnostics))
    values = {kv.key: kv.value for kv in status.values}
    assert status.level == DiagnosticStatus.WARN and 'recalibrate' in status.message
    assert values['sensor device'] == board.device_id
    assert values['model trained on device'] == 'simulator'
    assert values['force model'] == 'loaded'

    rewired = SensorIdentity(source='serial', device_id=board.device_id,
                             channel_names=CHANNEL_NAMES[3:] + CHANNEL_NAMES[:3])
    info.publish(SensorInfo(**rewired.to_dict()))
    deadline = time.monotonic() + 5.0
    while harness.node._sensor != rewired:
        assert time.monotonic() < deadline, 'sensor info not received'
        time.sleep(0.02)
    for i in range(4000, 5000, CHUNK):
        harness.send(x[i:i + CHUNK])
    assert not any(state.force_valid for state in harness.states[-40:])
    status = pipeline_status(harness, len(harness.diagnostics))
    assert status.level == DiagnosticStatus.ERROR
    assert status.message.startswith('force model refused: model channel order')
    assert {kv.key: kv.value for kv in status.values}['force model'] == 'refused'


@pytest.mark.parametrize('harness, told', [([Parameter('slip_mode', value='sequential')], False),
                                           ([Parameter('slip_mode', value='sequential')], True)],
                         indirect=['harness'], ids=['no_command', 'servo_command'])
def test_sequential_mode_gates_alarms_after_a_servo_command(harness, told):
    """A 30 ms 40 LSB ringing at sample 8000 (a servo step shaking the fingers): in the
    sequential mode it alarms, unless a gripper/command stamped at that sample's time (sent
    100 samples before, over DDS) told the node the servo moved."""
    from forte_msgs.msg import ServoCommand
    from forte_ros.qos import COMMANDS

    commands = harness.peer.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
    deadline = time.monotonic() + 10.0
    while commands.get_subscription_count() < 1:
        assert time.monotonic() < deadline, 'the node does not follow gripper/command'
        time.sleep(0.01)
    x = ringing_after_a_step()
    for start in range(0, x.shape[0], CHUNK):
        if told and start == 7900:
            command = ServoCommand(position=0.3)
            command.header.stamp.sec, command.header.stamp.nanosec = 104, 0  # sample 8000
            commands.publish(command)
            time.sleep(0.3)
        harness.send(x[start:start + CHUNK])
    flagged = [s.sample_index for s in harness.states if s.slip and s.sample_index >= 8000]
    if told:
        assert flagged == []
    else:
        assert flagged and flagged[0] < 8000 + 200



def _servo_command(position: float, sample: int, profile_velocity: float = 1.0):
    """A ServoCommand stamped at ``sample``'s time (sample 0 at 100 s, 2 kHz)."""
    from forte_msgs.msg import ServoCommand

    command = ServoCommand(position=position, profile_velocity=profile_velocity)
    nanoseconds = 100 * 10**9 + sample * 500_000
    command.header.stamp.sec, command.header.stamp.nanosec = divmod(nanoseconds, 10**9)
    return command


@pytest.mark.parametrize('harness', [[Parameter('slip_mode', value='sequential')]],
                         indirect=True)
def test_sequential_mode_hears_a_slip_right_after_a_known_tightening(harness):
    """Two gripper/commands at 1 rad/s: the node knows the second one's motion (0.0154 rad:
    31 samples) and flags an 8 LSB slip beginning 30 ms after its gate within 50 ms."""
    from forte_msgs.msg import ServoCommand
    from forte_ros.qos import COMMANDS

    commands = harness.peer.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
    deadline = time.monotonic() + 10.0
    while commands.get_subscription_count() < 1:
        assert time.monotonic() < deadline, 'the node does not follow gripper/command'
        time.sleep(0.01)
    onset = 8000 + 31 + 200 + 60
    x = tightening_then_slip(at=8000, slip_at=onset)
    sent = {6900: _servo_command(0.3, 7000), 7900: _servo_command(0.3 - 0.0154, 8000)}
    for start in range(0, x.shape[0], CHUNK):
        if start in sent:
            commands.publish(sent[start])
            time.sleep(0.3)
        harness.send(x[start:start + CHUNK])
    flagged = [s.sample_index for s in harness.states if s.slip and s.sample_index >= 7000]
    assert flagged and onset <= flagged[0] <= onset + 100
