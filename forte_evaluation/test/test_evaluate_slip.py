"""forte_evaluate_slip on labelled trials of generated slip bursts (the labelled recording
format): the scores, the report, the refusals."""
import json

import numpy as np

from forte_evaluation import evaluate_slip as evaluate_tool
from forte_perception.evaluation.labelled_recordings import (
    LabelledRecording,
    evaluate_slip,
    save_labelled,
)
from forte_perception.slip.detector import SlipParams
from forte_perception.testing import FS, slip_bursts


def test_evaluate_slip_on_labelled_trials(tmp_path, capsys):
    n = 8000
    slipping = slip_bursts(n, seed=1, onsets=(3000, 6000))
    quiet = slip_bursts(n, seed=2, onsets=())
    frames = np.concatenate([slipping, quiet]) + 0.1
    trial = np.repeat([0, 1], n)
    rec = LabelledRecording(frames, FS, np.array([3000, 6000]), trial)
    paper = SlipParams(mode='paper')
    result = evaluate_slip([rec], paper)
    scores = result['trials']
    assert scores.true_positive == 1 and scores.true_negative == 1
    assert scores.accuracy == 1.0 and result['missed_onsets'] == 0
    assert len(result['latencies_s']) == 2 and max(result['latencies_s']) < 0.1
    assert result['false_alarms'] == 0
    # a label without a slip in the signal is a miss (FN); a burst without label an FP
    wrong = LabelledRecording(frames, FS, np.array([n + 3000]), trial)
    result = evaluate_slip([wrong], paper)
    assert result['trials'].false_positive == 1 and result['trials'].false_negative == 1
    assert result['missed_onsets'] == 1 and result['false_alarms'] >= 2
    path = tmp_path / 'rec.npz'
    save_labelled(path, rec)
    assert evaluate_tool.main([str(path), '--mode', 'paper', '--report',
                               str(tmp_path / 'r.json')]) == 0
    assert 'precision 1.000' in capsys.readouterr().out
    report = json.loads((tmp_path / 'r.json').read_text())
    assert report['trials']['true_positive'] == 1 and report['trials']['precision'] == 1.0
    assert evaluate_tool.main([str(path), '--hop', '0']) == 2


def test_evaluate_slip_without_slip_or_flag_prints_n_a(tmp_path, capsys):
    """A quiet trial with no onset: precision, recall and F1 are undefined (n/a), accuracy 1."""
    path = tmp_path / 'quiet.npz'
    save_labelled(path, LabelledRecording(slip_bursts(8000, seed=2, onsets=()) + 0.1, FS,
                                          np.zeros(0, np.int64)))
    assert evaluate_tool.main([str(path), '--mode', 'paper']) == 0
    out = capsys.readouterr().out
    assert 'TP 0  FP 0  FN 0  TN 1' in out
    assert 'accuracy 1.000  precision n/a  recall n/a  F1 n/a' in out
    assert 'missed onsets 0, false alarms 0' in out
