"""The bench twin's commissioning aids: a scripted operator's press and injected sensor
faults, judged from the sensor board's scans as the serial driver reads them."""
from __future__ import annotations

import numpy as np

from forte_driver.emulators.serial_host import Host
from forte_driver.serial.protocol import Command
from forte_sim import make_scene
from forte_sim.bench_twin import BenchTwin
from forte_sim.channel_faults import parse_faults


def scans_during_press(tmp_path, faults: str, finger: int) -> tuple[np.ndarray, np.ndarray]:
    """Board scans [counts] before and at the plateau of a 4 N tip press on ``finger``."""
    scene = make_scene('calibration', seed=5, indentor='flat_wide')
    with BenchTwin(str(tmp_path / 'sensor'), scene, faults=parse_faults(faults)) as twin:
        host = Host(twin.sensor.link_path)
        try:
            assert host.command(Command.START).status == 0
            host.pump(0.4)
            before = np.array([sample.values for sample in host.samples])
            start, stop = twin.press(finger, 0.1, force=4.0, hold=1.0)
            assert stop - start == 3000
            host.samples.clear()
            host.pump(0.9)
            during = np.array([sample.values for sample in host.samples])
        finally:
            host.close()
    return np.median(before, axis=0), np.median(during[-400:], axis=0)


def test_a_press_moves_its_finger_and_a_reversed_channel_goes_negative(tmp_path):
    before, during = scans_during_press(tmp_path, 'reversed:left_middle', finger=0)
    change = during - before
    assert change[0] > 150 and change[2] > 30  # counts: distal ~0.3, root ~0.06 of 1024
    assert change[1] < -60  # the reversed middle channel falls
    assert np.all(np.abs(change[3:]) < 8)  # the right finger is not pressed


def test_swapped_fingers_move_the_other_fingers_channels(tmp_path):
    before, during = scans_during_press(tmp_path, 'swapped_fingers', finger=0)
    change = during - before
    assert np.all(np.abs(change[:3]) < 8)
    assert change[3] > change[4] > change[5] > 30
