"""The contact moves along the finger when the object and the finger slide on each other.

The fingers point down at the object. When the arm lifts them along an object the table
holds, or a carried object slips down between them, the contact patch moves toward the
fingertip by the slide distance, and the normal load's channel pattern follows it: the
distal channel takes a larger share. Without slide the pattern stays that of the grasp.

The pattern is read from the frames of a sensor with only the normal term (no shear,
ringing, temperature or noise) and a tangentially rigid contact, so that the fingers' slide
equals the relative motion of arm and object (no elastic stretch of the contact).
"""
from dataclasses import replace

import numpy as np
import pytest

from forte_sim import OBJECT_HELD, OBJECT_RESTING, make_scene
from forte_sim.model import (
    DEFAULT_MODEL,
    ChannelGainMap,
    channel_gains,
    slid_contact_location,
)
from forte_sim.synthesis import SignalSynthesis
from forte_sim.testing import close_to_force, hold

#: Only the normal load reaches the channels; the contact is rigid along the surface.
NORMAL_ONLY = replace(
    DEFAULT_MODEL, shear_gain=(0.0, 0.0, 0.0), vibration_gain=(0.0, 0.0, 0.0),
    temperature_gain=0.0, white_noise=0.0, low_frequency_noise=0.0,
    drift_per_sqrt_second=0.0, impulse_rate=0.0, tangential_stiffness=1.0e5,
    tangential_stiffening=0.0)
LIFT = 0.020            # arm travel [m]
LIFT_SPEED = 0.005      # [m/s], the paper's
#: Distal share of a finger's pattern read from 11-bit frames of about 0.1-0.2 full scale:
#: one quantum on each channel moves it by less than 0.003.
SHARE_TOLERANCE = 0.005


def _distal_share(tared: np.ndarray) -> np.ndarray:
    """Distal channel's share of each finger's three readings, shape (2,) [-]."""
    means = tared.mean(axis=0)
    return np.array([means[3 * f] / means[3 * f:3 * f + 3].sum() for f in (0, 1)])


def _expected_share(scene, slide: float) -> np.ndarray:
    """Distal share that channel_gains gives after each finger slid ``slide`` up [-]."""
    draws = scene._draws
    # up the object = toward the tip (u = 0) by the slide over the finger's sensing span
    location = min(max(draws.contact_location - slide / scene.model.finger_length, 0.0), 1.0)
    gains = [channel_gains(scene.model, location, draws.contact_spread, f) for f in (0, 1)]
    return np.array([g[0] / g.sum() for g in gains])


def _grip(object_name: str, seed: int, force: float, model=NORMAL_ONLY):
    """Scene, tare and servo angle of a grip of ``force`` per finger, settled 1 s [N]."""
    scene = make_scene('grasp', object_name=object_name, seed=seed, model=model)
    quiet, _ = hold(scene, 0.5, scene.initial_angle)
    theta = close_to_force(scene, force)
    settled, _ = hold(scene, 1.0, theta)
    return scene, quiet.mean(axis=0), theta, settled


def test_lifting_the_fingers_along_an_object_the_table_holds_moves_the_pattern_to_the_tip():
    # 0.6 kg bottle, 2.5 N per finger: friction (2 x 0.55 x 2.5 N) cannot lift its 5.9 N,
    # so the fingers slide 20 mm up its side and the contact 20 mm toward their tips
    scene, tare, theta, settled = _grip('mustard_bottle', 1, 2.5)
    start = _distal_share(settled[-400:] - tare)
    np.testing.assert_allclose(start, _expected_share(scene, 0.0), atol=SHARE_TOLERANCE)
    _, truth = hold(scene, LIFT / LIFT_SPEED, theta, LIFT_SPEED)
    frames, truth = hold(scene, 0.5, theta)
    assert truth.object_height.max() == 0.0 and truth.object_state[-1] == OBJECT_RESTING
    slide = truth.lift_height[-1] - truth.object_height[-1]
    assert slide == pytest.approx(LIFT, abs=1e-4)
    end = _distal_share(frames[-400:] - tare)
    expected = _expected_share(scene, slide)
    np.testing.assert_allclose(end, expected, atol=SHARE_TOLERANCE)
    assert np.all(end - start > 0.07)       # the rise is well beyond the tolerance


