"""slip_delay_report on a handful of generated scenes: every mode gives a curve along its
parameter, the table and the figure are written, and the known order holds (the paper mode
alarms on the sub-LSB quiet hold where the robust mode does not)."""
from __future__ import annotations

from forte_evaluation.slip_delay_report import SWEEPS, delay_report, figure
from forte_perception.evaluation.scenes import make_scene


def test_curves_tables_and_figure(tmp_path):
    scenes = [make_scene('quiet_sub_lsb', 'p1', 1), make_scene('closing_step', 'p3', 3),
              make_scene('sustained_sliding', 'p5', 5)]
    text, curves, states = delay_report(scenes, ['paper', 'robust', 'sequential'])
    for mode in ('paper', 'robust', 'sequential'):
        assert len(curves[mode]) == len(SWEEPS[mode])
        assert f'| {mode}' in text
        assert states[mode]['raised_outside'] >= 0
    # the paper mode's false alarms on sub-LSB quiet holding (issue 14) at its own T = 2
    paper = next(p for p in curves['paper'] if p.setting['threshold'] == 2.0)
    robust = next(p for p in curves['robust'] if p.setting['T'] == 2.0)
    assert paper.false_holding > 0 and robust.false_holding == 0
    figure(curves, tmp_path / 'curves.png')
    assert (tmp_path / 'curves.png').read_bytes()[:4] == b'\x89PNG'
