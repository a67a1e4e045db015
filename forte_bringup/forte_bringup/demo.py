"""The FORTE demo (``make demo``, ``python -m forte_bringup.demo``).

Runs the simulated scene with the full ROS 2 graph (``sim_node``, ``perception_node``,
``grasp_controller_node`` as separate processes over real DDS, brought up by
:class:`forte_bringup.bringup.Bringup` exactly as ``forte_bringup sim`` does), grasps a few
contrasting objects (a raspberry, a soda can, a glass bottle) with each controller (FORTE,
NO_SLIP, ON_OFF) through the ``grasp`` action, records every topic to one MCAP bag, then
reads the bag back and writes a report to ``out/demo/``:

- ``report.md``: outcome table (controller's outcome, ground-truth object state, lift,
  forces, slip events and onsets), one figure per grasp, where every file is;
- ``<object>_<controller>.png``: filtered channels, estimated vs true force, PSD features,
  finger variance with the slip threshold and the true slip onsets, servo command and lift;
- ``bag/``: the rosbag2 MCAP recording (``ros2 bag info out/demo/bag`` on a ROS install);
- ``logs/``: each node's output.

The graph is started once, at real time by default. Every grasp gets a fresh scene: the
simulator is cleaned up and configured again with the object on the table (lifecycle
transitions, ``Bringup.new_scene``), perception is restarted (``perception/reset``) and tares
itself on the quiet start, and the controller, idle between goals, waits for the new data;
so grasps never influence each other. The recorder runs throughout.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from forte_bringup.bringup import Bringup

#: The demo's objects: fragile (crushed by ON_OFF), slippery (dropped by NO_SLIP), heavy.
DEFAULT_OBJECTS = ('raspberry', 'soda_can', 'glass_bottle')
DEFAULT_CONTROLLERS = ('FORTE', 'NO_SLIP', 'ON_OFF')
#: Scene seed per object (placement, material spread, noise), the same for every controller.
#: Chosen so each scripted grasp has a single physical outcome: in the closed loop it is the
#: same for perception updates of 10, 20, 30 and 40 samples. (Seed 0 of the soda can is a
#: race for FORTE between stick-slip and tightenings: carried or not with the batch size;
#: seed 13, used next, needed all 20 allowed tightenings at some batch sizes: seed 7 needs
#: 12-15.) Other objects get seed 0.
DEMO_SEEDS = {'raspberry': 0, 'soda_can': 7, 'glass_bottle': 0}


def say(text: str) -> None:
    """Progress line on stdout."""
    print(f'[demo] {text}', flush=True)


def prepare_force_model(output: Path) -> Path:
    """The simulated-rig force model for the perception node, saved next to the report."""
    from forte_evaluation.sim_force_model import default_force_model

    path = output / 'force_model.npz'
    say('force model: training on the simulated calibration rig (cached after the first run)')
    default_force_model().save(path)
    return path


class DemoClient:
    """The demo's own ROS node: the recorder, the Grasp action client, ground-truth watch."""

    def __init__(self, bag: Path) -> None:
        import rclpy
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import JointState
        from std_srvs.srv import Trigger

        from forte_bringup.bag_recorder import BagRecorder
        from forte_msgs.action import Grasp
        from forte_msgs.msg import SimGroundTruth, TactileState
        from forte_ros.qos import COMMANDS, GROUND_TRUTH, TACTILE_STATE

        rclpy.init()
        self.recorder = BagRecorder(bag, node_name='forte_demo_recorder')
        self.node = rclpy.create_node('forte_demo')
        self.client = ActionClient(self.node, Grasp, 'grasp')
        self.reset_client = self.node.create_client(Trigger, 'perception/reset')
        self._goals_sent = 0
        self.truth = None
        self.max_true_force = 0.0
        self.tared_states = 0
        self.joint_states = 0
        self.node.create_subscription(SimGroundTruth, 'sim/ground_truth', self._on_truth,
                                      GROUND_TRUTH)
        self.node.create_subscription(TactileState, 'tactile/state', self._on_state,
                                      TACTILE_STATE)
        self.node.create_subscription(JointState, 'joint_states', self._on_joint_state,
                                      COMMANDS)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.recorder.node)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_state(self, message) -> None:
        if message.tared and message.data_valid:
            self.tared_states += 1

    def _on_joint_state(self, _message) -> None:
        self.joint_states += 1

    def reset_perception(self, timeout: float = 30.0) -> None:
        """Restart the perception pipeline (it tares again on the quiet start)."""
        from std_srvs.srv import Trigger

        if not self.reset_client.wait_for_service(timeout_sec=timeout):
            raise RuntimeError('perception/reset not available')
        future = self.reset_client.call_async(Trigger.Request())
        deadline = time.monotonic() + timeout
        while not future.done():
            if time.monotonic() > deadline:
                raise RuntimeError('perception/reset did not answer')
            time.sleep(0.02)

    def wait_ready(self, timeout: float = 30.0) -> None:
        """Wait until perception publishes tared, valid states and joint states flow."""
        self.tared_states = self.joint_states = 0
        deadline = time.monotonic() + timeout
        while self.tared_states < 20 or self.joint_states < 10:
            if time.monotonic() > deadline:
                raise RuntimeError(f'graph not ready: {self.tared_states} tared perception '
                                   f'states, {self.joint_states} joint states in {timeout} s')
            time.sleep(0.05)

    def _on_truth(self, message) -> None:
        self.truth = message
        self.max_true_force = max(self.max_true_force, *message.finger_force)

    def grasp(self, controller: str, timeout: float, attempts: int = 3) -> dict:
        """Send a Grasp goal and wait for its result; a goal the controller refuses before
        any motion (e.g. data not fresh yet) is retried after a second."""
        for attempt in range(attempts):
            result = self._grasp_once(controller, timeout)
            if not result['message'].startswith('refused') or attempt + 1 == attempts:
                return result
            say(f'  goal refused ({result["message"]}); retrying in 1 s')
            time.sleep(1.0)
        return result

    def _grasp_once(self, controller: str, timeout: float) -> dict:
        from forte_msgs.action import Grasp
        from forte_ros import call_in_executor

        if not self.client.wait_for_server(timeout_sec=30.0):
            raise RuntimeError('grasp action server not available')
        if not self._goals_sent:
            # the client sees the server; give the server time to match the client's response
            # readers too, or a reliable response can go to nobody (the goal runs
            # unacknowledged)
            time.sleep(1.0)
        self._goals_sent += 1
        self.max_true_force = 0.0
        goal = Grasp.Goal(controller=getattr(Grasp.Goal, controller), timeout=timeout)
        sent = call_in_executor(self.executor, self.client.send_goal_async, goal)
        deadline = time.monotonic() + 30.0
        while not sent.done():
            if time.monotonic() > deadline:
                raise RuntimeError('goal not acknowledged within 30 s')
            time.sleep(0.02)
        handle = sent.result()
        if not handle.accepted:
            raise RuntimeError('goal rejected')
        result_future = call_in_executor(self.executor, handle.get_result_async)
        deadline = time.monotonic() + timeout + 30.0
        while not result_future.done():
            if time.monotonic() > deadline:
                call_in_executor(self.executor, handle.cancel_goal_async)
                raise RuntimeError('no result within the timeout')
            time.sleep(0.05)
        result = result_future.result().result
        names = {v: k for k, v in vars(Grasp.Result).items()
                 if k.isupper() and isinstance(v, int)}
        return {'outcome': names.get(result.outcome, str(result.outcome)),
                'message': result.message, 'final_force': result.final_force,
                'lift_height': result.lift_height, 'slip_events': result.slip_events,
                'tightening': result.tightening, 'duration': result.duration}

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.recorder.close()
        self.recorder.node.destroy_node()
        self.node.destroy_node()
        rclpy.try_shutdown()


