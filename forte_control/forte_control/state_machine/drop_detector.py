"""Has the held object gone? The drop detector of the grasp state machine (no rclpy).

While LIFTING and HOLDING the force estimate and the fingers' deformation are compared with
their largest values since the lift began; a fall below a fraction of either, held for
``drop_confirm_time``, is a drop (docs/control.md). It cannot see an object that never left
the table: that is :mod:`.lift_check`'s question.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from forte_control.state_machine.controller_params import ControllerParams
from forte_control.state_machine.lift_check import deformation_level
from forte_control.state_machine.types import PerceptionInput

__all__ = ['DropDetector']


@dataclass
class DropDetector:
    """Detect a drop from the sensors during LIFTING / HOLDING.

    Two signals are compared with a reference taken while the object is held (the maximum
    seen since the lift started): the estimated force (when valid) and the deformation level
    (mean absolute tared filtered value over the 6 channels, when given). A drop is declared
    when either signal stays below its fraction of the reference for ``confirm_time``;
    optionally also when both contact flags are false for that long. A detector is armed only
    when its reference exceeds a minimum, so noise on an empty gripper never "drops".
    """

    params: ControllerParams   # drop_* fields
    reference_force: float = 0.0
    reference_level: float = 0.0
    low_since: float | None = None
    reason: str = ''

    def update(self, perception: PerceptionInput, now: float) -> bool:
        """Feed one fresh, valid perception sample; return True once a drop is confirmed."""
        p = self.params
        reasons = []
        if perception.force_valid and math.isfinite(perception.force):
            self.reference_force = max(self.reference_force, perception.force)
            if (self.reference_force >= p.drop_min_reference_force
                    and perception.force < p.drop_force_fraction * self.reference_force):
                reasons.append(f'force {perception.force:.3f} N < {p.drop_force_fraction:g} x '
                               f'{self.reference_force:.3f} N')
        level = deformation_level(perception.filtered)
        if level is not None:
            self.reference_level = max(self.reference_level, level)
            if (self.reference_level >= p.drop_min_reference_level
                    and level < p.drop_level_fraction * self.reference_level):
                reasons.append(f'deformation {level:.4f} < {p.drop_level_fraction:g} x '
                               f'{self.reference_level:.4f}')
        if p.drop_on_contact_loss and not any(perception.contact):
            reasons.append('contact lost on both fingers')
        if not reasons:
            self.low_since = None
            return False
        if self.low_since is None:
            self.low_since = now
        self.reason = '; '.join(reasons)
        return now - self.low_since >= p.drop_confirm_time
