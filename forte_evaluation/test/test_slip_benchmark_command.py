"""``python -m forte_evaluation.slip_benchmark`` on a small set: tables printed, JSON written."""
import json

from forte_evaluation import slip_benchmark
from forte_evaluation.slip_dataset import sim_scene
from forte_perception.evaluation.scenes import make_scene
from forte_perception.slip.params import RECOMMENDED_MODE


def small_set(*_args, **_kwargs):
    scenes = [make_scene('quiet_sub_lsb', 'p0', 0), make_scene('stick_slip_30_100lsb', 'p0', 0),
              make_scene('stick_slip_30_100lsb', 'p1', 1), sim_scene('jam_jar', 1, 'marginal')]
    return scenes, {'hash': 'test', 'path': '-', 'cached': True, 'seconds': 0.0}


def test_the_command_prints_both_splits_and_writes_json(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(slip_benchmark, 'build_set', small_set)
    code = slip_benchmark.main(['--mode', 'paper', '--repeats', '1', '--output', str(tmp_path)])
    assert code == 0
    text = capsys.readouterr().out
    assert '### paper mode, tune part' in text and '### paper mode, held-out part' in text
    assert '| sim_slippery |' in text and '**all sim**' in text
    document = json.loads((tmp_path / 'paper.json').read_text())
    assert document['config']['mode'] == 'paper' and document['config']['scenes'] == 4
    tune = document['results']['tune']
    assert tune['families']['stick_slip_30_100lsb']['events'] == 3
    assert tune['families']['quiet_sub_lsb']['events'] == 0
    assert tune['families']['quiet_sub_lsb']['recall'] is None        # NaN -> null
    assert len(document['scenes']) == 4
    assert (tmp_path / 'paper.md').read_text().startswith('### paper mode, tune part')


def test_selections_narrow_the_set(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(slip_benchmark, 'build_set', small_set)
    assert slip_benchmark.main(['--repeats', '1', '--output', str(tmp_path), '--split',
                                'held_out', '--signal-only']) == 0
    document = json.loads((tmp_path / 'sequential.json').read_text())  # the default mode
    assert list(document['results']) == ['held_out']
    assert document['config']['scenes'] == 1
    assert slip_benchmark.main(['--output', str(tmp_path), '--families', 'ramp']) == 2


def test_the_default_mode_is_the_perception_nodes():
    assert slip_benchmark._parser().parse_args([]).mode == RECOMMENDED_MODE == 'sequential'