OBJECT_STATES = {0: 'NONE', 1: 'RESTING', 2: 'HELD', 3: 'DROPPED', 4: 'BROKEN', 5: 'CRUSHED'}


def grasp_scene(bringup: Bringup, client: DemoClient, object_name: str, controller: str,
                settle: float, timeout: float, progress: str) -> tuple[dict, int]:
    """A fresh scene of ``object_name`` grasped with ``controller``, recorded ``settle`` s on.

    ``progress`` (e.g. ``3/9 raspberry / ON_OFF``) heads the progress line. Returns the
    outcome row (the Grasp result and the ground truth after the settle time) and the
    receive time [ns] at which the grasp began.
    """
    seed = DEMO_SEEDS.get(object_name, 0)
    bringup.new_scene(object=object_name, seed=seed)
    client.reset_perception()
    client.wait_ready()  # perception tared on the quiet start, joints known
    first = time.time_ns()
    say(f'{progress}: grasping')
    result = client.grasp(controller, timeout)
    time.sleep(settle)  # let the object settle (or fall) in the recording
    truth = client.truth
    result.update(
        object=object_name, controller=controller, seed=seed,
        object_state=OBJECT_STATES.get(truth.object_state, '?') if truth else '?',
        object_height=truth.object_height if truth else float('nan'),
        max_true_force=client.max_true_force,
        true_slip_onsets=truth.slip_onsets if truth else 0)
    return result, first


