"""The force calibration through ROS: ``forte_calibrate_force`` driving ``sim_node`` (two real
processes, real DDS on loopback): the quick protocol gives a model as good as the offline rig's
and it holds the raspberry; an interrupted session resumes without losing or repeating a
trial; a stale sensor, missing load-cell data and a load-cell topic of another type are
refused with one clear line.

Run time (2-core machine, sim at 6x real time): the quick session (6 x 8 trials) ~96 s, its
checks ~30 s; the interruption test ~20-35 s; the refusals ~45 s. The full protocol (6 x 40,
12 s holds: 18 min at 4x) is the documented command of
forte_commissioning.ros.force_calibration_node and calibrate_force.launch.py.
"""
from __future__ import annotations

import json
import signal
import time
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from forte_bringup.bringup import Bringup
from forte_bringup.testing import watching
from forte_driver.replay.bags import BagReadReport, read_bag
from forte_evaluation.closed_loop import run_trial
from forte_perception.force_training import (
    load_calibration,
    make_rows,
    train_model,
    training_sensor,
)
from forte_ros.testing import NodeProcess, ros_args, wait_until
from forte_sim.dataset import QUICK_PROTOCOL, generate_calibration_dataset

#: Simulated seconds per wall second of the calibration runs (the procedure keeps up).
FACTOR = 6.0
#: No frame for this long (wall) is a stale sensor: generous, other jobs share the machine.
STALE = 2.0


def rmse(model, rows) -> float:
    """Root-mean-square error of ``model`` on ``rows`` [N]."""
    return float(np.sqrt(np.mean((model.predict(rows.features) - rows.force) ** 2)))


def sim_process(**parameters) -> NodeProcess:
    """sim_node as the calibration launch starts it (reliable frames, batches of 100), with
    a 40 Hz load cell (every 50th sample): 480 messages per wall second at 6x real time,
    which the procedure keeps up with on a loaded 2-core machine."""
    settings = dict(scene='calibration', object='flat_wide', reliable=True, batch_size=100,
                    load_cell_decimation=50, real_time_factor=FACTOR)
    settings.update(parameters)
    return NodeProcess(['sim_node', *ros_args(**settings), '-r', '__node:=sim'])


def procedure(**parameters) -> NodeProcess:
    """forte_calibrate_force (console script) with ``parameters``."""
    return NodeProcess(['forte_calibrate_force', *ros_args(**parameters)])


def finish(process: NodeProcess, timeout: float) -> int:
    """Exit code of a process that ends by itself."""
    deadline = time.monotonic() + timeout
    while process.process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    assert process.process.poll() is not None, f'still running:\n{process.output[-3000:]}'
    process.kill()  # joins the output pump
    return process.process.returncode


@pytest.mark.slow
def test_quick_calibration_through_ros_trains_a_model_that_holds_the_raspberry(tmp_path):
    session = tmp_path / 'session'
    started = time.monotonic()
    with sim_process() as sim, procedure(session_dir=str(session), simulation=True, quick=True,
                                         frames_reliable=True,
                                         stale_timeout=STALE) as calibration:
        code = finish(calibration, 600)
        assert code == 0, calibration.output[-4000:]
        assert not sim.failures()
    elapsed = time.monotonic() - started
    output = calibration.output
    assert 'trial 48/48 recorded' in output and '48/48 trials in' in output
    dataset = load_calibration(session / 'calibration.npz')
    assert np.unique(dataset['trial']).tolist() == list(range(48))
    with np.load(session / 'calibration.npz', allow_pickle=False) as data:
        identity = json.loads(str(data['sensor_identity']))
    assert identity['source'] == 'sim' and identity['sample_rate'] == 2000.0
    # the bag of the session: frames, load cell, joints, commands, readable by another reader
    report = BagReadReport()
    counts = Counter(message.topic for message in read_bag(session / 'bags' / 'run_000',
                                                           report=report))
    assert {'/tactile/frames', '/load_cell/wrench', '/joint_states', '/gripper/command',
            '/tactile/sensor_info'} <= set(counts), (counts, report)
    assert counts['/tactile/frames'] > 48 * 170      # 48 trials of 170 batches of 100
    # as good as the offline rig's model of the same draws: both scored on other draws (seed
    # 1), RMSE within 10 % (a 50 ms late load cell costs +28 %, a 10 % scale error +126 %;
    # the CV RMSE of each dataset is no such measure: the hold of a trial whose opening
    # arrived late is longer, and its extra rows weigh on the two strongest trials' error)
    ros_rows = make_rows(dataset)
    offline = train_model(make_rows(generate_calibration_dataset(QUICK_PROTOCOL)),
                          C=10.0, epsilon=0.02)
    model = train_model(ros_rows, C=10.0, epsilon=0.02,
                        metadata={'sensor': training_sensor(dataset)})
    other_draws = make_rows(generate_calibration_dataset(replace(QUICK_PROTOCOL, seed=1)))
    reference, measured = (rmse(candidate, other_draws) for candidate in (offline, model))
    print(f'quick session through ROS: {elapsed:.0f} s; RMSE on other draws {measured:.4f} N '
          f'(ROS) vs {reference:.4f} N (forte_sim_dataset)')
    assert abs(measured - reference) <= 0.10 * reference
    # the model it produced lifts and holds the raspberry (closed loop, ground truth)
    for seed in (0, 1):
        result = run_trial('raspberry', 'FORTE', seed=seed, model=model)
        assert result.outcome == 'LIFTED' and result.object_state == 'HELD', result
        assert result.success, result
    # ... and in the sim graph, loaded by the perception node (same sensor: the simulator)
    model.save(tmp_path / 'calibrated_model.npz')
    raspberry_in_the_sim_graph(tmp_path / 'calibrated_model.npz', tmp_path / 'logs')


