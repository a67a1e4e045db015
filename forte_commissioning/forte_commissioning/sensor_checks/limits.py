"""Thresholds of the commissioning checks, each with its derivation (pure).

1 LSB = 1 count of the sensor board = 1/1024 of the normalised full scale
(:data:`forte_ros.contract.COUNTS_PER_FULL_SCALE`; the 11-bit quantum
:data:`forte_ros.contract.QUANTUM`).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ['DEFAULT_LIMITS', 'CommissioningLimits']


@dataclass(frozen=True)
class CommissioningLimits:
    """Every threshold of the checks.

    Attributes
    ----------
    offset_limit : float
        Largest accepted zero offset (median of the rest phase) [normalised], 0.10 = 102 LSB.
        The ELVR-L01D's zero offset plus the ADC's is a few % of full scale (the simulator
        draws +-0.03); the tare removes an offset but it eats measuring range, and 10 % FS
        only happens with a wrong ADC reference, a transducer under pressure at rest (a
        kinked tube, a finger pressed by its mount) or a damaged transducer.
    noise_limit_lsb : float
        Largest accepted white noise [LSB rms], 3.0: the issue's definition of a noisy
        channel. Measured as the rms of the first differences divided by sqrt(2), leaving
        out differences beyond 6 robust standard deviations (1.4826 x median absolute
        deviation): the differences remove the offset, the drift and the slow (0.2 s)
        noise, the cut the impulses the median-11 filter removes anyway. A healthy channel
        reads about 1.25 LSB (1.2 LSB of ADC and transducer noise, 0.29 LSB of
        quantisation); over the 2 s rest phase (4000
        samples) the estimate's relative standard error is about 2 %, so 3.0 LSB leaves a
        margin of more than 20 standard errors on either side of a healthy channel and of a
        channel with 3 LSB of extra noise (3.25 LSB).
    stuck_limit_lsb : float
        A channel whose readings at rest vary by less than this [LSB rms about their median]
        is stuck, 0.25: a live 11-bit channel always toggles at least its last bit (a healthy
        one shows 1.25 LSB); a constant code is a dead transducer or a disconnected ADC pin.
    rail_fraction : float
        A channel with more than this share of its rest readings at a rail of the range
        (+-1024 counts) is railed, 0.01.
    rate_tolerance : float
        Largest relative deviation of the device's sample rate from the contract's 2 kHz,
        0.002: the board's timer runs from a crystal (+-50 ppm); 0.2 % only fails a wrong
        rate setting or a board that loses timer alarms.
    drop_fraction : float
        Largest share of frames lost (driver's ``dropped``) or rejected (``corrupt``), 0.001:
        a sound USB link loses none; one in a thousand already gaps the perception every
        0.5 s.
    host_rate_fraction : float
        The host must receive at least this share of the device's rows per wall second
        (when the wall time is known), 0.98: the rest is a host that cannot keep up.
    response_min : float
        A channel responds to a press when its mean change is above this [normalised], 0.01
        (10 LSB, the paper's contact threshold of 0.5 % of full scale). A 2-5 N thumb press
        moves the pressed finger's root pair by 0.05-0.15, the distal pair by 0.2-0.4; a
        channel nobody pressed moves by less than 2 LSB (noise averaged over 0.2 s, drift).
    press_min : float
        A press is detected when the largest channel change is above this [normalised],
        0.04 (a 1 N press on the distal pair): else the operator did not press (repeat).
    order_margin : float
        In the tip press a channel must read at least this factor above the next channel
        down the finger, 1.15. The simulated finger gives distal / middle about 2.3 and
        middle / root about 1.8 at the tip (trim spread +-8 %); a swapped pair reverses one
        of the ratios.
    share_shift_min : float
        Moving the press from the tip to the root must raise the root pair's share of the
        finger's response and lower the distal pair's by at least this [-], 0.03 (the
        simulated finger: +0.12 and -0.19).
    leak_settle : float
        The squeeze's start level is taken this long after the close command [s], 2.0: the
        servo closes on the indentor in about 0.5 s.
    leak_window : float
        Length of the windows whose median gives a level [s], 0.5.
    leak_level_min : float
        A channel must carry at least this level in the squeeze to be judged [normalised],
        0.01 (10 LSB): below that its decay is lost in the noise (a dead channel).
    leak_retained_min : float
        A channel that keeps less than this share of its level over the hold, relative to
        the other loaded channels' median share, leaks, 0.75. The fin-ray's stress
        relaxation (18 % of the force, time constants 1.5 s and 15 s) and the temperature
        of the squeezed indentor move all channels of the fingers together (under a current
        limit the servo creeps closed as the finger relaxes: the levels rise by up to 8 %);
        relative to each other the channels of a healthy gripper stay within 3 %. A leak
        with time constant tau keeps exp(-T / tau) of its level over a hold of T: with a
        10 s hold it is found up to tau = 30 s.
    leak_continuing_max : float
        ...and which over the second half of the hold still keeps less than this share,
        relative to the others, 0.92: a leak keeps decaying (exp(-T / 2 tau)), a
        relaxation levels off.
    """

    offset_limit: float = 0.10
    noise_limit_lsb: float = 3.0
    stuck_limit_lsb: float = 0.25
    rail_fraction: float = 0.01
    rate_tolerance: float = 0.002
    drop_fraction: float = 0.001
    host_rate_fraction: float = 0.98
    response_min: float = 0.01
    press_min: float = 0.04
    order_margin: float = 1.15
    share_shift_min: float = 0.03
    leak_settle: float = 2.0
    leak_window: float = 0.5
    leak_level_min: float = 0.01
    leak_retained_min: float = 0.75
    leak_continuing_max: float = 0.92


#: The thresholds documented above.
DEFAULT_LIMITS = CommissioningLimits()
