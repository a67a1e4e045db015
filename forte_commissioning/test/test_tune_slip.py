"""forte_tune_slip: the threshold sweep as a lab runs it on its labelled recordings (an onset
CSV from an operator), the overlay it writes, its refusals, its sweep grid."""
import numpy as np

from forte_commissioning import tune_slip
from forte_perception.evaluation.labelled_recordings import (
    LabelledRecording,
    load_labelled,
    save_labelled,
)
from forte_perception.evaluation.onset_labels import write_onset_csv
from forte_perception.evaluation.threshold_sweep import params_from_overlay
from forte_perception.testing import (
    FS,
    SWEEP_DISTRACTORS,
    SWEEP_SAMPLES,
    SWEEP_SLIPS,
    known_answer_recording,
)

N, SLIPS, DISTRACTORS = SWEEP_SAMPLES, SWEEP_SLIPS, SWEEP_DISTRACTORS



def test_tune_slip_command(tmp_path, capsys):
    rec = known_answer_recording()
    path = tmp_path / 'known.npz'
    save_labelled(path, LabelledRecording(rec.frames, FS, np.zeros(0, np.int64), rec.trial))
    assert load_labelled(path).onsets.size == 0          # the onsets come from the CSV
    labels = tmp_path / 'labels.csv'
    write_onset_csv(labels, {'known': np.array(SLIPS) / FS}, 'operator: test')
    out = tmp_path / 'cfg' / 'overlay.yaml'
    assert tune_slip.main([str(path), '--labels', str(labels), '--modes', 'paper',
                           '--thresholds', '2', '25', '200', '-o', str(out),
                           '--report', str(tmp_path / 'r.json')]) == 0
    text = capsys.readouterr().out
    assert 'threshold=25 **<-**' in text
    assert 'slip_threshold: 25.0' in out.read_text()
    assert params_from_overlay({'perception': {'ros__parameters': {
        'slip_mode': 'paper', 'slip_threshold': 25.0}}}).threshold == 25.0
    # without the labels the recording has no onsets: every flag run is false
    assert tune_slip.main([str(path), '--modes', 'paper', '--thresholds', '2', '25',
                           '-o', str(out)]) == 0
    assert 'no setting reached the floor' in capsys.readouterr().out
    bad = tmp_path / 'bad.csv'
    bad.write_text('recording,onset\nknown,1.0\n')
    assert tune_slip.main([str(path), '--labels', str(bad), '-o', str(out)]) == 2
    assert 'onset_s' in capsys.readouterr().err
    labels.write_text('recording,onset_s\nother,1.0\n')
    assert tune_slip.main([str(path), '--labels', str(labels), '-o', str(out)]) == 2
    assert "'known' is not labelled" in capsys.readouterr().err


def test_robust_sweep_grid_of_the_command():
    settings, skipped = tune_slip.settings_for(['robust', 'paper'], (2.0, 4.0),
                                               {'single_threshold': (3.0, 4.5)}, FS)
    varied = [v for _, v in settings]
    assert {'mode': 'robust', 'threshold': 4.0, 'single_threshold': 4.5} in varied
    assert {'mode': 'paper', 'threshold': 4.0} in varied
    assert len(skipped) == 1            # robust T=4 with the one-finger threshold 3
