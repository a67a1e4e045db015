"""The wiring table, BOM and docs agree with docs/contracts.md, the design and the URDF."""
import csv
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from forte_finger.design import LOCATIONS, make_design

ROOT = Path(__file__).resolve().parents[2]
CONTRACTS = ROOT / 'docs' / 'contracts.md'
HARDWARE_DOC = ROOT / 'docs' / 'hardware.md'
WIRING = ROOT / 'hardware' / 'wiring.csv'
BOM = ROOT / 'hardware' / 'bom.csv'
URDF = ROOT / 'forte_description' / 'urdf' / 'forte_gripper.urdf'


def markdown_rows(text: str) -> list[list[str]]:
    """Cells of every markdown table row (backticks stripped)."""
    rows = []
    for line in text.splitlines():
        line = line.strip()
        if line.startswith('|') and line.endswith('|') and not set(line) <= set('|-: '):
            rows.append([cell.strip().strip('`') for cell in line[1:-1].split('|')])
    return rows


def contract_channels() -> list[tuple[int, str, str, str]]:
    """(index, name, finger, location) rows of the contract's channel table."""
    channels = []
    for cells in markdown_rows(CONTRACTS.read_text()):
        if len(cells) == 4 and cells[0].isdigit():
            finger = cells[2].split()[0]
            location = cells[3].split()[0]
            channels.append((int(cells[0]), cells[1], finger, location))
    return channels


@pytest.fixture(scope='module')
def wiring() -> list[dict]:
    with open(WIRING) as stream:
        return list(csv.DictReader(stream))


def test_wiring_follows_the_contract_channel_order(wiring):
    contract = contract_channels()
    assert [c[0] for c in contract] == list(range(6))
    ours = [(int(r['index']), r['name'], r['finger'], r['location']) for r in wiring]
    assert ours == contract


def test_wiring_uses_adc1_pins_with_the_right_channels(wiring):
    gpios = [row['esp32s3_gpio'] for row in wiring]
    assert len(set(gpios)) == 6
    for row in wiring:
        number = int(re.fullmatch(r'GPIO(\d+)', row['esp32s3_gpio']).group(1))
        # ESP32-S3: ADC1 channel n is GPIO n+1 for n = 0..9 (ESP-IDF soc/adc_channel.h)
        assert 1 <= number <= 10, 'ADC2 pins (GPIO11-20) conflict with Wi-Fi'
        assert row['adc_unit_channel'] == f'ADC1_CH{number - 1}'
        assert row['transducer'] == f"T{int(row['index']) + 1}"


def test_each_transducer_gets_the_inner_channel_on_its_positive_port(wiring):
    names = {channel.name for channel in make_design().channels}
    for row in wiring:
        prefix = f"{row['finger']} finger {row['location']}"
        assert row['positive_port_from'] == f'{prefix}_inner'
        assert row['negative_port_from'] == f'{prefix}_outer'
        for column in ('positive_port_from', 'negative_port_from'):
            assert row[column].split()[-1] in names
    assert sorted({row['location'] for row in wiring}) == sorted(LOCATIONS)


def test_hardware_doc_pin_table_equals_wiring_csv(wiring):
    rows = markdown_rows(HARDWARE_DOC.read_text())
    for row in wiring:
        assert list(row.values()) in rows, f'docs/hardware.md lacks the row for {row["name"]}'


def test_hardware_doc_port_table_equals_the_design():
    rows = {cells[0]: cells[1:] for cells in markdown_rows(HARDWARE_DOC.read_text())
            if len(cells) == 5}
    for port in make_design().port_table():
        stated = rows[port['channel']]
        expected = [port['port_x'], port['port_z'], port['vent_x'], port['vent_z']]
        assert [float(v) for v in stated] == pytest.approx(expected, abs=1e-3)


def test_bom_lists_the_parts_a_lab_needs():
    with open(BOM) as stream:
        bom = list(csv.DictReader(stream))
    assert all(row['estimate'] in ('yes', 'no') for row in bom)
    parts = ' '.join(row['part'] for row in bom)
    quantities = {row['part'].split()[-1]: row['quantity'] for row in bom}
    for needed in ('ELVR-L01D', 'ESP32-S3', 'XM430-W350-T', 'U2D2', 'Sil-Poxy', 'EPU 40',
                   'TPU', 'silicone tube', '12 V'):
        assert needed in parts, needed
    assert quantities['ELVR-L01D-F1RD-C-NA3F'] == '6'
    assert quantities['XM430-W350-T'] == '2'


def test_every_contract_frame_is_in_the_urdf():
    text = CONTRACTS.read_text()
    section = text[text.index('## Frames'):text.index('## Topics')]
    frames = set(re.findall(r'`(forte_\w+)`', section))
    assert len(frames) >= 7
    robot = ET.parse(URDF).getroot()
    names = {e.get('name') for e in robot.findall('link')} | \
            {e.get('name') for e in robot.findall('joint')}
    assert frames <= names, frames - names
