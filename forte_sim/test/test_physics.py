"""Physical behaviour of the simulated scenes (known situations, stated tolerances)."""
import math

import numpy as np
import pytest
from scipy.signal import medfilt, welch

from forte_ros.contract import QUANTUM
from forte_sim import (
    INDENTORS,
    OBJECT_BROKEN,
    OBJECT_CRUSHED,
    OBJECT_DROPPED,
    OBJECT_HELD,
    OBJECT_RESTING,
    SLIP_STICK_SLIP,
    GripperModel,
    make_scene,
)
from forte_sim.scene import TICK_SAMPLES
from forte_sim.testing import (
    close_to_force,
    hold,
    median_filtered,
    slip_characterization_trial,
)

FS = 2000


def _tared(frames, baseline):
    return frames - baseline


@pytest.mark.parametrize('indentor', ['flat_wide', 'sphere'])
def test_force_rises_monotonically_with_closure(indentor):
    scene = make_scene('calibration', indentor=indentor, seed=1)
    quiet, _ = hold(scene, 0.5, scene.initial_angle)
    baseline = quiet.mean(axis=0)
    forces, distal = [], []
    for theta in np.linspace(scene.theta_zero_force, 0.0, 12):
        frames, truth = hold(scene, 0.4, float(theta))
        forces.append(truth.load_cell_force[-200:].mean())
        distal.append(_tared(frames[-200:], baseline)[:, [0, 3]].mean())
    forces = np.array(forces)
    assert forces[0] < 0.1                      # just touching
    assert np.all(np.diff(forces) > 0.0)        # strictly rising with closure
    assert 5.0 < forces[-1] < 12.0              # rig range: 0-8 N and a bit
    assert np.all(np.diff(distal[1:]) > 0.0)    # the sensor follows


def test_force_relaxes_at_constant_closure_while_the_sensor_holds():
    scene = make_scene('calibration', indentor='cylinder_large', seed=2)
    quiet, _ = hold(scene, 1.0, scene.initial_angle)
    baseline = quiet.mean(axis=0)
    _, truth = hold(scene, 1.0, 0.1)           # close (ramp ~0.5 s) and settle
    early = truth.finger_force[-100:].mean()
    frames, truth = hold(scene, 15.0, 0.1)
    late = truth.finger_force[-100:].mean()
    # stress relaxation of the elastomer: 5-25 % within 15 s, never a rise
    assert 0.75 * early < late < 0.95 * early
    assert np.all(np.diff(truth.finger_force[::200, 0]) <= 1e-9)
    # the channels measure the deformation, which does not relax: < 5 % change
    tared = _tared(frames, baseline)
    assert abs(tared[-2000:, 0].mean() / tared[:2000, 0].mean() - 1.0) < 0.05


@pytest.mark.parametrize('indentor', sorted(INDENTORS))
def test_distal_channels_respond_most(indentor):
    scene = make_scene('calibration', indentor=indentor, seed=3)
    quiet, _ = hold(scene, 0.5, scene.initial_angle)
    frames, _ = hold(scene, 2.0, 0.3 * scene.theta_zero_force)
    response = (frames[-1000:] - quiet.mean(axis=0)).mean(axis=0)
    for distal, middle, root in ((0, 1, 2), (3, 4, 5)):
        assert response[distal] > response[middle] > 0.0
        assert response[distal] > abs(response[root])


def _band_max_db(x):
    """Max over 10-50 Hz of the Welch PSD (one 400-sample Hann segment) [dB]."""
    frequency, power = welch(x, fs=FS, window='hann', nperseg=400, noverlap=0,
                             detrend='constant')
    band = (frequency >= 10) & (frequency <= 50)
    return 10 * np.log10(power[band].max() + 1e-12)


