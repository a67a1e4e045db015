"""What each of the demo's nine grasps must end in, from the physics of its scene.

Shared by the demo test (the full ROS graph over DDS) and the closed-loop test (``run_trial``
on the same scenes): the two must produce the same pattern. Scenes: ``sim.yaml`` (seed 0,
trial 0, the same placement for every controller); the closed loop steps perception every
20 samples, as the graph's 20-sample TactileFrames batches do.

Two grasps have no single physical outcome: FORTE on the soda can and on the glass bottle.
Their grip is just enough by design (+0.88 deg per slip until the slip stops), so whether
the weight transfers before the lift ends is a race between stick-slip episodes and
tightenings. In the graph a tightening reaches the simulated servo some tens of ms
(simulated time) after the slip flag, varying with the machine's load; in the closed loop
the soda can flips between carried and not carried when only the perception batch size
changes (10, 20, 40 samples: on the table, hanging 1.5 mm above it after sliding 28 mm down
the fingers, on the table). For those two the tests demand the truth instead
(:func:`truthful`).
"""
from __future__ import annotations

from forte_bringup.metrics import contradicts_carried, truth_label

#: (object, controller) -> (outcome, ground-truth object state after the grasp), or
#: 'TRUTHFUL' where the physics goes either way (module docstring).
EXPECTED = {
    # 4 g, fragile: 0.25 N lifts it intact; ON_OFF's full close crushes it, in the grasp
    ('raspberry', 'FORTE'): ('LIFTED', 'HELD'),
    ('raspberry', 'NO_SLIP'): ('LIFTED', 'HELD'),
    ('raspberry', 'ON_OFF'): ('LIFTED', 'CRUSHED'),
    # 385 g / 200 g, slippery: 0.25 N cannot lift them, the fingers slide up the object that
    # stays on the table (the controller used to say LIFTED); ON_OFF squeezes hard enough;
    # FORTE's race with the stick-slip goes either way (module docstring)
    ('soda_can', 'FORTE'): 'TRUTHFUL',
    ('soda_can', 'NO_SLIP'): ('NOT_CARRIED', 'RESTING'),
    ('soda_can', 'ON_OFF'): ('LIFTED', 'HELD'),
    ('glass_bottle', 'FORTE'): 'TRUTHFUL',
    ('glass_bottle', 'NO_SLIP'): ('NOT_CARRIED', 'RESTING'),
    ('glass_bottle', 'ON_OFF'): ('LIFTED', 'HELD'),
}


def truthful(outcome: str, state: str, height: float) -> bool:
    """The outcome is LIFTED or NOT_CARRIED and tells the truth about carrying, as the
    evaluation judges it (``metrics.contradicts_carried``): LIFTED exactly when the object
    hangs in the grasp at least ``metrics.CARRIED_HEIGHT`` above the table, NOT_CARRIED when
    it is on the table or slid down the fingers to below that height."""
    label = truth_label(state, height)
    return outcome in ('LIFTED', 'NOT_CARRIED') and label in ('HELD', 'HELD_LOW', 'RESTING') \
        and not contradicts_carried(outcome, label)


def mismatches(got: dict[tuple[str, str], tuple[str, str, float]]) -> dict:
    """Grasps whose (outcome, object state, object height [m]) break :data:`EXPECTED`.

    Returns
    -------
    dict
        (object, controller) -> (what happened, what was expected); empty when all agree.
    """
    wrong = {}
    for key, expected in EXPECTED.items():
        result = got.get(key)
        if result is None:
            wrong[key] = (None, expected)
        elif expected == 'TRUTHFUL':
            if not truthful(*result):
                wrong[key] = (result, expected)
        elif result[:2] != expected:
            wrong[key] = (result, expected)
    return wrong


def closed_loop_results(model) -> dict[tuple[str, str], tuple[str, str, float]]:
    """The nine demo grasps run by ``run_trial`` on the demo's scenes (seed 0, 20-sample
    perception updates): (object, controller) -> (outcome, final object state, height [m])."""
    from forte_bringup.closed_loop import run_trial

    results = {}
    for object_name, controller in EXPECTED:
        trial = run_trial(object_name, controller, seed=0, model=model, chunk_samples=20)
        results[object_name, controller] = (trial.outcome, trial.object_state,
                                            trial.final_height)
    return results
