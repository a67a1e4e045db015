"""Sensor commissioning of a freshly assembled FORTE gripper, pure (no rclpy).

A lab runs it once on a new or repaired gripper: the procedure (``forte_commission``,
:mod:`forte_commissioning.ros.commission_node`) records the raw readings of a fixed protocol
and this package judges them:

- :mod:`.run_record`: what the procedure recorded (readings with their sequence numbers,
  the phases of the protocol, the link counters of the driver); saved as ``.npz``;
- :mod:`.limits`: every threshold, with its derivation;
- :mod:`.idle`: per channel offset, noise [LSB rms], stuck, railed, from the rest phase;
  sample rate and drops from the link counters;
- :mod:`.press`: the guided press test (one finger at a time, tip then root): each channel
  responds, with a positive sign, to its own finger only, in the distal / middle / root
  order of docs/contracts.md;
- :mod:`.leak`: the held squeeze: a sealed channel keeps its level (the fin-ray's stress
  relaxation moves a finger's channels together and levels off), a leaking one decays
  toward its offset;
- :mod:`.diagnosis`: every check's verdict and the findings (what is wrong, which channel,
  the fix); :mod:`.report`: the text report.

Channel order, finger groups and the value scale come from :mod:`forte_ros.contract`.
"""
from forte_commissioning.sensor_checks.diagnosis import CommissioningResult, evaluate
from forte_commissioning.sensor_checks.limits import DEFAULT_LIMITS, CommissioningLimits
from forte_commissioning.sensor_checks.report import text_report
from forte_commissioning.sensor_checks.run_record import (
    CommissioningRecording,
    LinkStatistics,
    Phase,
)

__all__ = ['DEFAULT_LIMITS', 'CommissioningLimits', 'CommissioningRecording', 'CommissioningResult',
           'LinkStatistics', 'Phase', 'evaluate', 'text_report']
