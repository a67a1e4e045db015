"""What each of the demo's nine grasps must end in, from the physics of its scene.

Shared by the demo test (the full ROS graph over DDS) and the closed-loop test (``run_trial``
on the same scenes): the two must produce the same pattern. Scenes: ``demo.DEMO_SEEDS``
(one seed per object, the same placement for every controller); the closed loop steps
perception every 20 samples, as the graph's 20-sample TactileFrames batches do.

Every scene was chosen to have a single physical outcome: the closed loop gives the same
outcome and truth for perception updates of 10, 20, 30 and 40 samples (a timing
perturbation of the order of the graph's transport delays). The soda can's seed 0, used
before, is a race for FORTE between stick-slip episodes and tightenings (+0.88 deg per slip
until the slip stops): on the table, hanging after sliding 28 mm down the fingers, or lifted,
depending on the batch size alone, and over DDS from run to run. With the paper's detector
and no gross-slip reaction, 8 of the soda can's seeds 0-15 were single-outcome for FORTE
(all NOT_CARRIED); with the robust detector and the gross-slip reaction (issue 14) 9 are
(3, 4, 6, 7, 9, 11, 12, 13, 15: all LIFTED, HELD) and 7 are races. Seed 13, the demo's
until 2026-11-26, needs all 20 tightenings that max_tightening allows at batch sizes 10 and
30 (so over DDS it ended in three different ways in CI runs, once NOT_CARRIED while the can
hung from the fingers); seed 7 needs 12-15 (batch sizes 10-40) and is the demo's now (seed
12 needs 12-14, but NO_SLIP's lift check passes its resting can: LIFTED, RESTING).
Of the glass bottle's seeds 0-8, 7 were single-outcome (all LIFTED); seed 0 is for NO_SLIP
and ON_OFF, and for FORTE at batch sizes 10-30 (at 40 it falls in the set-down probe, see
GRAPH_RACES), as are the raspberry's seed 0 and the soda can's seed 7 for NO_SLIP and
ON_OFF (batch sizes 10, 20, 30, 40).
"""
from __future__ import annotations

from forte_bringup.demo import DEMO_SEEDS

#: (object, controller) -> (controller's outcome, ground-truth object state after the grasp)
EXPECTED = {
    # 4 g, fragile: 0.25 N lifts it intact; ON_OFF's full close crushes it, in the grasp
    ('raspberry', 'FORTE'): ('LIFTED', 'HELD'),
    ('raspberry', 'NO_SLIP'): ('LIFTED', 'HELD'),
    ('raspberry', 'ON_OFF'): ('LIFTED', 'CRUSHED'),
    # 385 g, slippery: 0.25 N cannot lift it, the fingers slide up the can that stays on the
    # table (the controller used to say LIFTED); FORTE tightens on the first slips, then the
    # can slides smoothly (no more stick-slip to hear) but stays pinned against one finger:
    # FORTE's gross-slip reaction (unequal levels while lifting) tightens until it is carried
    # (before issue 14: NOT_CARRIED, RESTING); ON_OFF squeezes hard enough
    ('soda_can', 'FORTE'): ('LIFTED', 'HELD'),
    ('soda_can', 'NO_SLIP'): ('NOT_CARRIED', 'RESTING'),
    ('soda_can', 'ON_OFF'): ('LIFTED', 'HELD'),
    # 200 g, slippery: FORTE's tightenings on slip lift it, NO_SLIP cannot, ON_OFF can
    ('glass_bottle', 'FORTE'): ('LIFTED', 'HELD'),
    ('glass_bottle', 'NO_SLIP'): ('NOT_CARRIED', 'RESTING'),
    ('glass_bottle', 'ON_OFF'): ('LIFTED', 'HELD'),
}


#: The honest ends of a grasp that does not carry its object: the controller says so and the
#: object is on the table (never lifted, or lifted and lost in the hold).
HONEST_MISSES = (('NOT_CARRIED', 'RESTING'), ('DROPPED', 'RESTING'))

#: Grasps whose outcome over DDS is a race between honest outcomes (the controller agrees with
#: the truth in each): (object, controller) -> the other outcomes the graph may end in.
#: FORTE catches the soda can of seed 7 after 12-15 tightenings (closed loop, batches of
#: 10-40 samples) out of the 20 that max_tightening allows, most of them on gross-slip
#: evidence: over DDS, message timing changes how many fit before the lift ends (with seed
#: 13, which needs up to all 20, CI runs ended NOT_CARRIED, RESTING once and DROPPED,
#: RESTING once).
#: The glass bottle of seed 0 is carried in the closed loop with batches of 10-30 samples;
#: with 40 it falls 25 mm onto the table as the set-down probe begins to lower (NOT_CARRIED,
#: RESTING; the controller claimed LIFTED until the probe was voided by the slip it caused,
#: 2026-11-27), and over DDS FORTE's tightenings came too late for it in 1 of 3 quiet CI runs
#: of 2026-11-26 (NOT_CARRIED, RESTING). In a CI run of 2026-11-27 the soda can slid onto
#: the table in the hold and FORTE claimed LIFTED (a probe judged against the grip from
#: before the slide, docs/control.md): a controller that disagrees with the truth, which
#: this list never accepts.
#: Never a race: a crushed or broken object, or a controller that disagrees with the truth.
GRAPH_RACES = {
    ('soda_can', 'FORTE'): HONEST_MISSES,
    ('glass_bottle', 'FORTE'): HONEST_MISSES,
}


def mismatches(got: dict[tuple[str, str], tuple[str, str]], graph: bool = False) -> dict:
    """Grasps whose (outcome, ground-truth object state) differ from :data:`EXPECTED`.

    Parameters
    ----------
    got : dict
        (object, controller) -> (outcome, object state).
    graph : bool
        The grasps ran over DDS: a grasp of :data:`GRAPH_RACES` may also end in one of its
        race's other honest outcomes.

    Returns
    -------
    dict
        (object, controller) -> (what happened, what was expected); empty when all agree.
    """
    return {key: (got.get(key), expected) for key, expected in EXPECTED.items()
            if got.get(key) != expected
            and not (graph and got.get(key) in GRAPH_RACES.get(key, ()))}


def closed_loop_results(model) -> dict[tuple[str, str], tuple[str, str]]:
    """The nine demo grasps run by ``run_trial`` on the demo's scenes (20-sample perception
    updates): (object, controller) -> (outcome, final ground-truth object state)."""
    from forte_evaluation.closed_loop import run_trial

    results = {}
    for object_name, controller in EXPECTED:
        trial = run_trial(object_name, controller, seed=DEMO_SEEDS.get(object_name, 0),
                          model=model, chunk_samples=20)
        results[object_name, controller] = (trial.outcome, trial.object_state)
    return results
