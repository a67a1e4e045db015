"""The demo end to end: nine grasps over the full graph (DDS), bag, report, figures.

Each grasp's outcome is checked against the simulator's ground truth (``sim/ground_truth``,
recorded by the demo after the result; the controller never sees it): the exact outcome and
object state each scripted grasp must end in, from the physics of the scene (sim.yaml: seed
0, the same placement for every controller).

Two grasps have no single physical outcome over DDS: FORTE on the soda can and on the glass
bottle. Their grip is just enough by design (+0.88 deg per slip until the slip stops), so
whether the weight transfers before the lift ends is a race between stick-slip episodes and
tightenings. In the graph, a tightening reaches the simulated servo 20-170 ms (simulated
time, real-time factor 0.5) after the slip flag, varying with the machine's load (measured
from the demo bags: command stamp to joint state at the new angle; the controller itself
answers within the perception update that carries the flag); in the closed loop the same
scene flips between carried and not carried when only the perception batch size changes
(10, 20, 30, 40 samples). Over five graph runs the soda can ended carried twice and on the
table three times, the glass bottle carried four times out of five. For those two the test
demands the truth instead: LIFTED exactly when the can hangs in the grasp, NOT_CARRIED
exactly when it stayed on the table.
"""
from __future__ import annotations

import json
import subprocess
import sys

import pytest
from mcap.reader import make_reader

from forte_bringup.demo import DEFAULT_CONTROLLERS, DEFAULT_OBJECTS

#: The two (outcome, truth) pairs in which the controller tells the truth about carrying.
TRUTHFUL = {('LIFTED', 'HELD'), ('NOT_CARRIED', 'RESTING')}
#: (object, controller) -> (controller's outcome, ground-truth object state after the grasp),
#: or 'TRUTHFUL' where the physics goes either way (module docstring).
EXPECTED = {
    # 4 g, fragile: 0.25 N lifts it intact; ON_OFF's full close crushes it, in the grasp
    ('raspberry', 'FORTE'): ('LIFTED', 'HELD'),
    ('raspberry', 'NO_SLIP'): ('LIFTED', 'HELD'),
    ('raspberry', 'ON_OFF'): ('LIFTED', 'CRUSHED'),
    # 385 g / 200 g, slippery: 0.25 N cannot lift them, the fingers slide up the object that
    # stays on the table (the controller used to say LIFTED); ON_OFF squeezes hard enough;
    # FORTE's race with the stick-slip goes either way over DDS (module docstring)
    ('soda_can', 'FORTE'): 'TRUTHFUL',
    ('soda_can', 'NO_SLIP'): ('NOT_CARRIED', 'RESTING'),
    ('soda_can', 'ON_OFF'): ('LIFTED', 'HELD'),
    ('glass_bottle', 'FORTE'): 'TRUTHFUL',
    ('glass_bottle', 'NO_SLIP'): ('NOT_CARRIED', 'RESTING'),
    ('glass_bottle', 'ON_OFF'): ('LIFTED', 'HELD'),
}


@pytest.mark.slow
@pytest.mark.timeout(1200)
def test_demo_grasps_end_as_the_physics_says_and_the_report_shows_them(tmp_path):
    assert set(EXPECTED) == {(o, c) for o in DEFAULT_OBJECTS for c in DEFAULT_CONTROLLERS}
    output = tmp_path / 'demo'
    process = subprocess.run(
        [sys.executable, '-m', 'forte_bringup.demo', '--output', str(output)],
        capture_output=True, text=True, timeout=1100)
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    assert '[demo] 1/9 raspberry / FORTE: grasping' in process.stdout  # progress shown
    rows = json.loads((output / 'outcomes.json').read_text())
    got = {(r['object'], r['controller']): (r['outcome'], r['object_state']) for r in rows}
    messages = {(r['object'], r['controller']): r.get('message', '') for r in rows}
    wrong = {key: (got.get(key), expected, messages.get(key)) for key, expected
             in EXPECTED.items()
             if (got.get(key) not in TRUTHFUL if expected == 'TRUTHFUL'
                 else got.get(key) != expected)}
    assert not wrong, wrong
    for row in rows:  # the claim comes with its evidence
        if row['outcome'] == 'LIFTED':
            assert 'equal' in row['message'] and 'when set down' in row['message']
            assert row['lift_height'] == pytest.approx(0.03, abs=0.001)
    report = (output / 'report.md').read_text()
    assert '| glass_bottle | ON_OFF | LIFTED | HELD |' in report
    assert '| soda_can | NO_SLIP | NOT_CARRIED | RESTING |' in report
    for obj, controller in EXPECTED:
        figure = output / f'{obj}_{controller}.png'
        assert figure.name in report and figure.read_bytes()[:4] == b'\x89PNG'
    (mcap_file,) = (output / 'bag').glob('*.mcap')
    with mcap_file.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    topics = {channel.topic for channel in summary.channels.values()}
    assert {'/tactile/frames', '/tactile/state', '/sim/ground_truth', '/gripper/command',
            '/grasp/state', '/joint_states'} <= topics
    counts = summary.statistics.channel_message_counts
    by_topic = {summary.channels[c].topic: n for c, n in counts.items()}
    assert by_topic['/tactile/state'] > 900 and by_topic['/sim/ground_truth'] > 900
