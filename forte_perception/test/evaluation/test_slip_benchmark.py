"""The slip mode runner (forte_perception.evaluation.benchmark): the paper mode is the paper's
detector, outcomes and CPU times are reported per family and split, the tables print."""
import math

import numpy as np

from forte_perception.evaluation.benchmark import (
    MODES,
    Detection,
    markdown,
    paper_mode,
    prepare,
    report,
    run_mode,
)
from forte_perception.evaluation.scenes import make_scene
from forte_perception.median import running_median
from forte_perception.slip.detector import SlipParams, slip_features


def scenes():
    return [make_scene('stick_slip_30_100lsb', 'p0', 0),
            make_scene('quiet_above_lsb', 'p2', 2),
            make_scene('stick_slip_30_100lsb', 'p1', 1)]


def test_paper_mode_is_the_paper_detector_on_the_median_filtered_frames():
    scene = scenes()[0]
    (inp,) = prepare([scene])
    np.testing.assert_array_equal(inp.filtered, running_median(scene.frames, 11))
    det = paper_mode(inp)
    ref = slip_features(running_median(scene.frames, 11), 2000.0, SlipParams(mode='paper'))
    np.testing.assert_array_equal(det.sample_index, ref.sample_index)
    np.testing.assert_array_equal(det.slip, ref.slip)
    assert det.hop == 4 and MODES['paper'] is paper_mode


def test_run_mode_scores_every_scene_and_times_every_split():
    chosen = scenes()
    outcomes, cpu = run_mode(chosen, 'paper', repeats=2)
    assert [o.name for o in outcomes] == [s.name for s in chosen]
    strong = outcomes[0]
    assert strong.detected.all()           # >= 30 LSB on both fingers: the paper catches it
    assert outcomes[1].runs.shape[0] == 0  # >= 1 LSB of noise: no false flag
    for key in [('tune', 'stick_slip_30_100lsb'), ('tune', 'all signal'), ('tune', 'all'),
                ('held_out', 'all')]:
        assert cpu[key] >= 0.0
    assert cpu[('tune', 'all')] >= cpu[('tune', 'quiet_above_lsb')]
    results = report(outcomes, cpu)
    assert set(results) == {'tune', 'held_out'}
    tune = results['tune']
    assert list(tune['families']) == ['stick_slip_30_100lsb', 'quiet_above_lsb']
    assert tune['groups']['all']['events'] == 3
    assert tune['families']['stick_slip_30_100lsb']['updates'] == strong.updates
    assert not math.isnan(tune['groups']['all']['cpu_us_per_update'])
    assert tune['kinds']['signal stick_slip']['events'] == 3
    text = markdown(results, 'paper')
    assert '### paper mode, tune part' in text and '### paper mode, held-out part' in text
    assert '| quiet_above_lsb | 1 | 0 | 0 | n/a |' in text   # no event: recall undefined


def test_a_mode_is_any_function_of_the_sensor_input():
    def never(inp):
        m = (inp.raw.shape[0] - 400) // 4 + 1
        return Detection(399 + 4 * np.arange(m), np.zeros(m, bool), 4)

    outcomes, _ = run_mode(scenes()[:1], never, repeats=1)
    assert not outcomes[0].detected.any() and outcomes[0].runs.shape == (0, 2)


def test_sequential_mode_gates_with_the_scenes_servo_command():
    """A scene that records its servo command: the sequential runner feeds its changes to
    the servo gate (as the node does from gripper/command), so the ringing of a servo
    step at sample 8000 alarms only where the scene has no command."""
    from forte_perception.evaluation.benchmark import SensorInput, sequential_mode
    from forte_perception.testing import ringing_after_a_step

    frames = ringing_after_a_step()
    filtered = running_median(frames, 11)
    command = np.full(frames.shape[0], 0.30)
    command[8000:] = 0.30 - 0.0154  # a tightening at the ringing's first sample
    blind = sequential_mode(SensorInput(frames, filtered, 2000.0, {}))
    told = sequential_mode(SensorInput(frames, filtered, 2000.0, {'servo_command': command}))
    late = np.asarray(blind.sample_index) >= 8000
    assert np.asarray(blind.slip)[late].any()
    assert not np.asarray(told.slip)[late].any()