def test_stick_slip_raises_10_to_50_hz_power_at_labelled_onsets():
    _, raw, truth, offset = slip_characterization_trial('apple', seed=0)
    onsets = truth.slip_onset_indices[truth.slip_onset_types == SLIP_STICK_SLIP] + offset
    assert len(onsets) >= 2
    filtered = median_filtered(raw, raw[:2000])
    rises = []
    for onset in onsets:
        if onset < 400 or onset + 400 > len(raw):
            continue
        before = max(_band_max_db(filtered[onset - 400:onset, c]) for c in range(6))
        after = max(_band_max_db(filtered[onset:onset + 400, c]) for c in range(6))
        rises.append(after - before)
    assert len(rises) >= 2
    assert np.median(rises) > 6.0      # dB: a clear power rise at the labelled onsets
    # while the grip is still (before the lift) the same measure shows no rise
    quiet = [max(_band_max_db(filtered[t:t + 400, c]) for c in range(6))
             - max(_band_max_db(filtered[t - 400:t, c]) for c in range(6))
             for t in range(offset - 1600, offset - 400, 200)]
    assert np.max(np.abs(quiet)) < 3.0


def test_too_little_force_fails_to_hold_a_heavy_object_enough_holds_it():
    weak = make_scene('grasp', object_name='soda_can', seed=5)
    hold(weak, 0.5, weak.initial_angle)
    theta = close_to_force(weak, 0.25)                     # the paper's initial force
    _, truth = hold(weak, 6.0, theta, 0.005)
    assert truth.slip_onsets >= 1
    assert OBJECT_HELD not in truth.object_state
    assert truth.object_height.max() < 0.002
    strong = make_scene('grasp', object_name='soda_can', seed=5)
    hold(strong, 0.5, strong.initial_angle)
    hold(strong, 1.5, 0.0)                                 # On-Off: full close
    _, truth = hold(strong, 6.0, 0.0, 0.005)
    assert truth.object_state[-1] == OBJECT_HELD
    assert truth.object_height[-1] > 0.02


def test_loosening_the_grip_drops_a_lifted_object():
    scene = make_scene('grasp', object_name='tomato_soup_can', seed=6)
    hold(scene, 0.5, scene.initial_angle)
    hold(scene, 1.5, 0.15)
    _, truth = hold(scene, 4.0, 0.15, 0.005)
    assert truth.object_state[-1] == OBJECT_HELD
    height = truth.object_height[-1]
    _, truth = hold(scene, 3.0, scene.theta_zero_force - 0.003, 0.0)
    assert truth.object_state[-1] == OBJECT_DROPPED
    assert truth.object_height[-1] == 0.0 < height


@pytest.mark.parametrize(('name', 'state'), [('raspberry', OBJECT_CRUSHED),
                                             ('blueberry', OBJECT_CRUSHED),
                                             ('potato_chip', OBJECT_BROKEN)])
def test_full_close_destroys_fragile_objects(name, state):
    scene = make_scene('grasp', object_name=name, seed=7)
    hold(scene, 0.3, scene.initial_angle)
    _, truth = hold(scene, 2.5, 0.0)
    assert truth.object_state[-1] == state


def test_gentle_grip_lifts_fragile_objects_and_full_close_spares_the_raw_egg():
    for name in ('raspberry', 'potato_chip'):
        scene = make_scene('grasp', object_name=name, seed=8)
        hold(scene, 0.3, scene.initial_angle)
        theta = close_to_force(scene, 0.25)
        _, truth = hold(scene, 4.0, theta, 0.005)
        assert truth.object_state[-1] == OBJECT_HELD, name
        assert truth.finger_force[-1].max() < 0.6
    egg = make_scene('grasp', object_name='raw_egg', seed=8)
    hold(egg, 0.3, egg.initial_angle)
    _, truth = hold(egg, 2.5, 0.0)
    assert truth.object_state[-1] == OBJECT_RESTING
    assert truth.finger_force[-1].min() > 3.0


