"""The demo end to end on one grasp: full graph over DDS, bag, report, figure."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest
from mcap.reader import make_reader


@pytest.mark.slow
def test_demo_one_grasp_writes_report_figure_and_bag(tmp_path):
    output = tmp_path / 'demo'
    process = subprocess.run(
        [sys.executable, '-m', 'forte_bringup.demo', '--objects', 'glass_bottle',
         '--controllers', 'FORTE', '--output', str(output)],
        capture_output=True, text=True, timeout=300)
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    assert '[demo] 1/1 glass_bottle / FORTE: grasping' in process.stdout  # progress shown
    rows = json.loads((output / 'outcomes.json').read_text())
    assert len(rows) == 1 and rows[0]['controller'] == 'FORTE'
    assert rows[0]['outcome'] in ('LIFTED', 'DROPPED', 'FAULT', 'FORCE_LIMIT', 'NO_CONTACT')
    assert rows[0]['object_state'] in ('HELD', 'RESTING', 'DROPPED', 'BROKEN', 'CRUSHED')
    report = (output / 'report.md').read_text()
    assert '| glass_bottle | FORTE |' in report and 'glass_bottle_FORTE.png' in report
    assert (output / 'glass_bottle_FORTE.png').read_bytes()[:4] == b'\x89PNG'
    (mcap_file,) = (output / 'bag').glob('*.mcap')
    with mcap_file.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    topics = {channel.topic for channel in summary.channels.values()}
    assert {'/tactile/frames', '/tactile/state', '/sim/ground_truth', '/gripper/command',
            '/grasp/state', '/joint_states'} <= topics
    counts = summary.statistics.channel_message_counts
    by_topic = {summary.channels[c].topic: n for c, n in counts.items()}
    assert by_topic['/tactile/state'] > 100 and by_topic['/sim/ground_truth'] > 100
