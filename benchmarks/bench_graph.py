"""The live FORTE graphs at real time: CPU per node idle and grasping, latency, echo floor.

Brings up each graph exactly as ``forte_bringup`` does (:class:`forte_bringup.bringup.Bringup`,
one process per node, real DDS on this machine only) and measures, per node process, the CPU
time from ``/proc/<pid>/stat`` (utime + stime, in % of one core) over each phase:

- **sim** (real-time factor 1.0, raspberry): idle (no goal) and during back-to-back FORTE
  grasps; the scene is reset between grasps (sim cleanup + configure + activate, perception
  reset and auto-tare); the outcome of every grasp and the ground truth are counted, and any
  STALE_* fault is reported;
- **hardware**: the emulated tactile sensor and the simulated Dynamixel pair on
  pseudo-terminals (``forte_driver.emulators.emulated_sensor``,
  ``forte_driver.emulators.simulated_servo``),
  idle;
- **replay**: a bag of a quiet sensor (``forte_bringup.testing.write_quiet_bag``) replayed at its
  recorded rate.

Baseline, in the same run and graph: an **echo node** (``bench_perception_node.ECHO_NODE``)
subscribed to ``tactile/frames`` like perception (same QoS and clock), publishing one empty
TactileState per message: the rclpy floor of a node with perception's input.

Latency, from a frame's sample time (its header stamp; in simulation the sample clock is the
wall clock at activation plus the sample index, so it is comparable with receive times) to
the receipt here of: the echo's state (floor), perception's ``tactile/state``, and the
controller's ``gripper/command`` during grasps (the controller stamps a command with the
time of the newest data it answers).

``--grasps N --burners K`` runs N grasps beside K CPU-bound processes (the issue's stress
run: 30 grasps beside 2 burners). Run from the repository root with the workspace sourced::

    python benchmarks/bench_graph.py                      # sim, hardware, replay
    python benchmarks/bench_graph.py --graphs sim --grasps 30 --burners 2
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_perception_node import ECHO_NODE, proc_cpu_seconds  # noqa: E402

from forte_ros import call_in_executor  # noqa: E402
from forte_ros.isolation import isolate_ros_network  # noqa: E402

OUTCOME_STALE = 'STALE'


def burn() -> None:
    """A CPU-bound process (the robot PC's other work)."""
    value = 0
    while True:
        value = (value * 1103515245 + 12345) % 2 ** 31


class Probe:
    """This process's node: receive-time latencies, the Grasp client, the ground truth."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        from std_srvs.srv import Trigger

        from forte_msgs.action import Grasp
        from forte_msgs.msg import ServoCommand, SimGroundTruth, TactileState
        from forte_ros.qos import reliable as reliable_profile

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('forte_bench_probe', context=self.context)
        # deeper than the contract's queues: the probe must not lose a latency sample while
        # this process is busy (burners beside the graph)
        reliable = reliable_profile(100)
        self.latency: dict[str, list[float]] = {'echo': [], 'perception': [], 'command': []}
        self.truth = None
        self.tared = 0
        for topic, key, kind in (('bench/echo_state', 'echo', TactileState),
                                 ('tactile/state', 'perception', TactileState),
                                 ('gripper/command', 'command', ServoCommand)):
            self.node.create_subscription(kind, topic, self._receiver(key), reliable)
        self.node.create_subscription(SimGroundTruth, 'sim/ground_truth', self._on_truth,
                                      reliable)
        self.grasp_client = ActionClient(self.node, Grasp, 'grasp')
        self.reset_client = self.node.create_client(Trigger, 'perception/reset')
        self.Grasp, self.Trigger = Grasp, Trigger
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _receiver(self, key: str):
        samples = self.latency[key]

        def receive(message) -> None:
            stamp = message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec
            samples.append(time.time() - stamp)
            if key == 'perception' and message.tared and message.data_valid:
                self.tared += 1
        return receive

    def _on_truth(self, message) -> None:
        self.truth = message

    def clear(self) -> None:
        for samples in self.latency.values():
            samples.clear()

    def wait(self, future, timeout: float):
        deadline = time.monotonic() + timeout
        while not future.done():
            if time.monotonic() > deadline:
                raise RuntimeError('no answer in time')
            time.sleep(0.01)
        return future.result()

    def reset_perception(self) -> None:
        assert self.reset_client.wait_for_service(timeout_sec=20.0), 'no perception/reset'
        self.wait(self.reset_client.call_async(self.Trigger.Request()), 20.0)
        self.tared = 0
        deadline = time.monotonic() + 30.0
        while self.tared < 10:
            if time.monotonic() > deadline:
                raise RuntimeError('perception did not tare')
            time.sleep(0.02)

    def grasp(self, timeout: float = 60.0) -> tuple[str, str]:
        """One FORTE grasp (lift 1 cm); returns (outcome name, result message)."""
        assert self.grasp_client.wait_for_server(timeout_sec=30.0), 'no grasp action server'
        goal = self.Grasp.Goal(controller=self.Grasp.Goal.FORTE, lift_distance=0.01,
                               timeout=timeout)
        handle = self.wait(call_in_executor(self.executor, self.grasp_client.send_goal_async,
                                            goal), 30.0)
        if not handle.accepted:
            return 'REJECTED', ''
        result = self.wait(call_in_executor(self.executor, handle.get_result_async),
                           timeout + 30.0).result
        names = {v: k for k, v in vars(self.Grasp.Result).items()
                 if k.isupper() and isinstance(v, int)}
        return names.get(result.outcome, str(result.outcome)), result.message

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def percentile_ms(values: list[float], q: float) -> float:
    import numpy as np

    return float(np.percentile(values, q) * 1e3) if values else float('nan')


class CpuMeter:
    """CPU share of named processes between :meth:`start` and :meth:`stop` [% of a core]."""

    def __init__(self, pids: dict[str, int]) -> None:
        self.pids = pids
        self._start: dict[str, float] = {}
        self._t0 = 0.0

    def start(self) -> None:
        self._start = {name: proc_cpu_seconds(pid) for name, pid in self.pids.items()}
        self._t0 = time.monotonic()

    def stop(self) -> dict[str, float]:
        elapsed = time.monotonic() - self._t0
        return {name: 100.0 * (proc_cpu_seconds(pid) - self._start[name]) / elapsed
                for name, pid in self.pids.items()}


def graph_meter(bringup, echo: subprocess.Popen) -> CpuMeter:
    """A meter of every process of the graph and of the echo node."""
    return CpuMeter({**{c.name: c.process.pid for c in bringup.children}, 'echo': echo.pid})


def idle_phase(graph: str, label: str, meter: CpuMeter, seconds: float,
               probe: Probe | None = None) -> None:
    """CPU over ``seconds`` with no goal (and the latencies, given a probe)."""
    if probe is not None:
        probe.clear()
    meter.start()
    time.sleep(seconds)
    print_cpu(graph, f'{label} ({seconds:g} s)', meter.stop())
    if probe is not None:
        print_latency(graph, probe)
        probe.clear()


def start_echo(use_sim_time: bool, folder: Path) -> subprocess.Popen:
    script = folder / 'echo_node.py'
    script.write_text(ECHO_NODE)
    return subprocess.Popen(
        [sys.executable, str(script), '--ros-args', '-r', '__node:=bench_echo',
         '-r', 'tactile/state:=bench/echo_state', '-p', f'use_sim_time:={use_sim_time}'],
        stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, start_new_session=True)


def print_cpu(graph: str, phase: str, shares: dict[str, float]) -> None:
    nodes = {k: v for k, v in shares.items() if k != 'echo'}
    parts = ', '.join(f'{name} {share:.1f} %' for name, share in nodes.items())
    line = f'[{graph}] CPU {phase}: {parts}; FORTE nodes total {sum(nodes.values()):.1f} %'
    if 'echo' in shares and 'perception' in shares:
        line += (f'; echo floor {shares["echo"]:.1f} %, perception / echo '
                 f'{shares["perception"] / max(shares["echo"], 1e-9):.2f}x')
    print(line, flush=True)


def print_latency(graph: str, probe: Probe) -> None:
    for key, label in (('echo', 'echo floor: frame -> echo state'),
                       ('perception', 'frame -> tactile/state'),
                       ('command', 'frame -> gripper/command')):
        values = probe.latency[key]
        if values:
            print(f'[{graph}] latency {label}: p50 {percentile_ms(values, 50):.2f} ms, '
                  f'p90 {percentile_ms(values, 90):.2f} ms, p99 {percentile_ms(values, 99):.2f} '
                  f'ms ({len(values)} messages)', flush=True)


def run_sim(args: argparse.Namespace, folder: Path, model: Path) -> dict:
    from forte_bringup.bringup import Bringup

    bringup = Bringup('sim', {'object': 'raspberry', 'force_model': str(model),
                              'real_time_factor': '1.0'},
                      log_dir=folder / 'sim_logs', echo=None)
    echo = start_echo(True, folder)
    probe = Probe()
    burners = [multiprocessing.Process(target=burn, daemon=True) for _ in range(args.burners)]
    outcomes: dict[str, int] = {}
    try:
        bringup.start(timeout=60.0)
        meter = graph_meter(bringup, echo)
        for burner in burners:
            burner.start()
        probe.reset_perception()
        time.sleep(2.0)
        idle_phase('sim', 'idle', meter, args.idle, probe)
        stale = 0
        grasping = 0.0
        shares_sum: dict[str, float] = {}
        for index in range(args.grasps):
            if index:  # a fresh scene: the object back on the table, the sensor re-tared
                bringup.new_scene()
                probe.reset_perception()
            started = time.monotonic()
            meter.start()
            outcome, message = probe.grasp()
            shares = meter.stop()
            duration = time.monotonic() - started
            grasping += duration
            for name, share in shares.items():
                shares_sum[name] = shares_sum.get(name, 0.0) + share * duration
            truth = probe.truth.object_state if probe.truth is not None else -1
            key = f'{outcome}/{"HELD" if truth == 2 else truth}'
            outcomes[key] = outcomes.get(key, 0) + 1
            stale += OUTCOME_STALE in message
            print(f'[sim] grasp {index + 1}/{args.grasps}: {outcome} (truth object_state '
                  f'{truth}) in {duration:.1f} s{": " + message if outcome != "LIFTED" else ""}',
                  flush=True)
        print_cpu('sim', f'grasping ({args.grasps} FORTE grasps, {grasping:.0f} s)',
                  {name: total / grasping for name, total in shares_sum.items()})
        print_latency('sim', probe)
        print(f'[sim] outcomes (controller/truth): {outcomes}; STALE faults: {stale}; '
              f'burners beside the graph: {args.burners}', flush=True)
    finally:
        for burner in burners:
            burner.terminate()
        probe.close()
        echo.terminate()
        echo.wait(10)
        bringup.stop()
    return outcomes


def run_hardware(args: argparse.Namespace, folder: Path, model: Path) -> None:
    from forte_bringup.bringup import Bringup
    from forte_bringup.testing import emulated_devices

    with emulated_devices(folder) as (sensor, gripper):
        bringup = Bringup('hardware', {'sensor_port': str(sensor), 'gripper_port': str(gripper),
                                       'force_model': str(model)},
                          log_dir=folder / 'hardware_logs', echo=None)
        echo = start_echo(False, folder)
        probe = Probe()
        try:
            bringup.start(timeout=60.0)
            time.sleep(3.0)
            idle_phase('hardware', 'idle, emulated devices on ptys', graph_meter(bringup, echo),
                       args.idle, probe)
        finally:
            probe.close()
            echo.terminate()
            echo.wait(10)
            bringup.stop()


def run_replay(args: argparse.Namespace, folder: Path, model: Path) -> None:
    from forte_bringup.bringup import Bringup
    from forte_bringup.testing import write_quiet_bag

    bag = write_quiet_bag(folder / 'bag', messages=int(100 * (args.idle + 15.0)))
    bringup = Bringup('replay', {'bag': str(bag), 'rate': '1.0', 'force_model': str(model)},
                      log_dir=folder / 'replay_logs', echo=None)
    echo = start_echo(False, folder)
    try:
        bringup.start(timeout=60.0)
        time.sleep(2.0)
        idle_phase('replay', 'replaying at rate 1.0', graph_meter(bringup, echo), args.idle)
    finally:
        echo.terminate()
        echo.wait(10)
        bringup.stop()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--graphs', nargs='+', default=['sim', 'hardware', 'replay'],
                        choices=['sim', 'hardware', 'replay'])
    parser.add_argument('--idle', type=float, default=20.0, help='idle phase length [s]')
    parser.add_argument('--grasps', type=int, default=5, help='FORTE grasps in the sim graph')
    parser.add_argument('--burners', type=int, default=0,
                        help='CPU-bound processes beside the sim graph')
    args = parser.parse_args(argv)
    domain = isolate_ros_network()
    print(f'[bench_graph] ROS_DOMAIN_ID={domain}, discovery on localhost only; '
          f'{os.cpu_count()} CPUs', flush=True)
    from forte_evaluation.sim_force_model import default_force_model

    with tempfile.TemporaryDirectory(prefix='forte_bench_graph_') as tmp:
        folder = Path(tmp)
        model = folder / 'force_model.npz'
        default_force_model().save(model)
        started = time.monotonic()
        if 'sim' in args.graphs:
            run_sim(args, folder, model)
        if 'hardware' in args.graphs:
            run_hardware(args, folder, model)
        if 'replay' in args.graphs:
            run_replay(args, folder, model)
        print(f'[bench_graph] total {time.monotonic() - started:.0f} s', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