def grasp_all(bringup: Bringup, client: DemoClient, objects: list[str], controllers: list[str],
              settle: float, timeout: float, started: float, rows: list[dict],
              windows: list[tuple[str, int, int]]) -> None:
    """Every object with every controller; appends to ``rows`` and the bag ``windows``.

    A grasp that fails (the graph or the goal) becomes a ``demo error`` row; the others go on.
    """
    from forte_bringup.bringup import BringupError

    total = len(objects) * len(controllers)
    for object_index, object_name in enumerate(objects):
        for controller_index, controller in enumerate(controllers):
            number = object_index * len(controllers) + controller_index + 1
            label = f'{object_name} / {controller}'
            try:
                result, first = grasp_scene(bringup, client, object_name, controller,
                                            settle, timeout, f'{number}/{total} {label}')
                windows.append((label, first, time.time_ns()))
                rows.append(result)
                say(f'{number}/{total} {label}: {result["outcome"]}, object '
                    f'{result["object_state"]}, lift {1000 * result["lift_height"]:.1f} mm, '
                    f'{result["slip_events"]} slip reactions '
                    f'({time.monotonic() - started:.0f} s elapsed)')
            except (BringupError, RuntimeError) as error:
                say(f'{number}/{total} {label}: FAILED: {error}')
                rows.append({'object': object_name, 'controller': controller,
                             'outcome': f'demo error: {error}'})


def write_report(output: Path, bag: Path, model: Path, rows: list[dict],
                 windows: list[tuple[str, int, int]], objects: list[str],
                 controllers: list[str], started: float) -> Path:
    """Figures from the bag, ``report.md`` and ``outcomes.json`` in ``output``; the report.

    ``windows``: ``(label, first, last receive time [ns])`` of each grasp in the ``bag``;
    ``model``: the force model perception used.
    """
    from forte_bringup.report import outcome_table, plot_grasp, traces_from_bag

    say(f'bag closed: {bag}; reading it back for the report')
    traces = traces_from_bag(bag, windows)
    figures = []
    for trace, row in zip(traces, [r for r in rows if 'lift_height' in r]):
        trace.outcome = row
        name = trace.label.replace(' / ', '_') + '.png'
        figures.append(plot_grasp(trace, output / name))
    report = output / 'report.md'
    lines = ['# FORTE demo report', '',
             f'Simulated scene with the full ROS 2 graph, {len(rows)} grasps '
             f'({", ".join(objects)} x {", ".join(controllers)}), '
             f'{time.monotonic() - started:.0f} s in total.', '',
             '## Outcomes', '', outcome_table(rows), '',
             '"outcome" is what the controller concluded from its sensors; "object (truth)" is '
             'the simulator\'s ground truth a few seconds after the grasp.', '',
             *(f'- {r["object"]} / {r["controller"]}: {r.get("message", "")}' for r in rows),
             '',
             '## Figures', '']
    for figure in figures:
        lines += [f'### {figure.stem}', '', f'![{figure.stem}]({figure.name})', '']
    lines += ['## Files', '',
              f'- report: `{report}`',
              f'- figures: {", ".join(f"`{f}`" for f in figures)}',
              f'- bag (rosbag2, MCAP): `{bag}`',
              f'- force model used by perception: `{model}`',
              f'- node logs: `{output / "logs"}`', '']
    report.write_text('\n'.join(lines))
    (output / 'outcomes.json').write_text(json.dumps(rows, indent=1, default=float))
    return report


