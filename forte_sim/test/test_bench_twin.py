"""The bench twin: one scene behind the emulated sensor board and the simulated XM430 pair.

Judged from outside, as the hardware graph sees it: the sensor board's scans are read with
pyserial and the protocol decoder, the servos are driven with the real gripper core over
dynamixel-sdk, and the physics is checked against a second scene of the same seed.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pytest

from forte_driver.dynamixel.gripper import DynamixelError, Gripper, GripperConfig
from forte_driver.emulators.serial_host import Host
from forte_driver.serial.protocol import Command
from forte_ros.contract import COUNTS_PER_FULL_SCALE, SAMPLE_PERIOD
from forte_sim import make_scene
from forte_sim.bench_twin import BenchTwin


@pytest.fixture
def twin(tmp_path):
    truths = []
    with BenchTwin(str(tmp_path / 'forte_sensor'), make_scene('grasp', 'soda_can', seed=3),
                   on_truth=truths.append) as bench:
        bench.truths = truths
        yield bench


def _retry(action, attempts: int = 3):
    """A gripper transaction, retried if the loaded test machine missed the SDK timeout."""
    for attempt in range(attempts):
        try:
            return action()
        except DynamixelError:
            if attempt == attempts - 1:
                raise


def test_sensor_scans_are_the_scenes_samples(twin):
    """With the servos untouched (torque off) the fingers stay open: the scene of the same
    seed, held at its start angle, must give exactly the scans the board sends."""
    reference = make_scene('grasp', 'soda_can', seed=3)
    host = Host(twin.sensor.link_path)
    try:
        assert host.command(Command.START).status == 0
        host.pump(0.6)
    finally:
        host.close()
    assert len(host.samples) > 600  # 0.6 s at 2 kHz, less the start-up
    indices = np.array([twin.sample_index_at(sample.time_us) for sample in host.samples])
    assert np.all(np.diff(indices) == 1) and indices[0] >= 0
    frames, _ = reference.step(int(indices[-1]) + 1, reference.initial_angle)
    expected = np.clip(np.rint(frames[indices] * COUNTS_PER_FULL_SCALE),
                       -COUNTS_PER_FULL_SCALE, COUNTS_PER_FULL_SCALE)
    np.testing.assert_array_equal(np.array([s.values for s in host.samples]), expected)
    assert np.ptp(expected, axis=0).max() >= 1  # a live signal (noise), not a constant


def test_servos_move_the_scenes_fingers_and_report_them(twin):
    """Commanded through the real gripper core, the fingers close on the soda can: the
    scene's angle follows the command (the fin-ray fingers wrap the can), both servos report
    the scene's angle, and the can is squeezed (true finger forces and servo currents)."""
    gripper = Gripper(GripperConfig(port=twin.servo_device))
    gripper.open()
    try:
        _retry(gripper.configure)
        _retry(lambda: gripper.set_torque(True))
        start = twin.scene.joint_position
        target = max(start - 0.4, 0.0)
        _retry(lambda: gripper.command(target, 1.0, 1.0))
        time.sleep(1.5)
        state = _retry(gripper.read_state)
    finally:
        gripper.close()
    theta = twin.scene.joint_position
    assert theta == pytest.approx(target, abs=0.01)
    assert target < twin.scene.theta_zero_force < start  # closed past the first touch
    assert (twin.truths[-1].finger_force[-1] > 0.5).all()  # [N], both fingers
    for finger in state.values():
        assert finger.theta == pytest.approx(theta, abs=2 * 2 * math.pi / 4096 + 0.02)
        assert finger.effort < 0.0  # squeezing: current along -theta (docs/gripper_driver.md)
    assert twin.scene.joint_effort[0] > 0.0


def test_the_arm_velocity_lifts_the_scene_and_truth_is_reported(tmp_path):
    truths = []
    with BenchTwin(str(tmp_path / 'sensor'), make_scene('empty', seed=1),
                   on_truth=truths.append) as bench:
        bench.set_arm_velocity(0.01)
        time.sleep(0.5)
        bench.set_arm_velocity(0.0)
        with pytest.raises(ValueError):
            bench.set_arm_velocity(math.nan)
        time.sleep(0.1)
    height = truths[-1].lift_height[-1]
    elapsed = (truths[-1].first_index + len(truths[-1].lift_height)) * SAMPLE_PERIOD
    assert 0.0 < height <= 0.01 * elapsed + 1e-9
    assert sum(len(truth.lift_height) for truth in truths) == pytest.approx(
        elapsed / SAMPLE_PERIOD)


def test_a_scene_thread_that_fails_says_why(tmp_path):
    """An exception in the scene thread (here the truth consumer) is kept in ``failure``
    for the node to report, not lost with the thread."""
    def consumer_not_ready(truth):
        raise AttributeError('the consumer is not ready')

    with BenchTwin(str(tmp_path / 'sensor'), make_scene('empty', seed=1),
                   on_truth=consumer_not_ready) as bench:
        assert bench.failure == ''
        deadline = time.monotonic() + 5.0
        while not bench.failure and time.monotonic() < deadline:
            time.sleep(0.01)
        assert bench.failure == 'AttributeError: the consumer is not ready'
