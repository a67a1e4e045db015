"""Safety checks of the grasp state machine, run on every step before anything moves.

Freshness of the perception and joint state, validity of the perception data, the servo's
hardware error, the lift cap, the whole-grasp timeout and the force cap. The machine acts on
the verdict (:class:`SafetyVerdict`): a fault stops the arm, holds the gripper at its
current command and latches until a reset, which :func:`persisting_conditions` refuses while
the condition persists. Pure Python, no rclpy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from forte_control.state_machine.controller_params import ControllerParams
from forte_control.state_machine.progress import GraspProgress, LatestInputs
from forte_control.state_machine.types import (
    Controller,
    FaultFlag,
    GraspState,
    Outcome,
    PerceptionInput,
)

__all__ = ['SafetyStop', 'SafetyVerdict', 'check_step', 'check_time', 'flag_names', 'fresh',
           'persisting_conditions', 'stale_flags']


def fresh(stamp: float, now: float, bound: float) -> bool:
    """True when ``stamp`` is finite and no older than ``bound`` seconds at ``now``."""
    return math.isfinite(stamp) and now - stamp <= bound


def check_time(now: float) -> None:
    """Raise ``ValueError`` unless ``now`` is a finite time in seconds."""
    if not isinstance(now, (int, float)) or not math.isfinite(now):
        raise ValueError(f'now must be a finite time in seconds, got {now!r}')


def flag_names(flags: FaultFlag) -> str:
    """The names of the set flags, ``'|'``-separated (``'NONE'`` when none is set)."""
    names = [flag.name for flag in FaultFlag if flag and flag in flags]
    return '|'.join(names) if names else 'NONE'


def stale_flags(latest: LatestInputs, now: float, params: ControllerParams,
                controller: Controller) -> FaultFlag:
    """STALE_* flags of the inputs at ``now`` (the perception only matters with sensing)."""
    flags = FaultFlag.NONE
    joint = latest.joint
    if joint is None or not fresh(joint.stamp, now, params.joint_state_timeout) \
            or not math.isfinite(joint.theta):
        flags |= FaultFlag.STALE_JOINT_STATE
    if controller != Controller.ON_OFF:
        perception = latest.perception
        if perception is None or not fresh(perception.stamp, now, params.perception_timeout):
            flags |= FaultFlag.STALE_PERCEPTION
    return flags


def persisting_conditions(latest: LatestInputs, now: float, node_params: ControllerParams,
                          force_params: ControllerParams, controller: Controller
                          ) -> FaultFlag:
    """Fault conditions that still hold at ``now`` (a fault reset is refused while any does).

    Parameters
    ----------
    latest : LatestInputs
    now : float
        Current time [s].
    node_params : ControllerParams
        The node's parameters, for the freshness bounds.
    force_params : ControllerParams
        The parameters of the faulted grasp (the node's without one), for the force cap.
    controller : Controller
        Controller of the last grasp (ON_OFF needs no perception).
    """
    flags = stale_flags(latest, now, node_params, controller)
    perception = latest.perception
    if perception is not None and perception.force_valid \
            and perception.force > force_params.max_force and controller != Controller.ON_OFF:
        flags |= FaultFlag.FORCE_LIMIT
    if (controller != Controller.ON_OFF and perception is not None
            and not perception.data_valid):
        flags |= FaultFlag.INVALID_INPUT
    joint = latest.joint
    if joint is not None and joint.servo_error:
        flags |= FaultFlag.SERVO
    return flags


class SafetyStop(Enum):
    """What a step must do instead of advancing its phase."""

    FAULT = 'fault'            # latch a fault (flags, outcome, message)
    TIMEOUT = 'timeout'        # end the grasp with outcome TIMEOUT
    OVER_FORCE = 'over force'  # force above the cap, not confirmed yet: hold, never tighten


@dataclass(frozen=True)
class SafetyVerdict:
    """Outcome of the safety checks of one step.

    ``stop`` is ``None`` when the phase may advance; ``perception_valid`` then says whether
    the perception may be acted on in this step.
    """

    stop: SafetyStop | None = None
    perception_valid: bool = False
    flags: FaultFlag = FaultFlag.NONE
    outcome: Outcome = Outcome.FAULT
    message: str = ''


def _fault(flags: FaultFlag, message: str, outcome: Outcome = Outcome.FAULT) -> SafetyVerdict:
    return SafetyVerdict(SafetyStop.FAULT, flags=flags, outcome=outcome, message=message)


def check_step(grasp: GraspProgress, latest: LatestInputs, state: GraspState,
               controller: Controller, now: float) -> SafetyVerdict:
    """The safety checks of one step of an active grasp, in order of precedence.

    Updates ``grasp.over_force_since`` (the force cap must be exceeded for
    ``force_limit_confirm`` before it faults). ON_OFF needs no perception: it is only judged
    (fresh and valid) for the outcome, and no force cap applies.
    """
    p = grasp.params
    stale = stale_flags(latest, now, p, controller)
    if stale:
        return _fault(stale, 'data older than the freshness bound: arm stopped, gripper held')
    joint = latest.joint
    assert joint is not None
    if joint.servo_error:
        return _fault(FaultFlag.SERVO, 'servo hardware error')
    if grasp.lift_height > p.max_lift_distance + 1e-9:
        return _fault(FaultFlag.LIFT_LIMIT, f'lift {grasp.lift_height:.4f} m above the cap '
                      f'{p.max_lift_distance} m')
    if state != GraspState.RELEASING and now - grasp.start_time > p.timeout:
        return SafetyVerdict(SafetyStop.TIMEOUT, outcome=Outcome.TIMEOUT,
                             message=f'timeout after {p.timeout:g} s in {state.name}')
    perception = latest.perception
    if controller == Controller.ON_OFF:
        return SafetyVerdict(perception_valid=(
            perception is not None and perception.data_valid
            and fresh(perception.stamp, now, p.perception_timeout)))
    assert perception is not None
    if not perception.data_valid and latest.invalid_since is not None \
            and now - latest.invalid_since > p.invalid_input_timeout:
        return _fault(FaultFlag.INVALID_INPUT, 'perception data invalid for more than '
                      f'{p.invalid_input_timeout:g} s')
    if perception.data_valid and perception.force_valid and perception.force > p.max_force:
        return _over_force(grasp, perception, now)
    grasp.over_force_since = None
    return SafetyVerdict(perception_valid=perception.data_valid)


def _over_force(grasp: GraspProgress, perception: PerceptionInput, now: float
                ) -> SafetyVerdict:
    """Force above the cap: FORCE_LIMIT once it lasted ``force_limit_confirm``, else hold."""
    p = grasp.params
    if grasp.over_force_since is None:
        grasp.over_force_since = now
    if now - grasp.over_force_since >= p.force_limit_confirm:
        return _fault(FaultFlag.FORCE_LIMIT, f'force {perception.force:.3f} N above the cap '
                      f'{p.max_force:g} N for {p.force_limit_confirm:g} s',
                      outcome=Outcome.FORCE_LIMIT)
    # not confirmed yet (a single estimate can spike): never tighten meanwhile
    return SafetyVerdict(SafetyStop.OVER_FORCE,
                         message=f'force {perception.force:.3f} N above the cap, holding')
