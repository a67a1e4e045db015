"""Benchmark of the simulated FORTE scenes (forte_sim) on one core.

Times are CPU seconds of this process (one core), so other jobs on the machine do not
inflate them. Prints, each against a baseline measured in the same run:

1. x-realtime per scene (calibration rig, grasp with lift and stick-slip, slip
   characterisation at 1 mm/s, empty gripper), stepped in one call and in 20-sample chunks
   (the closed loop's step); baseline: real time (x-realtime = simulated s / wall s) and the
   same scene stepped one sample per call (a per-sample Python loop of the same model).
2. The 10 s grasp trial (20000 frames) in 20-sample chunks: wall time against the 0.2 s target.
3. Cost against trial length (1, 10, 60 s): wall time per simulated second (flat = linear).
4. Cost against the number of objects simulated side by side (1, 4, 16 scenes stepped in
   lockstep): wall time per scene-second (flat = linear, no interaction cost).
5. The calibration dataset (--quick protocol) generation time.
6. The ROS node's production path (step + build + publish, no subscriber) in x-realtime.
"""
from __future__ import annotations

import os
import time

# one core: keep numpy / BLAS single-threaded, as the evaluation workers are
for variable in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS'):
    os.environ.setdefault(variable, '1')

from forte_ros.contract import SAMPLE_RATE as FS  # noqa: E402
from forte_sim import make_scene  # noqa: E402
from forte_sim.dataset import QUICK_PROTOCOL, generate_calibration_dataset  # noqa: E402


def best_of(function, repeats: int = 3) -> float:
    """Smallest CPU time of ``repeats`` runs [s].

    CPU time of this process (``time.process_time``), not wall time: the benchmark measures
    the cost on one core, which wall time overstates when other jobs share the machine.
    """
    times = []
    for _ in range(repeats):
        start = time.process_time()
        function()
        times.append(time.process_time() - start)
    return min(times)


def scene_run(name: str, seconds: float, chunk: int | None, object_name: str | None = None):
    """A scripted trial of ``seconds`` simulated seconds: close, hold, lift."""
    def run() -> None:
        if name == 'calibration':
            scene = make_scene('calibration', indentor='sphere', seed=1)
            phases = [(0.1, scene.initial_angle, 0.0), (0.9, 0.1, 0.0)]
        elif name == 'empty':
            scene = make_scene('empty', seed=1)
            phases = [(1.0, 0.5, 0.0)]
        else:
            scene = make_scene(name, object_name=object_name, seed=1)
            velocity = 0.001 if name == 'slip_characterization' else 0.005
            theta = scene.theta_zero_force - 0.015
            phases = [(0.1, scene.initial_angle, 0.0), (0.1, theta, 0.0),
                      (0.8, theta, velocity)]
        for share, command, velocity in phases:
            left = int(round(share * seconds * FS))
            while left > 0:
                n = left if chunk is None else min(chunk, left)
                scene.step(n, command, velocity)
                left -= n
    return run


def section_scenes() -> None:
    print('1. x-realtime per scene, one core (10 s trials; baseline: real time = 1x)')
    print(f'   {"scene":34s} {"one call":>10s} {"20-chunks":>10s} {"1-sample":>10s} '
          f'{"chunk/1-sample":>15s}')
    cases = [('calibration', None), ('grasp', 'apple'), ('grasp', 'soda_can'),
             ('slip_characterization', 'jam_jar'), ('empty', None)]
    for name, object_name in cases:
        label = name + (f' ({object_name})' if object_name else '')
        whole = best_of(scene_run(name, 10.0, None, object_name))
        chunked = best_of(scene_run(name, 10.0, 20, object_name))
        single = best_of(scene_run(name, 0.5, 1, object_name), repeats=1) * 20
        print(f'   {label:34s} {10 / whole:9.0f}x {10 / chunked:9.0f}x {10 / single:9.1f}x '
              f'{single / chunked:14.1f}x')


def section_trial() -> None:
    wall = best_of(scene_run('grasp', 10.0, 20, 'soda_can'), repeats=5)
    print('2. 10 s grasp trial (20000 frames, soda can, 20-sample steps): '
          f'{wall * 1e3:.1f} ms (target < 200 ms: {"met" if wall < 0.2 else "MISSED"}; '
          f'{200 / (wall * 1e3):.1f}x under it)')


def section_length() -> None:
    print('3. cost against trial length (grasp, apple, one call)')
    baseline = None
    for seconds in (1.0, 10.0, 60.0):
        wall = best_of(scene_run('grasp', seconds, None, 'apple'))
        per_second = wall / seconds
        baseline = baseline or per_second
        print(f'   {seconds:5.0f} s: {wall * 1e3:8.1f} ms, {per_second * 1e3:6.2f} ms per '
              f'simulated s ({per_second / baseline:4.2f}x the 1 s cost)')


def section_objects() -> None:
    print('4. cost against the number of objects simulated side by side '
          '(grasp scenes in lockstep, 20-sample steps, 2 s each)')
    names = ['apple', 'soda_can', 'raspberry', 'mustard_bottle']
    baseline = None
    for count in (1, 4, 16):
        def run(count=count) -> None:
            scenes = [make_scene('grasp', object_name=names[i % 4], seed=i)
                      for i in range(count)]
            thetas = [scene.theta_zero_force - 0.015 for scene in scenes]
            for step in range(200):
                velocity = 0.005 if step >= 40 else 0.0
                for scene, theta in zip(scenes, thetas, strict=True):
                    scene.step(20, theta, velocity)
        wall = best_of(run)
        per_scene_second = wall / (count * 2.0)
        baseline = baseline or per_scene_second
        print(f'   {count:3d} scenes: {wall * 1e3:8.1f} ms, {per_scene_second * 1e3:6.2f} ms '
              f'per scene-second ({per_scene_second / baseline:4.2f}x the single scene)')


def section_dataset() -> None:
    start = time.process_time()
    dataset = generate_calibration_dataset(QUICK_PROTOCOL)
    wall = time.process_time() - start
    seconds = len(dataset['frames']) / FS
    print(f'5. calibration dataset --quick: {seconds:.0f} s of data (48 trials) in {wall:.2f} s '
          f'({seconds / wall:.0f}x realtime)')


def section_node() -> None:
    from forte_ros.isolation import isolate_ros_network

    isolate_ros_network()
    import rclpy
    from rclpy.parameter import Parameter

    from forte_sim.ros.sim_node import SimNode

    rclpy.init()
    try:
        node = SimNode(parameter_overrides=[Parameter('autostart', value=True)])
        node._stop_timer()      # drive the production path directly
        batches = 1000
        start = time.process_time()
        for _ in range(batches):
            node._step_batch(20)
        wall = time.process_time() - start
        simulated = batches * 20 / FS
        print(f'6. sim_node production (step + 3 messages + publish, no reader): '
              f'{simulated / wall:.1f}x realtime ({wall / batches * 1e3:.3f} ms per batch; '
              'baseline: real time = 1x)')
        node.destroy_node()
    finally:
        rclpy.try_shutdown()


def main() -> None:
    started = time.perf_counter()
    section_scenes()
    section_trial()
    section_length()
    section_objects()
    section_dataset()
    section_node()
    print(f'(bench_sim total {time.perf_counter() - started:.0f} s)')


if __name__ == '__main__':
    main()
