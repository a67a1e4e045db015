"""The live commissioning run's pure parts: schedule, recorder, outputs (no ROS)."""
import numpy as np

from forte_commissioning.live_commissioning import (
    CommissioningSchedule,
    FrameRecorder,
    mean_joint_position,
    phases_from_boundaries,
    write_outputs,
)
from forte_commissioning.sensor_checks import CommissioningRecording
from forte_commissioning.simulated_commissioning import protocol, run_simulated


def test_the_schedule_runs_the_protocol_in_order():
    steps = protocol()
    assert [step.name for step in steps] == [
        'rest', 'rest_left_tip', 'press_left_tip', 'rest_left_root', 'press_left_root',
        'rest_right_tip', 'press_right_tip', 'rest_right_root', 'press_right_root',
        'squeeze', 'rest_end']
    schedule = CommissioningSchedule(steps, headless=True)
    assert schedule.advance(0.0) == [] and not schedule.started
    schedule.start(100.0)
    seen = []
    for tick in range(int(schedule.duration * 20) + 4):  # 20 Hz, exact times
        now = 100.0 + tick / 20
        seen += [(now - 100.0, action) for action in schedule.advance(now)]
    kinds = [action.kind for _, action in seen]
    assert kinds.count('phase') == len(steps) and kinds[-1] == 'done'
    assert kinds.count('press') == 4 and kinds.count('squeeze') == 1 and 'open' in kinds
    assert 'prompt' in kinds  # the squeeze warns to keep hands off
    press_times = [time for time, action in seen if action.kind == 'press']
    assert press_times == [3.0, 5.5, 8.0, 10.5]
    assert schedule.finished and schedule.advance(1e9) == []


def test_with_an_operator_the_schedule_prompts_instead_of_pressing():
    schedule = CommissioningSchedule(protocol(gap=3.0, press=3.0), headless=False)
    schedule.start(0.0)
    actions = [action for now in np.arange(0.0, 60.0, 0.1) for action in schedule.advance(now)]
    prompts = [action.text for action in actions if action.kind == 'prompt']
    assert not any(action.kind == 'press' for action in actions)
    assert 'PRESS the LEFT finger at its TIP now and hold it (3 s)' in prompts
    assert 'release; next: the right finger at its root' in prompts


def test_the_recorder_keeps_rows_in_order_and_the_link_counters():
    recorder = FrameRecorder()
    rows = np.arange(120.0).reshape(20, 6)
    recorder.add(rows, 1000, 5_000_000, 3, 1, 10.0)
    recorder.add(rows, 1010, 5_005_000, 3, 1, 10.01)  # half of it seen already
    recorder.add(rows, 1040, 5_020_000, 5, 2, 10.03)  # a gap of 10 rows
    assert recorder.next_sequence == 1060 and recorder.received == 50
    link = recorder.link()
    assert (link.first_sequence, link.last_sequence, link.dropped, link.corrupt) == (
        1000, 1040, 2, 1)
    assert abs(link.device_seconds - 0.02) < 1e-12
    phases = phases_from_boundaries(protocol()[:2], [1000, 1030], recorder.next_sequence)
    recording = recorder.recording(phases)
    assert recording.frames.shape == (50, 6)
    assert [(phase.start, phase.stop) for phase in recording.phases] == [(1000, 1030),
                                                                         (1030, 1060)]


def test_joint_positions_are_averaged_over_the_fingers():
    joints = ('forte_left_finger_joint', 'forte_right_finger_joint')
    assert mean_joint_position(list(joints), [0.5, 0.7], joints) == 0.6
    assert np.isnan(mean_joint_position(['other'], [0.1], joints))


def test_the_outputs_are_written_report_last(tmp_path):
    run = run_simulated((), seed=4)
    result, report = write_outputs(run.recording, tmp_path / 'out', {'device': 'simulated'})
    assert result.passed and (tmp_path / 'out' / 'report.txt').read_text() == report
    assert (tmp_path / 'out' / 'report.png').read_bytes()[:4] == b'\x89PNG'
    again = CommissioningRecording.load(tmp_path / 'out' / 'recording.npz')
    np.testing.assert_array_equal(again.frames, run.recording.frames)
