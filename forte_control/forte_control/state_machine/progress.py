"""Bookkeeping of the state machine: the grasp in progress and the latest inputs (no rclpy)."""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from forte_control.state_machine.controller_params import ControllerParams
from forte_control.state_machine.drop_detector import DropDetector
from forte_control.state_machine.lift_check import (
    LiftCheckParams,
    LiftMonitor,
    OpenGripperLevels,
    WrenchInput,
)
from forte_control.state_machine.types import (
    ControlInputs,
    GraspGoal,
    JointInput,
    Outcome,
    PerceptionInput,
)

__all__ = ['GraspProgress', 'LatestInputs', 'RampCommands']


class RampCommands:
    """The ramp commands issued so far, to look up the one in force at a sensor time.

    Entries older than the last lookup's stamp are pruned, so the record holds only what
    the perception has not yet seen (a few steps, or the steps of its delay).
    """

    def __init__(self) -> None:
        self._entries: deque[tuple[float, float]] = deque()  # (time [s], command [rad])

    def record(self, time: float, command: float) -> None:
        """Remember that ``command`` [rad] was issued at ``time`` [s]."""
        self._entries.append((time, command))

    def at(self, stamp: float, default: float) -> float:
        """The command in force at ``stamp`` [s]: the last one issued at or before it; the
        first one recorded for an earlier stamp (the ramp starts where the gripper is);
        ``default`` when nothing was recorded [rad]."""
        entries = self._entries
        while len(entries) > 1 and entries[1][0] <= stamp:
            entries.popleft()
        return entries[0][1] if entries else default


@dataclass
class GraspProgress:
    """Bookkeeping of the grasp in progress."""

    goal: GraspGoal
    params: ControllerParams           # effective parameters (node params + goal overrides)
    lift_check: LiftCheckParams        # lift verification thresholds when the goal started
    start_time: float
    phase_start: float
    ramp_start_angle: float = 0.0      # command at the start of the current ramp [rad]
    ramp_commands: RampCommands = field(default_factory=RampCommands)  # for ramp_lead
    contact_force: float | None = None
    target_force: float = 0.0
    balancing_from: float | None = None  # command that first reached the target [rad]
    force_invalid_since: float | None = None
    over_force_since: float | None = None
    at_min_since: float | None = None
    last_tightening_time: float = -math.inf
    last_slip_stamp: float = -math.inf
    slipping_stamp: float | None = None  # stamp of the last perception seen slipping [s]
    last_slipping_stamp: float = -math.inf  # ... never reset by a state that was not [s]
    slip_duration: float = 0.0         # time perception reported slipping [s]
    drop: DropDetector | None = None
    lift: LiftMonitor | None = None
    open_levels: OpenGripperLevels | None = None  # the lift check's zero, from the open gripper
    lift_target: float = 0.0           # lift_distance, plus the set-down probe if any [m]
    grip_change_lift: float = 0.0      # commanded lift at the last tightening (0: none) [m]
    recheck_lift: float = 0.0          # lift the contact's place must be judged up to [m]
    probe_phase: str = ''              # '', 'down' (lowering), 'settle', 'up' (to probe again)
    probe_since: float = 0.0           # start of the probe's settle [s]
    probe_began: float = 0.0           # start of the current probe [s]
    probes: int = 0                    # set-down probes begun [count]
    free_current: float | None = None  # lowest servo current while closing [A]
    slip_events: int = 0
    gross_slip_events: int = 0         # tightenings on the lift monitor's gross-slip evidence
    regrip: bool = False               # arm waits: the contact slides off, tightening
    tightening: float = 0.0
    lift_height: float = 0.0
    outcome: Outcome = Outcome.NONE

    def levels_zero(self) -> tuple[float, float]:
        """The finger levels that read as unloaded: the open gripper's, (0, 0) without them."""
        return self.open_levels.zero() if self.open_levels is not None else (0.0, 0.0)


@dataclass
class LatestInputs:
    """The newest input of each kind received so far (``None`` = never received)."""

    perception: PerceptionInput | None = None
    joint: JointInput | None = None
    wrench: WrenchInput | None = None
    invalid_since: float | None = None  # perception data_valid false since [s]

    def remember(self, inputs: ControlInputs, now: float) -> None:
        """Keep the inputs given (``None`` fields leave the previous ones) at time ``now``."""
        if inputs.perception is not None:
            self.perception = inputs.perception
            if inputs.perception.data_valid:
                self.invalid_since = None
            elif self.invalid_since is None:
                self.invalid_since = now
        if inputs.joint is not None:
            self.joint = inputs.joint
        if inputs.wrench is not None:
            self.wrench = inputs.wrench
