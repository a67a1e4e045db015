"""forte_ros.sensor_identity: refusals (rate, channel order, full scale) and warnings
(another board, another firmware) of a model's training sensor against the live sensor."""
from __future__ import annotations

import json

import pytest

from forte_ros.contract import CHANNEL_NAMES
from forte_ros.sensor_identity import SIMULATED_SENSOR, SensorIdentity, check_identity

BOARD = SensorIdentity(source='serial', device_id='00000000c0ffee01', firmware='1.0.0',
                       protocol_version=1, adc_bits=12)


def test_identity_round_trips_through_json():
    text = json.dumps(BOARD.to_dict())
    assert SensorIdentity.from_dict(json.loads(text)) == BOARD


def test_from_dict_ignores_unknown_keys_and_refuses_a_missing_device():
    values = dict(BOARD.to_dict(), written_by='a newer FORTE')
    assert SensorIdentity.from_dict(values) == BOARD
    with pytest.raises(ValueError, match='device_id'):
        SensorIdentity.from_dict({'source': 'serial'})
    with pytest.raises(ValueError, match='sensor identity'):
        SensorIdentity.from_dict(dict(BOARD.to_dict(), sample_rate='fast'))


def test_the_same_sensor_passes_silently():
    check = check_identity(BOARD.to_dict(), BOARD)
    assert check.usable and check.warnings == ()


def test_a_dataset_without_identity_is_compared_on_rate_and_channels_only():
    check = check_identity({'sample_rate': 2000.0, 'channel_names': list(CHANNEL_NAMES)}, BOARD)
    assert check.usable and check.warnings == ()


@pytest.mark.parametrize('change, words', [
    ({'sample_rate': 1000.0}, '1000 Hz'),
    ({'channel_names': list(CHANNEL_NAMES[3:] + CHANNEL_NAMES[:3])}, 'channel order'),
    ({'counts_per_full_scale': 2048}, '2048 counts'),
])
def test_rate_channel_order_and_full_scale_refuse_the_model(change, words):
    check = check_identity(dict(BOARD.to_dict(), **change), BOARD)
    assert not check.usable
    assert len(check.refusals) == 1 and words in check.refusals[0]


def test_a_rate_within_the_tolerance_is_the_same_rate():
    assert check_identity({'sample_rate': 2000.0 * (1 + 1e-9)}, BOARD).usable


def test_another_board_or_firmware_warns_but_keeps_the_model():
    check = check_identity(SIMULATED_SENSOR.to_dict(), BOARD)
    assert check.usable
    assert any('simulator' in text and BOARD.device_id in text for text in check.warnings)
    other_firmware = dict(BOARD.to_dict(), firmware='0.9.0')
    check = check_identity(other_firmware, BOARD)
    assert check.usable and check.warnings == (
        'model trained with firmware 0.9.0, sensor runs 1.0.0',)


def test_an_unknown_live_device_is_not_a_different_device():
    unknown = SensorIdentity(source='replay', device_id='')
    assert check_identity(BOARD.to_dict(), unknown).warnings == ()
