"""The grasp controller's configuration: :class:`ControllerParams` and a goal's overrides.

The defaults (the paper's values) are the dataclass fields; the ranges and choices of every
field are the table of :mod:`forte_control.parameters` (also the node's parameter
descriptors), checked here through :func:`forte_control.parameters.range_problems`. Pure
Python, no rclpy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from forte_control.parameters import range_problems
from forte_control.state_machine.types import PAPER_SLIP_INCREMENT, Controller, GraspGoal

__all__ = ['GOAL_OVERRIDES', 'ControllerParams', 'grasp_params']


@dataclass(frozen=True)
class ControllerParams:
    """Configuration of the grasp controller (node parameters; a goal may override some).

    Angles in rad (paper convention: 0 = fully closed, closing decreases theta), forces in
    N, distances in m, speeds in rad/s or m/s, times in s, current in A.
    """

    # closing and contact
    closing_speed: float = 0.25             # servo command ramp while closing [rad/s]
    contact_mode: str = 'either'            # 'either' finger (paper: any channel) or 'both'
    contact_level: float = 0.005            # or mean |tared filtered| this high (0: off) [-]
    min_angle: float = 0.0                  # most closed command allowed [rad]
    max_angle: float = 1.0                  # most open command allowed: the joint limit [rad]
    no_contact_settle: float = 0.3          # wait at min_angle before NO_CONTACT [s]
    ramp_lead: float = 0.05                 # closing/loading ramp ahead of perception, max [s]
    # loading
    loading_speed: float = 0.05             # servo command ramp while loading [rad/s]
    initial_force: float = 0.25             # f_init [N]
    initial_force_mode: str = 'relative'    # 'relative' (above force at contact) | 'absolute'
    invalid_force_timeout: float = 0.5      # longest wait for a valid force in LOADING [s]
    min_finger_share: float = 0.33          # FORTE loads on while the weaker finger's level
    #                                         is below this x the stronger's (0: off) [-]
    max_balancing_closing: float = 0.1      # ... at most this far past the target [rad]
    # lifting
    lift_speed: float = 0.005               # arm lift speed [m/s]
    lift_distance: float = 0.03             # lift height that counts as success [m]
    hold_duration: float = 1.0              # HOLDING time before the outcome LIFTED [s]
    # slip reaction (FORTE controller)
    slip_increment: float = PAPER_SLIP_INCREMENT   # tightening per slip event [rad]
    slip_refractory: float = 0.05           # min time between two tightenings [s]
    slip_speed: float = 1.0                 # servo profile velocity for tightening [rad/s]
    slipping_interval: float = 0.2          # re-tighten while slipping persists (0: off) [s]
    slip_reaction: str = 'sliding'          # 'events' (the paper's) or 'sliding' (+ state)
    # drop detection (LIFTING / HOLDING)
    drop_force_fraction: float = 0.3        # drop when force < fraction * reference force
    drop_min_reference_force: float = 0.1   # force detector armed only above this [N]
    drop_level_fraction: float = 0.3        # drop when deformation level < fraction * ref
    drop_min_reference_level: float = 0.01  # level detector armed only above this [-1..1]
    drop_on_contact_loss: bool = False      # also drop when both contact flags are false
    drop_confirm_time: float = 0.1          # condition must persist this long [s]
    # on-off controller
    on_off_closing_speed: float = 0.25      # constant closing speed of ON_OFF [rad/s]
    on_off_settle: float = 0.5              # wait at theta=0 before lifting [s]
    # release
    open_angle: float = 1.0                 # command when releasing [rad]
    release_speed: float = 0.5              # servo speed when releasing [rad/s]
    release_tolerance: float = 0.02         # joint angle tolerance to finish releasing [rad]
    release_timeout: float = 3.0            # longest RELEASING [s]
    # safety
    max_force: float = 8.0                  # force cap [N] (top of the force model range)
    force_limit_confirm: float = 0.03       # force above the cap this long -> fault [s]
    max_tightening: float = 20 * PAPER_SLIP_INCREMENT  # cap on total slip tightening [rad]
    max_lift_distance: float = 0.2          # lift cap [m]
    max_lift_speed: float = 0.02            # largest lift speed a goal may ask [m/s]
    perception_timeout: float = 0.1         # perception freshness bound [s]
    joint_state_timeout: float = 0.2        # joint state freshness bound [s]
    invalid_input_timeout: float = 0.2     # data_valid false this long -> fault [s]
    timeout: float = 60.0                   # whole-grasp timeout [s]
    max_current: float = 1.0                # servo current limit sent with commands [A]

    def problems(self) -> list[str]:
        """Reasons why these parameters are unsafe or inconsistent (empty when valid).

        Ranges and choices come from :data:`forte_control.parameters.CONTROLLER_PARAMETERS`
        (inclusive bounds, the same as the node's parameter descriptors); a value outside
        is reported as ``'<name>=<value> outside [<low>, <high>] <unit>'``. Relations
        between parameters are checked only when every value is in its range.
        """
        out: list[str] = []
        for item in fields(self):
            value = getattr(self, item.name)
            if isinstance(value, float) and not math.isfinite(value):
                out.append(f'{item.name} must be finite, got {value}')
        if out:
            return out

        # ranges and choices: the table of forte_control.parameters (the node's descriptors)
        out.extend(range_problems({item.name: getattr(self, item.name) for item in fields(self)}))
        if out:
            return out
        if self.initial_force >= self.max_force:
            out.append(f'initial_force={self.initial_force} N must be below '
                       f'max_force={self.max_force} N')
        if self.lift_speed > self.max_lift_speed:
            out.append(f'lift_speed={self.lift_speed} m/s above max_lift_speed='
                       f'{self.max_lift_speed} m/s')
        if self.lift_distance > self.max_lift_distance:
            out.append(f'lift_distance={self.lift_distance} m above max_lift_distance='
                       f'{self.max_lift_distance} m')
        if self.slip_increment > self.max_tightening and self.max_tightening > 0.0:
            out.append(f'slip_increment={self.slip_increment} rad above max_tightening='
                       f'{self.max_tightening} rad')
        if self.min_angle >= self.open_angle:
            out.append(f'min_angle={self.min_angle} rad must be below open_angle='
                       f'{self.open_angle} rad')
        if self.open_angle > self.max_angle:
            out.append(f'open_angle={self.open_angle} rad above max_angle={self.max_angle} '
                       'rad (the joint limit)')
        return out

    def validated(self) -> ControllerParams:
        """Return ``self`` if valid, else raise ``ValueError`` listing every problem."""
        problems = self.problems()
        if problems:
            raise ValueError('unsafe controller parameters: ' + '; '.join(problems))
        return self


#: Goal fields that, when non-zero, replace the node parameter of the same name.
GOAL_OVERRIDES = ('initial_force', 'lift_speed', 'lift_distance', 'slip_increment',
                  'max_tightening', 'max_force', 'timeout')

#: Goal fields a goal may only set within a node cap: (goal field, cap field, unit, cap
#: as named in the refusal).
_GOAL_CAPS = (('max_force', 'max_force', 'N', 'the node cap'),
              ('max_tightening', 'max_tightening', 'rad', 'the node cap'),
              ('lift_distance', 'max_lift_distance', 'm', 'the lift cap'),
              ('lift_speed', 'max_lift_speed', 'm/s', 'max_lift_speed'))


def grasp_params(node_params: ControllerParams, goal: GraspGoal
                 ) -> tuple[ControllerParams | None, str]:
    """Parameters of a grasp: node parameters with the goal's non-zero overrides.

    Goal caps may only be tighter than the node caps.

    Parameters
    ----------
    node_params : ControllerParams
        The node's (valid) parameters.
    goal : GraspGoal
        The request; its numbers must be finite and >= 0 (0 = the node's value).

    Returns
    -------
    tuple
        ``(params, 'ok')``, or ``(None, reason)`` if the goal is refused.
    """
    problems = [f'goal {name}={getattr(goal, name)} must be finite and >= 0 (0 = default)'
                for name in GOAL_OVERRIDES
                if not math.isfinite(getattr(goal, name)) or getattr(goal, name) < 0.0]
    if problems:
        return None, '; '.join(problems)
    try:
        Controller(int(goal.controller))
    except ValueError:
        return None, f'unknown controller {goal.controller}'
    for name, cap_name, unit, cap_text in _GOAL_CAPS:
        value, cap = getattr(goal, name), getattr(node_params, cap_name)
        if value > cap:
            problems.append(f'goal {name}={value} {unit} above {cap_text} {cap} {unit}')
    if problems:
        return None, '; '.join(problems)
    overrides = {name: getattr(goal, name) for name in GOAL_OVERRIDES if getattr(goal, name) > 0.0}
    params = replace(node_params, **overrides)
    problems = params.problems()
    if problems:
        return None, 'goal refused: ' + '; '.join(problems)
    return params, 'ok'
