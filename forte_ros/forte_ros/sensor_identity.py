"""What a force model was trained on against the sensor it runs on (pure Python).

A force model maps six raw pressure readings to a force. It is only meaningful for readings
that mean the same as the ones it was trained on: the same sample rate (the history
features are windows of a fixed number of samples), the same channel order (the SVR's
inputs are positional) and the same full scale (a reading of 1.0 is
``counts_per_full_scale`` ADC counts). Those three are *refusals*: a model that differs in
any of them is not used. A different board (``device_id``) or firmware reads the same units
but has its own transducers, tubing and offsets: the model still works, less accurately,
so that is a *warning* (recalibrate).

:class:`SensorIdentity` is the identity of a sensor as the serial board reports it in its
answer to IDENTIFY (docs/firmware.md), or of the simulator's stand-in
(:data:`SIMULATED_SENSOR`); it travels as forte_msgs/SensorInfo on ``tactile/sensor_info``
(whose fields are this class's fields: ``SensorInfo(header=..., **identity.to_dict())``
builds the message, :meth:`SensorIdentity.from_message` reads it back),
as the calibration dataset's ``sensor_identity`` key (JSON) and as the force model's
``metadata['sensor']``.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

from forte_ros.contract import CHANNEL_NAMES, COUNTS_PER_FULL_SCALE, SAMPLE_RATE

#: The simulator's ADC resolution: 11-bit readings (+-1024 counts) [bit].
SIMULATED_ADC_BITS = 11
#: Relative sample-rate difference that counts as a different rate [-].
RATE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class SensorIdentity:
    """Identity of a tactile sensor.

    Attributes
    ----------
    source : str
        ``'serial'``, ``'sim'`` or ``'replay'`` (forte_msgs/SensorInfo SOURCE_*).
    device_id : str
        Board id, 16 hex digits; ``'simulator'`` for the simulator; ``''`` when unknown.
    firmware : str
        Firmware version ``'major.minor.patch'``; ``''`` when unknown.
    protocol_version : int
        Serial protocol version; 0 when not serial.
    sample_rate : float
        Scans per second [Hz].
    channel_names : tuple of str, length 6
        Channel order of the frames.
    counts_per_full_scale : int
        ADC counts of a normalised reading of 1.0 [counts].
    adc_bits : int
        ADC resolution [bit].
    """

    source: str
    device_id: str
    firmware: str = ''
    protocol_version: int = 0
    sample_rate: float = SAMPLE_RATE
    channel_names: tuple[str, ...] = CHANNEL_NAMES
    counts_per_full_scale: int = COUNTS_PER_FULL_SCALE
    adc_bits: int = SIMULATED_ADC_BITS

    def to_dict(self) -> dict:
        """JSON-serialisable form (``channel_names`` as a list)."""
        values = asdict(self)
        values['channel_names'] = list(self.channel_names)
        return values

    @classmethod
    def from_message(cls, message: object) -> SensorIdentity:
        """Identity of a forte_msgs/SensorInfo message (its fields are this class's)."""
        return cls.from_dict({field.name: getattr(message, field.name) for field in fields(cls)})

    @classmethod
    def from_dict(cls, values: dict) -> SensorIdentity:
        """Identity from :meth:`to_dict`'s form; unknown keys are ignored.

        Raises
        ------
        ValueError
            ``source`` or ``device_id`` is missing, or a value has the wrong kind.
        """
        known = {field.name for field in fields(cls)}
        missing = {'source', 'device_id'} - set(values)
        if missing:
            raise ValueError(f'sensor identity lacks {", ".join(sorted(missing))}')
        kept = {key: value for key, value in values.items() if key in known}
        try:
            if 'channel_names' in kept:
                kept['channel_names'] = tuple(str(name) for name in kept['channel_names'])
            for key in ('protocol_version', 'counts_per_full_scale', 'adc_bits'):
                if key in kept:
                    kept[key] = int(kept[key])
            if 'sample_rate' in kept:
                kept['sample_rate'] = float(kept['sample_rate'])
        except (TypeError, ValueError) as exc:
            raise ValueError(f'sensor identity: {exc}') from exc
        return cls(**kept)


#: The simulator's sensor (``forte_sim``: scenes, sim_node, forte_sim_dataset).
SIMULATED_SENSOR = SensorIdentity(source='sim', device_id='simulator')


@dataclass(frozen=True)
class IdentityCheck:
    """Verdict of :func:`check_identity`.

    Attributes
    ----------
    refusals : tuple of str
        Reasons the model must not be used (empty: usable).
    warnings : tuple of str
        Differences that leave the model usable but less accurate.
    """

    refusals: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    @property
    def usable(self) -> bool:
        """True when nothing refuses the model."""
        return not self.refusals


def check_identity(trained: dict, sensor: SensorIdentity) -> IdentityCheck:
    """Compare what a model was trained on with the sensor it is to run on.

    Parameters
    ----------
    trained : dict
        The model's ``metadata['sensor']``: at least ``sample_rate`` and ``channel_names``
        (every calibration dataset has them); ``counts_per_full_scale``, ``device_id`` and
        ``firmware`` when the dataset recorded a sensor identity. A key that is absent is
        not compared.
    sensor : SensorIdentity
        The sensor (or, before it identified itself, what the node expects of it).

    Returns
    -------
    IdentityCheck
        Refusals: sample rate, channel order or full scale differ. Warnings: another
        board (``device_id``) or firmware.
    """
    refusals: list[str] = []
    warnings: list[str] = []
    rate = trained.get('sample_rate')
    if rate is not None and not math.isclose(float(rate), sensor.sample_rate,
                                             rel_tol=RATE_TOLERANCE):
        refusals.append(f'model trained at {float(rate):g} Hz, sensor runs at '
                        f'{sensor.sample_rate:g} Hz')
    names = trained.get('channel_names')
    if names is not None and tuple(names) != tuple(sensor.channel_names):
        refusals.append(f'model channel order {list(names)} differs from the sensor\'s '
                        f'{list(sensor.channel_names)}')
    scale = trained.get('counts_per_full_scale')
    if scale is not None and int(scale) != sensor.counts_per_full_scale:
        refusals.append(f'model trained on {int(scale)} counts per full scale, sensor has '
                        f'{sensor.counts_per_full_scale}')
    device = trained.get('device_id')
    if device and sensor.device_id and device != sensor.device_id:
        warnings.append(f'model trained on device {device}, sensor is {sensor.device_id}: '
                        'recalibrate this gripper (docs/commissioning.md)')
    firmware = trained.get('firmware')
    if firmware and sensor.firmware and firmware != sensor.firmware:
        warnings.append(f'model trained with firmware {firmware}, sensor runs {sensor.firmware}')
    return IdentityCheck(tuple(refusals), tuple(warnings))


__all__ = ['RATE_TOLERANCE', 'SIMULATED_ADC_BITS', 'SIMULATED_SENSOR', 'IdentityCheck',
           'SensorIdentity', 'check_identity']
