"""The scripted operator's presses and the simulated commissioning session."""
import numpy as np
import pytest

from forte_sim.channel_faults import parse_fault
from forte_sim.commissioning_session import SessionStep, simulate_session
from forte_sim.model import DEFAULT_MODEL, contact_stiffness_scale
from forte_sim.operator_press import (
    PRESS_LOCATIONS,
    OperatorPress,
    ScriptedOperator,
    press_deflection,
)


def test_the_deflection_solves_the_finger_spring():
    force = np.array([0.0, 1.0, 3.0, 6.0])
    for location in (0.1, 0.85):
        d = press_deflection(DEFAULT_MODEL, force, location)
        stiffness = 1.18 * contact_stiffness_scale(location)
        np.testing.assert_allclose(stiffness * (0.25 * d + 1e-4 * d ** 3), force, atol=1e-9)
    assert press_deflection(DEFAULT_MODEL, np.array([3.0]), 0.1)[0] > \
        press_deflection(DEFAULT_MODEL, np.array([3.0]), 0.85)[0]  # the tip is softer


def test_the_force_is_a_trapezoid():
    press = OperatorPress(0, 0.1, force=4.0, start=100, ramp=0.25, hold=1.0)
    assert press.stop == 100 + 3000
    force = press.force_at(np.array([99, 100, 350, 600, 2600, 2850, 3100, 3200]))
    np.testing.assert_allclose(force, [0, 0, 2.0, 4.0, 4.0, 2.0, 0, 0])


@pytest.mark.parametrize('finger', [0, 1])
def test_a_press_loads_its_finger_alone_in_the_order_of_the_physics(finger):
    operator = ScriptedOperator()
    operator.schedule(OperatorPress(finger, PRESS_LOCATIONS['tip'], 4.0, start=0))
    operator.schedule(OperatorPress(finger, PRESS_LOCATIONS['root'], 4.0, start=4000))
    signal = operator.signal(0, 8000)
    own = slice(3 * finger, 3 * finger + 3)
    other = slice(3 - 3 * finger, 6 - 3 * finger)
    tip, root = signal[1500, own], signal[5500, own]
    assert tip[0] > tip[1] > tip[2] > 0.0
    assert np.all(signal[:, other] == 0.0)
    assert root[2] / root.sum() > tip[2] / tip.sum() + 0.05  # the root pair's share grows
    assert root[0] / root.sum() < tip[0] / tip.sum() - 0.05
    assert 0.2 < tip[0] < 0.5  # a 4 N press on the distal pair (8 N ~ 0.5-0.6)
    assert np.all(signal[3500:4000] == 0.0)


def test_a_session_records_every_step_and_injects_its_fault():
    steps = [SessionStep('rest', 1.0), SessionStep('press', 1.5, finger=1, location=0.1),
             SessionStep('rest', 0.5), SessionStep('squeeze', 3.0), SessionStep('rest', 0.5)]
    healthy = simulate_session(steps, seed=2)
    assert healthy.spans == [(0, 2000), (2000, 5000), (5000, 6000), (6000, 12000),
                             (12000, 13000)]
    assert healthy.frames.shape == (13000, 6)
    rest = np.median(healthy.frames[:2000], axis=0)
    pressed = healthy.frames[3000:4000].mean(axis=0) - rest
    assert pressed[3] > pressed[4] > pressed[5] > 0.02 and np.all(np.abs(pressed[:3]) < 0.005)
    squeezed = healthy.frames[10000:12000].mean(axis=0) - rest
    assert np.all(squeezed > 0.03)  # the indentor loads both fingers
    faulty = simulate_session(steps, [parse_fault('reversed:right_distal')], seed=2)
    np.testing.assert_array_equal(np.delete(faulty.frames, 3, axis=1),
                                  np.delete(healthy.frames, 3, axis=1))
    assert faulty.frames[3000:4000, 3].mean() < rest[3] - 0.1
