"""Benchmarks of the grasp control (run by ``make bench`` with the environment sourced).

1. State machine step cost [us/step] against a baseline of building the same inputs without
   stepping (what any caller pays anyway).
2. Closed-loop trials (scene + perception + state machine): trials/s and x-realtime, against
   the same scene + pipeline stepped with the same commands but no controller, and the
   projected time of the 930-trial evaluation.
3. Slip -> tightening latency of the node over real DDS (Fast DDS, loopback):
   a) inside the node: TactileState callback entry to ServoCommand publish;
   b) end to end: a publisher node publishes a TactileState with slip, a subscriber node in
      the same process receives the ServoCommand from the controller running in its own
      process; baseline: the same path through a relay node that republishes a ServoCommand
      for every slip message with no logic.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
import time

from forte_ros.isolation import isolate_ros_network

isolate_ros_network()

import numpy as np  # noqa: E402

from forte_control.state_machine import (  # noqa: E402
    ControlInputs,
    ControllerParams,
    GraspGoal,
    GraspStateMachine,
    JointInput,
    PerceptionInput,
)


def percentiles(values, qs=(50, 90, 99)):
    array = np.asarray(values, float)
    return {q: float(np.percentile(array, q)) for q in qs} | {'max': float(array.max())}


# ------------------------------------------------------------------ 1. state machine step
def bench_step(n: int = 20000) -> None:
    machine = GraspStateMachine(ControllerParams(lift_distance=0.2, max_lift_distance=0.2,
                                                 timeout=3600.0))
    now = 0.0

    def inputs(t, contact):
        return ControlInputs(
            perception=PerceptionInput(stamp=t, force=0.5, force_valid=True,
                                       contact=(contact, contact), slip=False,
                                       slip_active=True, data_valid=True,
                                       filtered=(0.05,) * 6),
            joint=JointInput(stamp=t, theta=0.5))

    machine.start(GraspGoal(), now, inputs(now, False))
    for _ in range(3):  # into LIFTING
        now += 0.01
        machine.step(inputs(now, True), now)
    start = time.perf_counter()
    for _ in range(n):
        now += 0.0001
        machine.step(inputs(now, True), now)
    stepped = time.perf_counter() - start
    start = time.perf_counter()
    for _ in range(n):
        now += 0.0001
        inputs(now, True)
    baseline = time.perf_counter() - start
    step_us = (stepped - baseline) / n * 1e6
    print(f'[step] state machine step (LIFTING): {step_us:.1f} us/step '
          f'({stepped / n * 1e6:.1f} us incl. inputs); baseline building the inputs only: '
          f'{baseline / n * 1e6:.1f} us; ratio {stepped / baseline:.2f}x; '
          f'at 100 updates/s: {step_us * 100 / 1e4:.3f} % of one core')


# ------------------------------------------------------------------ 2. closed loop
def bench_closed_loop() -> None:
    from forte_evaluation.closed_loop import run_trial
    from forte_evaluation.sim_force_model import default_force_model
    from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
    from forte_sim import make_scene

    start = time.perf_counter()
    model = default_force_model()
    print(f'[closed loop] force model ready in {time.perf_counter() - start:.1f} s '
          f'({model.support_vectors.shape[0]} support vectors)')
    cases = [(obj, ctrl) for obj in ('raspberry', 'glass_bottle', 'apple')
             for ctrl in ('FORTE', 'NO_SLIP', 'ON_OFF')]
    results = []
    start = time.perf_counter()
    for obj, ctrl in cases:
        results.append(run_trial(obj, ctrl, seed=1, model=model))
    wall = time.perf_counter() - start
    simulated = sum(r.simulated_seconds for r in results)
    rate = len(results) / wall
    for r in results:
        print(f'  {r.object_name:13s} {r.controller:8s} outcome {r.outcome:10s} truth '
              f'{r.object_state:8s} success {r.success!s:5s} slip events {r.slip_events:2d} '
              f'sim {r.simulated_seconds:5.2f} s wall {r.wall_seconds:5.2f} s')
    # baseline: same scenes and pipeline, replaying the commands of the trial, no controller
    start = time.perf_counter()
    for obj, ctrl in cases[:3]:
        scene = make_scene('grasp', object_name=obj, seed=1)
        pipeline = PerceptionPipeline(PipelineConfig(tare_duration=0.5), model)
        chunks = int(next(r for r in results if r.object_name == obj
                          and r.controller == ctrl).simulated_seconds / 0.01)
        for _ in range(chunks):
            frames, _ = scene.step(20, scene.initial_angle, 0.0)
            pipeline.process(frames)
    base_wall = time.perf_counter() - start
    base_sim = sum(r.simulated_seconds for r in results[:3])
    loop_ratio = (sum(r.wall_seconds for r in results[:3]) / base_wall) if base_wall else math.nan
    print(f'[closed loop] {len(results)} trials in {wall:.1f} s: {rate:.2f} trials/s, '
          f'{simulated / wall:.1f}x realtime (single process)')
    print(f'[closed loop] baseline scene + pipeline without controller: '
          f'{base_sim / base_wall:.1f}x realtime; full loop / baseline wall time '
          f'= {loop_ratio:.2f}x (controller + bookkeeping overhead)')
    print(f'[closed loop] projected evaluation, 930 trials: {930 / rate / 60:.1f} min on one '
          f'core, {930 / rate / 60 / 2:.1f} min on 2 worker processes')


# ------------------------------------------------------------------ 3. slip latency (ROS)
RELAY_SCRIPT = r'''
import rclpy, sys
from rclpy.node import Node
from forte_msgs.msg import TactileState, ServoCommand
from forte_ros.qos import COMMANDS, TACTILE_STATE
rclpy.init()
node = Node('relay')
pub = node.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
def on_state(msg):
    if msg.slip:
        out = ServoCommand()
        out.header.stamp = node.get_clock().now().to_msg()
        out.position = 0.1
        pub.publish(out)
node.create_subscription(TactileState, 'tactile/state', on_state, TACTILE_STATE)
print('ready', flush=True)
try:
    rclpy.spin(node)
except Exception:
    pass
finally:
    rclpy.try_shutdown()
'''


class LatencyWorld:
    """Publisher + subscriber nodes standing in for perception, gripper and arm."""

    def __init__(self, rclpy, executor_type):
        from geometry_msgs.msg import TwistStamped
        from rclpy.node import Node
        from sensor_msgs.msg import JointState

        from forte_msgs.msg import ServoCommand, TactileState
        from forte_ros.qos import COMMANDS, TACTILE_STATE

        self.TactileState = TactileState
        self.JointState = JointState
        self.publisher_node = Node('bench_perception')
        self.subscriber_node = Node('bench_gripper')
        self.tactile_pub = self.publisher_node.create_publisher(TactileState, 'tactile/state',
                                                                TACTILE_STATE)
        self.joint_pub = self.publisher_node.create_publisher(JointState, 'joint_states',
                                                              COMMANDS)
        self.lock = threading.Lock()
        self.theta = 0.7
        self.sent_slip_at = None
        self.latencies: list[float] = []
        self.commands = 0
        self.slip_next = False
        self.subscriber_node.create_subscription(ServoCommand, 'gripper/command',
                                                 self.on_command, COMMANDS)
        self.subscriber_node.create_subscription(TwistStamped, 'arm/cmd_vel',
                                                 lambda msg: None, COMMANDS)
        self.publisher_node.create_timer(0.01, self.tick)
        self.executor = executor_type()
        self.executor.add_node(self.publisher_node)
        self.executor.add_node(self.subscriber_node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def on_command(self, msg) -> None:
        received = time.monotonic()
        with self.lock:
            self.commands += 1
            self.theta = msg.position  # a soft object: 10 N/rad beyond contact at 0.5 rad
            if self.sent_slip_at is not None:
                self.latencies.append(received - self.sent_slip_at)
                self.sent_slip_at = None

    def tick(self) -> None:
        with self.lock:
            squeeze = 0.5 - self.theta
            slip = self.slip_next
            self.slip_next = False
        msg = self.TactileState()
        msg.header.stamp = self.publisher_node.get_clock().now().to_msg()
        msg.force = max(0.0, 10.0 * squeeze)
        msg.force_valid = True
        msg.contact = [squeeze > 0.0, squeeze > 0.0]
        msg.slip = slip
        msg.slip_active = True
        msg.data_valid = True
        msg.filtered = [max(0.0, 0.05 * squeeze)] * 6
        joints = self.JointState()
        joints.header.stamp = msg.header.stamp
        joints.name = ['forte_left_finger_joint', 'forte_right_finger_joint']
        joints.position = [self.theta, self.theta]
        self.joint_pub.publish(joints)
        if slip:
            with self.lock:
                self.sent_slip_at = time.monotonic()
        self.tactile_pub.publish(msg)

    def inject(self, count: int, period: float) -> None:
        for _ in range(count):
            time.sleep(period)
            with self.lock:
                self.slip_next = True

    def measure(self, events: int) -> list[float]:
        """Slip -> command latencies [s] of ``events`` slips, one every 50 ms, after 1 s."""
        time.sleep(1.0)
        with self.lock:
            self.latencies.clear()
        self.inject(events, 0.05)
        time.sleep(0.5)
        return list(self.latencies)

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.publisher_node.destroy_node()
        self.subscriber_node.destroy_node()


def _wait(condition, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not condition():
        time.sleep(0.01)
    return condition()


#: grasp_controller_node parameters of the end-to-end latency run: a quick grasp into LIFTING,
#: a tightening for every slip message.
LATENCY_CONTROLLER_PARAMETERS = {
    'closing_speed': 1.0, 'loading_speed': 0.5, 'lift_speed': 0.002, 'lift_distance': 0.05,
    'slip_increment': 0.004, 'slip_refractory': 0.0, 'max_tightening': 0.6,
    'perception_timeout': 1.0, 'joint_state_timeout': 1.0}


def _stop(process: subprocess.Popen) -> None:
    """Terminate ``process``; kill it if it has not exited 10 s later."""
    process.terminate()
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()


def _start_controller(env: dict) -> subprocess.Popen:
    """grasp_controller_node in its own process (:data:`LATENCY_CONTROLLER_PARAMETERS`)."""
    args = ['--ros-args']
    for name, value in LATENCY_CONTROLLER_PARAMETERS.items():
        args += ['-p', f'{name}:={value}']
    return subprocess.Popen(
        [sys.executable, '-m', 'forte_control.ros.grasp_controller_node', *args], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _grasp_client():
    """A Grasp action client in a node of its own, spun in a thread: (client, executor)."""
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from forte_msgs.action import Grasp

    client_node = Node('bench_client')
    client = ActionClient(client_node, Grasp, 'grasp')
    client_executor = SingleThreadedExecutor()
    client_executor.add_node(client_node)
    threading.Thread(target=client_executor.spin, daemon=True).start()
    return client, client_executor


def _controller_latencies(world: LatencyWorld, client, events: int) -> list[float] | None:
    """Slip -> tightening latencies [s] through the controller, its grasp in LIFTING.

    None if the controller's action server did not come up.
    """
    from forte_msgs.action import Grasp

    if not client.wait_for_server(timeout_sec=20.0):
        return None
    time.sleep(1.0)
    goal_future = client.send_goal_async(Grasp.Goal())
    _wait(goal_future.done, 10.0)
    handle = goal_future.result()
    # wait for LIFTING: the servo stops changing once loaded
    _wait(lambda: world.commands > 5, 10.0)
    latencies = world.measure(events)
    if handle is not None and handle.accepted:
        cancel = handle.cancel_goal_async()
        _wait(cancel.done, 5.0)
    return latencies


def _relay_latencies(world: LatencyWorld, env: dict, events: int) -> list[float]:
    """The baseline: slip -> command latencies [s] through a relay node in its own process."""
    relay = subprocess.Popen([sys.executable, '-c', RELAY_SCRIPT], env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        relay.stdout.readline()
        _wait(lambda: world.tactile_pub.get_subscription_count() > 0, 10.0)
        return world.measure(events)
    finally:
        _stop(relay)


def bench_latency(events: int = 60) -> None:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    rclpy.init()
    env = dict(os.environ)
    controller = _start_controller(env)
    world = LatencyWorld(rclpy, SingleThreadedExecutor)
    client, client_executor = _grasp_client()
    try:
        node_latencies = _controller_latencies(world, client, events)
    finally:
        _stop(controller)
    if node_latencies is None:
        print('[latency] controller did not come up; skipped')
        return
    relay_latencies = _relay_latencies(world, env, events)
    world.close()
    client_executor.shutdown(timeout_sec=2.0)
    rclpy.try_shutdown()
    if not node_latencies or not relay_latencies:
        print(f'[latency] too few samples (controller {len(node_latencies)}, relay '
              f'{len(relay_latencies)})')
        return
    c = percentiles(node_latencies)
    r = percentiles(relay_latencies)
    print(f'[latency] slip -> tightening end to end (publisher node -> controller process -> '
          f'subscriber node), {len(node_latencies)} events: p50 {c[50] * 1e3:.2f} ms, '
          f'p90 {c[90] * 1e3:.2f} ms, p99 {c[99] * 1e3:.2f} ms, max {c["max"] * 1e3:.2f} ms')
    print(f'[latency] baseline relay node (no logic), {len(relay_latencies)} events: '
          f'p50 {r[50] * 1e3:.2f} ms, p90 {r[90] * 1e3:.2f} ms, p99 {r[99] * 1e3:.2f} ms; '
          f'ratio of medians {c[50] / r[50]:.2f}x; one perception update = 10 ms')


def bench_latency_in_process(events: int = 200) -> None:
    """Callback entry -> publish inside the node (perf_counter), node in this process."""
    import rclpy
    from rclpy.parameter import Parameter

    from forte_control.ros.grasp_controller_node import GraspControllerNode
    from forte_msgs.msg import TactileState

    rclpy.init()
    node = GraspControllerNode(parameter_overrides=[
        Parameter('slip_refractory', value=0.0), Parameter('slip_increment', value=0.002),
        Parameter('initial_force_mode', value='absolute'),
        Parameter('max_tightening', value=0.6), Parameter('lift_distance', value=0.2),
        Parameter('timeout', value=600.0),
        Parameter('perception_timeout', value=1.0), Parameter('joint_state_timeout', value=1.0)])
    # the node is not spun: this thread calls its callbacks, as its one executor thread would
    from forte_control.state_machine import ControlInputs, JointInput, PerceptionInput

    def msg(slip, contact=True):
        m = TactileState()
        m.header.stamp = node.get_clock().now().to_msg()
        m.force = 0.5
        m.force_valid = True
        m.contact = [contact, contact]
        m.slip = slip
        m.slip_active = True
        m.data_valid = True
        m.filtered = [0.05] * 6
        return m

    now = node.get_clock().now().nanoseconds * 1e-9
    node._joint = JointInput(stamp=now, theta=0.5)
    node._perception = PerceptionInput(stamp=now, force=0.3, force_valid=True,
                                       contact=(True, True), slip_active=True, data_valid=True)
    node._machine.start(GraspGoal(), now, ControlInputs(node._perception, node._joint))
    for _ in range(5):
        node._joint = JointInput(stamp=node.get_clock().now().nanoseconds * 1e-9, theta=0.5)
        node._on_tactile(msg(False))
        time.sleep(0.01)
    node.slip_reaction_latency.clear()
    for _ in range(events):
        node._joint = JointInput(stamp=node.get_clock().now().nanoseconds * 1e-9, theta=0.5)
        node._on_tactile(msg(True))
    latencies = list(node.slip_reaction_latency)
    node.destroy_node()
    rclpy.try_shutdown()
    if latencies:
        p = percentiles(latencies)
        print(f'[latency] inside the node, tactile callback -> ServoCommand published, '
              f'{len(latencies)} events: p50 {p[50] * 1e6:.0f} us, p99 {p[99] * 1e6:.0f} us, '
              f'max {p["max"] * 1e6:.0f} us')
    else:
        print('[latency] inside the node: no slip reaction recorded')


def main() -> None:
    start = time.perf_counter()
    bench_step()
    bench_latency_in_process()
    bench_latency()
    bench_closed_loop()
    print(f'[bench_control] total {time.perf_counter() - start:.1f} s')


if __name__ == '__main__':
    main()