def test_a_carried_object_keeps_its_pattern_until_it_slips_down_and_then_moves_it():
    scene, tare, theta, settled = _grip('tomato_soup_can', 5, 6.0)
    start = _distal_share(settled[-400:] - tare)
    hold(scene, LIFT / LIFT_SPEED, theta, LIFT_SPEED)
    frames, truth = hold(scene, 0.5, theta)
    assert truth.object_state[-1] == OBJECT_HELD
    carried = truth.object_height[-1]
    # carried, not sliding: the fingers' slide is the lift the object did not follow
    assert truth.lift_height[-1] - carried < 2e-4
    np.testing.assert_allclose(_distal_share(frames[-400:] - tare), start,
                               atol=SHARE_TOLERANCE)
    # loosen: the can slides down between the fingers (gross slip) onto the table
    frames, truth = hold(scene, 2.0, theta + 0.6 * (scene.theta_zero_force - theta))
    assert truth.object_height[-1] == 0.0
    slide = truth.lift_height[-1] - truth.object_height[-1]
    assert slide == pytest.approx(LIFT, abs=2e-4)
    end = _distal_share(frames[-400:] - tare)
    np.testing.assert_allclose(end, _expected_share(scene, slide), atol=SHARE_TOLERANCE)
    assert np.all(end - start > 0.07)


class _FixedLocationSynthesis(SignalSynthesis):
    """The synthesis with the normal gains of channel_gains at the grasp location always."""

    def __init__(self, scene) -> None:
        draws = scene._draws
        super().__init__(scene.model, scene.seed, draws, scene.object.mass, True, False)
        self._fixed = np.concatenate([
            channel_gains(scene.model, draws.contact_location, draws.contact_spread, f)
            for f in (0, 1)])

    def _normal_gains(self, slide: np.ndarray) -> np.ndarray:
        return self._fixed


def _lift_trial(object_name: str, seed: int, force: float, fixed_location: bool):
    """Raw frames of a grip of ``force`` and a 20 mm lift (full model, noise and all)."""
    scene = make_scene('grasp', object_name=object_name, seed=seed)
    if fixed_location:
        scene._synthesis = _FixedLocationSynthesis(scene)
    frames = [hold(scene, 0.5, scene.initial_angle)[0]]
    theta = close_to_force(scene, force)
    frames.append(hold(scene, 1.0, theta)[0])
    frames.append(hold(scene, LIFT / LIFT_SPEED, theta, LIFT_SPEED)[0])
    return np.concatenate(frames), scene._contact.slide


def test_without_slide_the_frames_are_those_of_the_fixed_contact_location_bit_for_bit():
    # a firm grip carries the can without any slide
    frames, slide = _lift_trial('soda_can', 0, 8.0, fixed_location=False)
    assert slide == [0.0, 0.0]
    reference, _ = _lift_trial('soda_can', 0, 8.0, fixed_location=True)
    np.testing.assert_array_equal(frames, reference)


def test_with_slide_only_the_frames_after_the_slide_began_differ():
    frames, slide = _lift_trial('mustard_bottle', 1, 2.5, fixed_location=False)
    assert min(slide) > 0.015
    reference, _ = _lift_trial('mustard_bottle', 1, 2.5, fixed_location=True)
    differs = np.flatnonzero((frames != reference).any(axis=1))
    lift_start = len(frames) - int(LIFT / LIFT_SPEED * 2000)
    assert len(differs) > 0 and differs[0] >= lift_start


def test_slid_location_moves_toward_the_tip_by_the_slide_and_stays_on_the_finger():
    length = DEFAULT_MODEL.finger_length
    slides = np.array([0.0, 0.25 * length, -0.25 * length, 2.0 * length, -2.0 * length])
    np.testing.assert_allclose(slid_contact_location(DEFAULT_MODEL, 0.4, slides),
                               [0.4, 0.15, 0.65, 0.0, 1.0], atol=1e-15)


def test_gain_map_is_channel_gains_at_every_location_and_chunk_independent():
    locations = np.random.default_rng(3).uniform(0.0, 1.0, (500, 2))
    gains = ChannelGainMap(DEFAULT_MODEL, 0.15)(locations)
    expected = np.array([np.concatenate([channel_gains(DEFAULT_MODEL, u, 0.15, f)
                                         for f, u in enumerate(row)]) for row in locations])
    np.testing.assert_allclose(gains, expected, rtol=1e-13)
    parts = np.concatenate([ChannelGainMap(DEFAULT_MODEL, 0.15)(locations[i:i + 7])
                            for i in range(0, 500, 7)])
    np.testing.assert_array_equal(parts, gains)
