"""``commission.launch.py target:=bench_twin``: sensor commissioning through the real
serial and gripper drivers against the bench twin, with no fault and with an injected one.

The launch starts the bench twin on the simulated rig (its sensor board and servos on
ptys, ``sensor_fault`` injected into the readings), the hardware graph on the twin's links
and ``forte_commission --headless`` (the twin's scripted operator presses, the leak test
closes the gripper through ``gripper/command``). The test reads the report it writes.
The healthy run is in the root namespace; the faulty one runs as one gripper of several on
a domain (``namespace:=right prefix:=right_``): its commissioning starts only if
``forte_commission`` reads the namespaced readings and the prefixed joints, and its report
must then name the injected fault. (Until 2026-11 a third run, healthy in the namespace,
checked the namespace alone; the faulty namespaced run checks it and more, 35 s less.)

Needs launch_pytest and launch_ros (the launch kit on a bare machine); skipped with that
reason otherwise.
"""
from __future__ import annotations

import time
from pathlib import Path

import pytest

REASON = ('launch_pytest / launch_ros need a ROS 2 install (ros-jazzy-launch-pytest) or the '
          'launch kit (../shared/ros2-launch-kit)')
launch_pytest = pytest.importorskip('launch_pytest', reason=REASON)
pytest.importorskip('launch_ros', reason=REASON)

import launch  # noqa: E402
import numpy as np  # noqa: E402
from launch.actions import IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402

from forte_perception.commissioning import CommissioningRecording, evaluate  # noqa: E402
from forte_ros.testing import wait_until  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch' / 'commission.launch.py'
#: Start-up of twin and graph (up to a minute on a loaded 2-core machine), the protocol
#: (25.5 s headless) and the report [s].
DONE = 240.0
#: Findings about the link, not the sensor: on a loaded 2-core machine the emulated board
#: (Python, beside the graph and other jobs) skipped up to 5 % of its scans in some runs
#: (the driver counts them dropped, the report FAILs dropped_frames, rightly); the sensor's
#: verdicts are judged on what arrived, which this test checks.
LINK_FINDINGS = ('dropped_frames', 'corrupt_frames', 'host_rate', 'sample_rate')
#: Injected fault -> (finding kind, channel names) the report must name; '' = healthy.
FAULTS = {'': None, 'reversed:left_middle': ('reversed', 'left_middle')}


#: Runs: (injected fault, namespace, prefix).
RUNS = [('', '', ''), ('reversed:left_middle', 'right', 'right_')]


@pytest.fixture(params=RUNS, ids=['healthy', 'reversed_in_namespace'])
def run(request) -> tuple[str, str, str]:
    return request.param


@pytest.fixture
def fault(run: tuple[str, str, str]) -> str:
    return run[0]


@launch_pytest.fixture
def commissioning(run: tuple[str, str, str], tmp_path: Path) -> launch.LaunchDescription:
    fault, namespace, prefix = run
    arguments = {'target': 'bench_twin', 'sensor_fault': fault, 'seed': '3',
                 'sensor_port': str(tmp_path / 'bench' / 'sensor'),
                 'gripper_port': str(tmp_path / 'bench' / 'gripper'),
                 'output': str(tmp_path / 'out'), 'namespace': namespace, 'prefix': prefix}
    return launch.LaunchDescription([
        IncludeLaunchDescription(PythonLaunchDescriptionSource(str(LAUNCH)),
                                 launch_arguments=arguments.items()),
        launch_pytest.actions.ReadyToTest(),
    ])


@pytest.mark.launch(fixture=commissioning)
def test_commissioning_on_the_bench_twin_names_the_injected_fault(fault: str,
                                                                   tmp_path: Path):
    report_file = tmp_path / 'out' / 'report.txt'
    start = time.monotonic()
    assert wait_until(report_file.exists, DONE, period=0.5), 'no report within the time allowed'
    report = report_file.read_text()
    print(f'commissioning with fault {fault!r}: report after {time.monotonic() - start:.0f} s')
    print(report[:1200])
    assert (tmp_path / 'out' / 'report.png').stat().st_size > 10_000
    recording = CommissioningRecording.load(tmp_path / 'out' / 'recording.npz')
    assert [phase.name for phase in recording.phases][:3] == ['rest', 'rest_left_tip',
                                                             'press_left_tip']
    assert len(recording.frames) > 0.9 * 2000 * 25.5  # the protocol, through the drivers
    assert np.all(np.diff(recording.sequence) >= 1)
    result = evaluate(recording)  # the report's verdicts, structured
    link = [check for check in result.checks if check.subject == 'link']
    print('link:', '; '.join(f'{check.check} {check.status} ({check.detail})' for check in link))
    sensor = [(finding.kind, finding.channel_names) for finding in result.findings
              if finding.kind not in LINK_FINDINGS]
    judged = [check for check in result.checks if check.subject != 'link']
    if FAULTS[fault] is None:
        assert sensor == [] and {check.status for check in judged} == {'PASS'}, report
        assert 'VERDICT: PASS' in report or 'dropped_frames' in report
    else:
        kind, channel = FAULTS[fault]
        assert sensor == [(kind, (channel,))], report
        assert 'VERDICT: FAIL' in report and f'{kind} [{channel}]' in report