def run(objects: list[str], controllers: list[str], output: Path, settle: float,
        timeout: float, real_time_factor: float) -> int:
    """The whole demo; returns a process exit code."""
    from forte_bringup.bringup import Bringup, BringupError
    from forte_bringup.report import outcome_table

    started = time.monotonic()
    if output.exists():
        shutil.rmtree(output)
    output.mkdir(parents=True)
    model = prepare_force_model(output)
    bag = output / 'bag'
    client = DemoClient(bag)
    rows: list[dict] = []
    windows: list[tuple[str, int, int]] = []
    say('starting sim_node, perception_node, grasp_controller_node at real-time factor '
        f'{real_time_factor:g}')
    # no live views: the demo draws its figures from the bag (the marker node would take
    # about a tenth of a core from the graph it measures)
    bringup = Bringup('sim', {'object': objects[0], 'force_model': str(model),
                              'visualization': 'false'},
                      extra_parameters={'sim': {'real_time_factor': real_time_factor}},
                      log_dir=output / 'logs', echo=None)
    try:
        bringup.start(timeout=60.0)
        grasp_all(bringup, client, objects, controllers, settle, timeout, started, rows,
                  windows)
    except BringupError as error:
        say(f'the graph did not start: {error}')
        rows.append({'object': '-', 'controller': '-', 'outcome': f'demo error: {error}'})
    finally:
        bringup.stop()
        client.close()
    report = write_report(output, bag, model, rows, windows, objects, controllers, started)
    print('\n' + outcome_table(rows) + '\n', flush=True)
    say(f'report: {report}')
    say(f'figures: {output}/*.png; bag: {bag}; done in {time.monotonic() - started:.0f} s')
    failed = [r for r in rows if str(r.get('outcome', '')).startswith('demo error')]
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    """Entry point (``python -m forte_bringup.demo``, ``forte_demo``)."""
    parser = argparse.ArgumentParser(prog='forte_demo', description=__doc__.split('\n')[0])
    parser.add_argument('--objects', nargs='+', default=list(DEFAULT_OBJECTS))
    parser.add_argument('--controllers', nargs='+', default=list(DEFAULT_CONTROLLERS),
                        choices=DEFAULT_CONTROLLERS)
    parser.add_argument('--output', type=Path, default=Path('out/demo'))
    parser.add_argument('--settle', type=float, default=1.5,
                        help='recording time after each result [s]')
    parser.add_argument('--timeout', type=float, default=60.0, help='grasp timeout [s]')
    parser.add_argument('--real-time-factor', type=float, default=1.0,
                        help='simulated seconds per wall second (the graph runs on /clock)')
    args = parser.parse_args(argv)

    from forte_ros.isolation import isolate_ros_network

    domain = isolate_ros_network()
    say(f'ROS_DOMAIN_ID={domain}, discovery on localhost only')
    return run(args.objects, args.controllers, args.output, args.settle, args.timeout,
               args.real_time_factor)


if __name__ == '__main__':
    sys.exit(main())
