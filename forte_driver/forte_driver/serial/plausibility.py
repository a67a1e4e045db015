"""Is a CRC-valid sample frame one the FORTE firmware can have sent? (pure Python)

A CRC-16 lets about 1 in 65 536 corrupt candidates through; such a frame decodes to
arbitrary fields. The checks here follow how ``firmware/core/forte_device.c`` builds a
scan (docs/firmware.md): :func:`check_sample_alone` judges one frame by itself,
:func:`stream_mismatch` judges whether two frames can belong to one device session.
Used by :class:`forte_driver.serial.stream.StreamAssembler`.
"""
from __future__ import annotations

from forte_driver.serial.protocol import (
    FLAG_OVERRUN,
    FLAG_SATURATED,
    FLAG_SESSION_START,
    OVERRUN_MODULUS,
    SEQUENCE_MODULUS,
    Sample,
)
from forte_ros.contract import COUNTS_PER_FULL_SCALE, N_CHANNELS

#: Flag bits the protocol defines (bit0 saturated, bit1 overrun, bit2 first scan).
DEFINED_FLAGS = FLAG_SATURATED | FLAG_OVERRUN | FLAG_SESSION_START
#: Saturation bits the protocol defines (one per channel).
DEFINED_SATURATION_BITS = (1 << N_CHANNELS) - 1

_HALF_SEQUENCE = SEQUENCE_MODULUS // 2
_TIME_MODULUS = 1 << 64
_HALF_TIME = _TIME_MODULUS // 2
_TIME_MASK = _TIME_MODULUS - 1
_LOW, _HIGH = -COUNTS_PER_FULL_SCALE, COUNTS_PER_FULL_SCALE


def check_sample_alone(sample: Sample) -> str | None:
    """Why a decoded sample cannot have been sent by the firmware, judged on its own.

    Parameters
    ----------
    sample : Sample
        A CRC-valid decoded sample.

    Returns
    -------
    str or None
        The reason, or ``None`` if the frame is plausible on its own.
    """
    values = sample.values
    if len(values) != N_CHANNELS or min(values) < _LOW or max(values) > _HIGH:
        return f'reading out of [-1024, 1024]: {tuple(values)}'
    flags, saturated = sample.flags, sample.saturated
    if flags & ~DEFINED_FLAGS or saturated & ~DEFINED_SATURATION_BITS:
        return f'undefined bits: flags 0x{flags:02x}, saturated 0x{saturated:02x}'
    if bool(flags & FLAG_SATURATED) != bool(saturated):
        return f'saturated flag {flags & FLAG_SATURATED} with channel bits 0x{saturated:02x}'
    if saturated:
        for channel in range(N_CHANNELS):
            if saturated >> channel & 1 and abs(values[channel]) != _HIGH:
                return f'channel {channel} marked clipped at reading {values[channel]}'
    if flags & FLAG_SESSION_START:
        # the first stored scan: every earlier sequence number was a device overrun
        if sample.sequence % OVERRUN_MODULUS != sample.overruns:
            return (f'first-scan flag with sequence {sample.sequence} but '
                    f'{sample.overruns} overruns')
        if sample.sequence < OVERRUN_MODULUS and bool(flags & FLAG_OVERRUN) != bool(
                sample.overruns):
            return 'first-scan flag with an overrun flag that disagrees with the overruns'
    return None


def stream_mismatch(reference: Sample, sample: Sample, sample_period_us: int | None
                    ) -> str | None:
    """Why ``sample`` cannot belong to the same device session as ``reference``.

    Same session: device time differs by exactly (sequence step) x period (modulo 2**64;
    the step is taken modulo 2**32 in [-2**31, 2**31)), the overrun counter grows by at
    most the sequence numbers skipped between the two (mod 2**16), an overrun flag needs
    an overrun since ``reference``, and the first-scan flag cannot follow ``reference``.

    Returns
    -------
    str or None
        The reason, or ``None`` if both frames fit one session.
    """
    step = (sample.sequence - reference.sequence) % SEQUENCE_MODULUS
    if step >= _HALF_SEQUENCE:
        step -= SEQUENCE_MODULUS
    if sample_period_us is not None:
        elapsed = (sample.time_us - reference.time_us) & _TIME_MASK
        if elapsed >= _HALF_TIME:
            elapsed -= _TIME_MODULUS
        if elapsed != step * sample_period_us:
            return (f'device time {elapsed:+d} us for a sequence step of {step:+d} '
                    f'(expected {step * sample_period_us:+d} us)')
    if step > 0:
        earlier, later, skipped = reference, sample, step - 1
        if sample.flags & FLAG_SESSION_START:
            return f'first-scan flag {step} scans after an earlier frame of the session'
    elif step < 0:
        earlier, later, skipped = sample, reference, -step - 1
    else:
        if sample.overruns != reference.overruns:
            return 'repeated sequence number with another overrun count'
        return None
    if skipped < OVERRUN_MODULUS:
        overruns = (later.overruns - earlier.overruns) % OVERRUN_MODULUS
        if overruns > skipped:
            return f'overruns +{overruns} over {skipped} skipped sequence numbers'
        if later.flags & FLAG_OVERRUN and not overruns:
            return 'overrun flag without an overrun'
    return None
