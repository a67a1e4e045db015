"""The delay / false-alarm report (forte_perception.evaluation.change_detection): known answers
from hand-built scenes and detector stubs whose flags are placed by hand."""
import math

import numpy as np
import pytest

from forte_perception.evaluation.benchmark import Detection
from forte_perception.evaluation.change_detection import (
    best_at_zero_false_alarms,
    delay_false_alarm_curve,
    is_distractor,
    markdown_curve,
    slip_params_settings,
)
from forte_perception.evaluation.labels import FINGER_BOTH, SlipScene
from forte_perception.evaluation.scenes import make_scene
from forte_perception.slip.params import SlipParams

FS = 2000.0


def labelled(tag, events, holding, n):
    """A scene of zero frames (only the labels matter) whose first value tags it."""
    events = np.array(events, np.int64).reshape(-1, 2)
    k = events.shape[0]
    frames = np.zeros((n, 6))
    frames[0, 0] = tag
    return SlipScene(f'f{tag}/x/0', f'f{tag}', 'tune', 'signal', 'x', 0, frames, events,
                     [FINGER_BOTH] * k, ('stick_slip',) * k, np.full(k, 5.0),
                     np.array(holding, np.int64).reshape(-1, 2), FS, 1000)


# slip: two events (onsets 2000 and 8000); quiet: 10 s all holding; distractor: 2 s holding
# then 3 s busy (evaluated 1000 .. 11000 = 5 s)
SLIP = labelled(1, [(2000, 2400), (8000, 8600)], [(1000, 1900), (4000, 7000)], 12000)
QUIET = labelled(2, [], [(1000, 21000)], 21000)
DISTRACTOR = labelled(3, [], [(1000, 5000)], 11000)


def stub(delay_samples, quiet_flags=(), distractor_flags=()):
    """A detector: flags each SLIP event ``delay_samples`` after its onset, and the given
    samples in the quiet and distractor scenes."""
    def detect(inp):
        tag = int(round(inp.raw[0, 0]))
        flags = {1: [2000 + delay_samples, 8000 + delay_samples], 2: list(quiet_flags),
                 3: list(distractor_flags)}[tag]
        flags = np.array(flags, np.int64)
        return Detection(flags, np.ones(flags.size, bool), 4)
    return detect


def test_known_delays_and_false_alarm_rates():
    scenes = [SLIP, QUIET, DISTRACTOR]
    settings = [({'h': 1}, stub(80, quiet_flags=[5000, 15000], distractor_flags=[3000, 9000])),
                ({'h': 2}, stub(200)),
                ({'h': 3}, stub(1200))]      # later than 0.5 s: nothing detected
    fast, slow, late = delay_false_alarm_curve(scenes, settings)
    assert fast.events == 2 and fast.detected == 2 and fast.recall == 1.0
    assert fast.delay_p50_ms == pytest.approx(40.0) and fast.delay_p90_ms == pytest.approx(40.0)
    holding_s = 0.45 + 1.5 + 10.0 + 2.0         # SLIP + QUIET + DISTRACTOR holding
    assert fast.holding_h == pytest.approx(holding_s / 3600.0)
    # quiet 5000 and 15000 in holding, distractor 3000 in holding, 9000 busy
    assert fast.false_holding == 3
    assert fast.false_per_hour_holding == pytest.approx(3 / (holding_s / 3600.0))
    assert fast.distractor_min == pytest.approx(5.0 / 60.0)
    assert fast.false_distractor == 2
    assert fast.false_per_min_distractor == pytest.approx(24.0)
    assert fast.runs == 6 and fast.false_runs == 4 and fast.precision == pytest.approx(2 / 6)
    assert not fast.zero_false_alarms
    assert slow.delay_p50_ms == pytest.approx(100.0) and slow.zero_false_alarms
    assert slow.false_per_hour_holding == 0.0 and slow.false_per_min_distractor == 0.0
    assert late.detected == 0 and math.isnan(late.delay_p50_ms) and late.recall == 0.0
    # the late flags are in the 0.5 s after each event's end: not false either
    assert late.false_runs == 0
    assert best_at_zero_false_alarms([fast, slow, late]) is slow
    table = markdown_curve([fast, slow, late], 'stub')
    assert 'h=2 **<-**' in table and table.count('\n') == 4 and 'n/a' in table


def test_p90_interpolates_between_delays():
    scenes = [SLIP]

    def detect(inp):
        flags = np.array([2000 + 20, 8000 + 220], np.int64)
        return Detection(flags, np.ones(2, bool), 4)

    (point,) = delay_false_alarm_curve(scenes, [({}, detect)])
    assert point.delay_p50_ms == pytest.approx(60.0)      # mean of 10 and 110 ms
    assert point.delay_p90_ms == pytest.approx(100.0)     # 10 + 0.9 x 100


def test_distractor_and_quiet_scenes_are_told_apart():
    (point,) = delay_false_alarm_curve([QUIET, DISTRACTOR], [({}, stub(0))])
    assert point.distractor_min == pytest.approx(5.0 / 60.0)  # the quiet scene is not one
    assert math.isnan(point.recall) and point.events == 0
    from forte_perception.evaluation.slip_metrics import scene_outcome
    assert is_distractor(scene_outcome(DISTRACTOR, np.zeros(0, np.int64), 4))
    assert not is_distractor(scene_outcome(QUIET, np.zeros(0, np.int64), 4))
    assert not is_distractor(scene_outcome(SLIP, np.zeros(0, np.int64), 4))


def test_best_point_without_clean_points_is_none():
    (point,) = delay_false_alarm_curve([QUIET], [({}, stub(0, quiet_flags=[4000]))])
    assert best_at_zero_false_alarms([point]) is None


def test_slip_params_settings_sweep_a_real_mode():
    scene = make_scene('stick_slip_30_100lsb', 'p0', 0)
    settings = slip_params_settings(SlipParams(mode='paper'), 'threshold', (2.0, 1e6))
    assert [s[0] for s in settings] == [{'threshold': 2.0}, {'threshold': 1e6}]
    normal, deaf = delay_false_alarm_curve([scene], settings)
    assert normal.detected > 0 and deaf.detected == 0 and deaf.runs == 0
    # a setting the mode refuses is left out
    assert len(slip_params_settings(SlipParams(mode='robust'), 'single_threshold',
                                    (1.0, 3.0))) == 1