def test_servo_follows_profile_velocity_and_stalls_at_its_current_limit():
    scene = make_scene('grasp', object_name='soda_can', seed=9)
    start = scene.joint_position
    _, truth = scene.step(200, 0.0, 0.0, profile_velocity=0.4)   # 0.1 s
    assert truth.joint_position[-1] == pytest.approx(start - 0.04, abs=0.4 * TICK_SAMPLES / FS)
    model = GripperModel()
    current = 0.15
    _, truth = scene.step(6000, 0.0, 0.0, max_current=current)
    limit = (current - model.friction_current) * model.torque_constant / model.lever_arm
    assert scene.joint_position > 0.1                  # stalled on the can, not closed
    assert truth.finger_force[-1].max() == pytest.approx(limit, rel=0.05)
    assert max(scene.joint_effort) <= current + 1e-9


def test_warm_object_heats_the_inner_channels_slowly():
    hot = make_scene('grasp', object_name='apple', seed=11)
    assert abs(hot._draws.temperature) > 0.1
    cold = make_scene('grasp', object_name='apple', seed=11,
                      model=GripperModel(temperature_gain=0.0))
    hot.step(1000, 0.5, 0.0)
    cold.step(1000, 0.5, 0.0)
    first_hot, _ = hot.step(2000, 0.5, 0.0)
    first_cold, _ = cold.step(2000, 0.5, 0.0)
    later_hot, _ = hot.step(20000, 0.5, 0.0)
    later_cold, _ = cold.step(20000, 0.5, 0.0)
    early = (first_hot - first_cold)[:, 0].mean()
    late = (later_hot - later_cold)[-2000:, 0].mean()
    sign = math.copysign(1.0, hot._draws.temperature)
    assert sign * late > sign * early + 2 * QUANTUM    # grows over ~10 s
    assert sign * late > 0.0


def test_sensor_is_quantised_noisy_untared_with_occasional_impulses():
    scene = make_scene('empty', seed=12)
    frames, truth = scene.step(60 * FS, scene.initial_angle, 0.0)
    assert np.all(np.isnan(truth.load_cell_force))
    codes = frames / QUANTUM
    np.testing.assert_array_equal(codes, np.rint(codes))
    offsets = frames.mean(axis=0)
    assert np.all(np.abs(offsets) < 0.05) and np.any(np.abs(offsets) > 2 * QUANTUM)
    detrended = frames - medfilt(frames, (11, 1))
    assert 0.5 * QUANTUM < detrended[:, 0].std() < 3 * QUANTUM
    impulses = np.abs(detrended) > 0.015
    assert 3 <= impulses.sum() <= 200                  # ~0.2 per second per channel
    filtered = medfilt(frames, (11, 1))
    assert np.abs(filtered - medfilt(filtered, (11, 1))).max() < 0.015


@pytest.mark.parametrize(('name', 'paper_grasp', 'paper_zero'), [('apple', 0.527, 0.552),
                                                                 ('jam_jar', 0.460, 0.476)])
def test_slip_characterization_angles_match_the_paper(name, paper_grasp, paper_zero):
    scene = make_scene('slip_characterization', object_name=name, seed=0)
    assert scene.theta_zero_force == pytest.approx(paper_zero, abs=0.002)
    assert scene.stable_grasp_angle() == pytest.approx(paper_grasp, abs=0.008)
    assert scene.stable_grasp_angle() <= scene.slip_test_angle < scene.theta_zero_force
    with pytest.raises(ValueError, match='slip_characterization'):
        make_scene('slip_characterization', object_name='soda_can')


def test_putting_a_held_object_back_down_leaves_it_resting():
    scene = make_scene('grasp', object_name='tomato_soup_can', seed=2)
    hold(scene, 0.5, scene.initial_angle)
    hold(scene, 1.5, 0.2)
    _, truth = hold(scene, 4.0, 0.2, 0.005)
    assert truth.object_state[-1] == OBJECT_HELD
    _, truth = hold(scene, 5.0, 0.2, -0.005)
    assert truth.lift_height[-1] == 0.0 and truth.object_height[-1] == 0.0
    assert truth.object_state[-1] == OBJECT_RESTING