def raspberry_in_the_sim_graph(model_path, log_dir) -> None:
    """A FORTE grasp of the raspberry in the sim graph (forte_bringup, every node a process)
    with the force model at ``model_path``: LIFTED and, in the ground truth, HELD."""
    from forte_msgs.action import Grasp
    from forte_msgs.msg import SimGroundTruth

    bringup = Bringup('sim', {'object': 'raspberry', 'force_model': str(model_path),
                              'real_time_factor': '1.0'}, log_dir=log_dir, echo=None)
    with watching() as watcher:
        bringup.start(timeout=60.0)
        try:
            assert wait_until(lambda: watcher.counts['tared'] > 20, 30.0), watcher.counts
            assert wait_until(lambda: watcher.counts['joint_states'] > 10, 30.0)
            assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, 30.0)
            assert wait_until(lambda: watcher.status_values('perception: pipeline'), 10.0)
            values = watcher.status_values('perception: pipeline')
            assert values['force model'] == 'loaded', values
            assert values['model trained on device'] == values['sensor device'] == 'simulator'
            goal = Grasp.Goal(controller=Grasp.Goal.FORTE, lift_distance=0.01, timeout=60.0)
            accepted, result, _ = watcher.grasp_once_inputs_flow(goal, timeout=120.0)
            assert accepted and result is not None, watcher.last_grasp_state
            truth = watcher.truth
            assert (result.outcome, truth.object_state) == (
                Grasp.Result.LIFTED, SimGroundTruth.OBJECT_HELD), (result.message, truth)
            assert truth.object_height > 0.005, truth
        finally:
            bringup.stop()


def test_an_interrupted_session_resumes_without_losing_or_repeating_a_trial(tmp_path):
    session = tmp_path / 'session'
    settings = dict(session_dir=str(session), simulation=True, trials_per_indentor=2,
                    quiet_seconds=0.5, hold_seconds=1.0, release_seconds=0.5,
                    indentors=['flat_wide', 'sphere'], frames_reliable=True,
                    stale_timeout=STALE)
    with sim_process() as sim:
        with procedure(**settings) as first:
            assert first.wait_for_output('trial 2/4 recorded', 120), first.output[-3000:]
            code, _ = first.stop(signal.SIGINT, timeout=20)
            assert code == 0, first.output[-3000:]
        assert 'interrupted: ' in first.output and 'to resume' in first.output, first.output
        kept = sorted(path.name for path in (session / 'trials').glob('trial_*.npz'))
        assert len(kept) >= 2
        with procedure(**settings) as second:
            assert finish(second, 180) == 0, second.output[-3000:]
        assert not sim.failures()
    assert '(resumed)' in second.output
    assert f'{len(kept)}/4 trials done' in second.output
    dataset = load_calibration(session / 'calibration.npz')
    starts = np.flatnonzero(np.diff(dataset['trial'], prepend=-1))
    assert dataset['trial'][starts].tolist() == [0, 1, 2, 3]       # each trial once
    assert sorted(path.name for path in (session / 'bags').iterdir()) == ['run_000', 'run_001']
    for name in kept:                                               # kept trials untouched
        assert (session / 'trials' / name).stat().st_size > 0


def test_a_stale_sensor_no_load_cell_and_a_bad_load_cell_topic_are_refused(tmp_path):
    # robot mode; a second per check is enough to see nothing, discovery needs more
    robot = dict(quick=True, ready_timeout=4.0, indentors=['flat_wide'])
    with procedure(session_dir=str(tmp_path / 'a'), **{**robot, 'ready_timeout': 1.0}) \
            as refused:
        assert finish(refused, 60) == 2
    assert 'refused: stale sensor: no tactile frame on /tactile/frames' in refused.output
    # a sensor and a gripper, but the grasp scene has no load cell
    with sim_process(scene='grasp', object='apple', real_time_factor=1.0):
        with procedure(session_dir=str(tmp_path / 'b'), **robot) as refused:
            assert finish(refused, 60) == 2
        assert 'refused: no load-cell data: nothing publishes /load_cell/wrench' in \
            refused.output, refused.output
        with procedure(session_dir=str(tmp_path / 'c'), load_cell_topic='/sim/ground_truth',
                       **robot) as refused:
            assert finish(refused, 60) == 2
        assert 'refused: bad load-cell topic: /sim/ground_truth carries forte_msgs/msg/' \
            'SimGroundTruth, not geometry_msgs/msg/WrenchStamped' in refused.output, \
            refused.output
        with procedure(session_dir=str(tmp_path / 'd'), load_cell_topic='joint_states',
                       **robot) as refused:
            assert finish(refused, 60) == 2
        assert 'refused: bad load-cell topic: /joint_states carries sensor_msgs/msg/' \
            'JointState' in refused.output, refused.output
    for folder in ('a', 'b', 'c'):                   # nothing recorded, nothing lost
        assert not list((tmp_path / folder / 'trials').glob('*.npz'))
