"""Every grasp controller parameter in one table: type, unit, range and description.

The table is the single source of what a parameter means and which values it may take:

- :meth:`forte_control.state_machine.ControllerParams.problems` checks the ranges and
  choices of :data:`CONTROLLER_PARAMETERS` (through :func:`range_problems`);
- the node ``grasp_controller`` builds its ``ParameterDescriptor`` objects (description,
  ``FloatingPointRange`` / ``IntegerRange``, allowed choices) from the same entries
  (:mod:`forte_control.ros.node_parameters`), so ``ros2 param describe`` shows exactly the range
  the state machine enforces.

Bounds are inclusive at both ends, as ``FloatingPointRange`` is. A quantity that must be
strictly positive (a speed, a timeout, a cap) has a small positive minimum instead of an open
bound at zero, so the descriptor can say it.

The entries are :class:`forte_ros.parameter_table.ParameterSpec`, the shape every FORTE
node's table has. The defaults of the state machine's parameters stay in
:class:`ControllerParams` and :class:`LiftCheckParams` (the paper's values, documented
there; each entry's ``field`` names its field); the node-only parameters carry their
default here. This module is pure Python (no rclpy), like the state machine.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import replace
from typing import Any

from forte_ros.contract import BASE_FRAME, JOINT_NAMES
from forte_ros.parameter_table import ParameterSpec, parameter_table
from forte_ros.parameter_table import range_problems as table_range_problems

# Hard limits no parameter may exceed (also the upper ends of the ranges below).
HARD_MAX_FORCE = 10.0            # [N], above the force model's 0-8 N range
HARD_MAX_LIFT_SPEED = 0.05       # [m/s]
HARD_MAX_LIFT_DISTANCE = 0.5     # [m]
HARD_MAX_SERVO_SPEED = 3.0       # [rad/s]
HARD_MAX_CURRENT = 2.3           # [A], XM430-W350 stall current
HARD_MAX_SLIP_INCREMENT = math.radians(5.0)  # [rad]
HARD_MAX_TIGHTENING = 0.6        # [rad]
HARD_MAX_FRESHNESS = 1.0         # [s]
HARD_MAX_ANGLE = math.pi         # [rad]

# Smallest values of quantities that must be positive (inclusive lower bounds).
MIN_SERVO_SPEED = 1e-3           # [rad/s]
MIN_ANGLE_STEP = 1e-4            # [rad]
MIN_FORCE = 0.01                 # [N]
MIN_LIFT_SPEED = 1e-4            # [m/s]
MIN_LIFT_DISTANCE = 1e-4         # [m]
MIN_DURATION = 1e-3              # [s]
MIN_CURRENT = 0.01               # [A]
MIN_LEVEL = 1e-4                 # [normalised tactile units]


def _spec(name: str, kind: type, unit: str, description: str, low: float | None = None,
          high: float | None = None, **extra: Any) -> ParameterSpec:
    """A table entry, arguments in the order of this module's tables."""
    return ParameterSpec(name, kind, description, unit, low, high, **extra)


def _field_table(specs: Iterable[ParameterSpec], prefix: str = '') -> dict[str, ParameterSpec]:
    """The table of a dataclass's parameters: each entry's default is the field of its
    name, and its node name is ``prefix`` + the field name."""
    return parameter_table(replace(spec, name=prefix + spec.name, field=spec.name)
                           for spec in specs)


SERVO_SPEED = (MIN_SERVO_SPEED, HARD_MAX_SERVO_SPEED)

#: The state machine's parameters (the fields of :class:`ControllerParams`), in field order.
CONTROLLER_PARAMETERS: dict[str, ParameterSpec] = _field_table((
    # closing and contact
    _spec('closing_speed', float, 'rad/s', 'servo command ramp while closing to contact',
          *SERVO_SPEED),
    _spec('contact_mode', str, '', "contact needed on 'either' finger (paper: any channel) "
          "or on 'both'", choices=('either', 'both')),
    _spec('contact_level', float, '', 'contact also when the mean |tared filtered| value '
          'reaches this while closing (a very soft object loads too slowly for the contact '
          'flag); 0: flags only', 0.0, 2.0),
    _spec('min_angle', float, 'rad', 'most closed servo command allowed', 0.0, HARD_MAX_ANGLE),
    _spec('max_angle', float, 'rad', 'most open servo command allowed: the finger joints\' '
          'upper limit (the URDF limit and the gripper driver\'s theta_max, 1.0 rad by '
          'default); gripper position goals beyond it are rejected', MIN_ANGLE_STEP,
          HARD_MAX_ANGLE),
    _spec('no_contact_settle', float, 's', 'wait at min_angle before NO_CONTACT', 0.0, 10.0),
    _spec('ramp_lead', float, 's', 'the closing and loading ramps run at most this far ahead '
          'of the latest perception sample and wait while perception trails by more (the '
          'overshoot past contact stays speed x (lead + detection delay) however late the '
          'tactile data arrives)', 0.0, HARD_MAX_FRESHNESS),
    # loading
    _spec('loading_speed', float, 'rad/s', 'servo command ramp while loading the initial force',
          *SERVO_SPEED),
    _spec('initial_force', float, 'N', 'initial force f_init loaded after contact',
          MIN_FORCE, HARD_MAX_FORCE),
    _spec('initial_force_mode', str, '', "'relative' (f_init above the force at contact) or "
          "'absolute'", choices=('relative', 'absolute')),
    _spec('invalid_force_timeout', float, 's', 'longest wait for a valid force while loading',
          0.0, 5.0),
    _spec('min_finger_share', float, '', 'FORTE loads on past the force target while the '
          "weaker finger's deformation level is below this fraction of the stronger's (the "
          'object pinned against one finger; 0: off, the paper\'s loading)', 0.0, 1.0),
    _spec('max_balancing_closing', float, 'rad', 'FORTE closes at most this far past the '
          'command that reached the force target while the object is pinned', 0.0, 1.0),
    # lifting
    _spec('lift_speed', float, 'm/s', 'arm lift speed', MIN_LIFT_SPEED, HARD_MAX_LIFT_SPEED),
    _spec('lift_distance', float, 'm', 'lift height that counts as success',
          MIN_LIFT_DISTANCE, HARD_MAX_LIFT_DISTANCE),
    _spec('hold_duration', float, 's', 'time held at the lift height before LIFTED', 0.0, 600.0),
    # slip reaction
    _spec('slip_increment', float, 'rad', 'servo tightening per slip event (paper: 0.88 deg)',
          MIN_ANGLE_STEP, HARD_MAX_SLIP_INCREMENT),
    _spec('slip_refractory', float, 's', 'minimum time between two slip tightenings', 0.0, 10.0),
    _spec('slipping_interval', float, 's', 'while the slipping state persists after a slip '
          'tightening, tighten again this often (within max_tightening; 0: never)', 0.0, 10.0),
    _spec('slip_reaction', str, '', "'events': one tightening per slip event (the paper's "
          "reaction, for slip_mode paper); 'sliding': also tighten again while the slipping "
          "state persists (slipping_interval)", choices=('events', 'sliding')),
    _spec('slip_speed', float, 'rad/s', 'servo profile velocity of a slip tightening',
          *SERVO_SPEED),
    # drop detection
    _spec('drop_force_fraction', float, '', 'drop when force < fraction x reference force',
          0.0, 1.0),
    _spec('drop_min_reference_force', float, 'N', 'force drop detector armed above this '
          'reference', 0.0, HARD_MAX_FORCE),
    _spec('drop_level_fraction', float, '', 'drop when deformation < fraction x reference',
          0.0, 1.0),
    _spec('drop_min_reference_level', float, '', 'deformation drop detector armed above this '
          '(sensor units, -1..1)', 0.0, 2.0),
    _spec('drop_on_contact_loss', bool, '', 'also detect a drop when both contact flags are '
          'false'),
    _spec('drop_confirm_time', float, 's', 'a drop condition must persist this long', 0.0, 10.0),
    # ON_OFF controller
    _spec('on_off_closing_speed', float, 'rad/s', 'constant closing speed of the ON_OFF '
          'controller', *SERVO_SPEED),
    _spec('on_off_settle', float, 's', 'ON_OFF wait at theta = 0 before lifting', 0.0, 10.0),
    # release
    _spec('open_angle', float, 'rad', 'servo command when releasing', MIN_ANGLE_STEP,
          HARD_MAX_ANGLE),
    _spec('release_speed', float, 'rad/s', 'servo speed when releasing', *SERVO_SPEED),
    _spec('release_tolerance', float, 'rad', 'joint angle tolerance that ends RELEASING',
          MIN_ANGLE_STEP, 1.0),
    _spec('release_timeout', float, 's', 'longest RELEASING', MIN_DURATION, 60.0),
    # safety
    _spec('max_force', float, 'N', 'grip force cap', MIN_FORCE, HARD_MAX_FORCE),
    _spec('force_limit_confirm', float, 's', 'force above the cap this long before '
          'FORCE_LIMIT (no tightening meanwhile)', 0.0, 0.2),
    _spec('max_tightening', float, 'rad', 'cap on total slip tightening', 0.0,
          HARD_MAX_TIGHTENING),
    _spec('max_lift_distance', float, 'm', 'lift height cap', MIN_LIFT_DISTANCE,
          HARD_MAX_LIFT_DISTANCE),
    _spec('max_lift_speed', float, 'm/s', 'largest lift speed a goal may request',
          MIN_LIFT_SPEED, HARD_MAX_LIFT_SPEED),
    _spec('perception_timeout', float, 's', 'perception freshness bound', MIN_DURATION,
          HARD_MAX_FRESHNESS),
    _spec('joint_state_timeout', float, 's', 'joint state freshness bound', MIN_DURATION,
          HARD_MAX_FRESHNESS),
    _spec('invalid_input_timeout', float, 's', 'perception data_valid false this long -> '
          'fault', 0.0, 5.0),
    _spec('timeout', float, 's', 'whole-grasp timeout', MIN_DURATION, 3600.0),
    _spec('max_current', float, 'A', 'servo current limit sent with every command',
          MIN_CURRENT, HARD_MAX_CURRENT),
))

#: Parameters of the node only (not of the state machine), with their defaults.
NODE_PARAMETERS: dict[str, ParameterSpec] = parameter_table((
    _spec('control_rate', float, 'Hz', 'rate of the control step and of arm velocity commands',
          1.0, 200.0, default=20.0, read_only=True),
    _spec('feedback_rate', float, 'Hz', 'rate of action feedback and grasp/state messages',
          0.1, 100.0, default=10.0, read_only=True),
    _spec('input_wait', float, 's', 'longest wait for fresh inputs when a goal or a fault reset '
          'arrives (the controller subscribes to its inputs only while one needs them)',
          0.05, 30.0, default=1.0),
    _spec('step_on_perception', bool, '', 'also step the state machine on every tactile/state '
          'message (slip messages are always handled at once)', default=True),
    _spec('arm_frame_id', str, '', "frame_id of arm/cmd_vel (the arm's base frame)",
          default='base_link'),
    _spec('gripper_frame_id', str, '', 'frame_id of grasp/state and gripper/command',
          default=BASE_FRAME),
    _spec('joint_names', list, '', 'joints whose mean position is the servo angle',
          default=JOINT_NAMES, read_only=True),
    _spec('prefix', str, '', 'TF / joint-name prefix prepended to joint_names, '
          "gripper_frame_id and arm_frame_id (e.g. right_ for a second gripper; '' = none)",
          default='', read_only=True),
    _spec('use_receive_time', bool, '', 'judge data freshness by receive time instead of '
          'header stamps (for replays of recorded stamps without a /clock)', default=False,
          read_only=True),
    _spec('dry_run', bool, '', 'compute everything but publish zero arm velocity and no servo '
          'commands (bag replay); refused while a grasp is active', default=False),
))


#: Prefix of the lift verification's parameters on the node (a ``lift_check:`` block in YAML).
LIFT_CHECK_PREFIX = 'lift_check.'

#: The lift verification's thresholds (the fields of
#: :class:`forte_control.state_machine.lift_check.LiftCheckParams`, which holds their
#: defaults), under their node names. Levels are in the tared filtered channels' normalised
#: units (-1..1).
LIFT_CHECK_PARAMETERS: dict[str, ParameterSpec] = _field_table((
    _spec('verify_lift', bool, '', 'LIFTED only with evidence that the object is carried '
          '(false: from the commanded lift alone, the old behaviour)'),
    _spec('balance_window', float, 's', 'averaging time of the two finger levels',
          MIN_DURATION, 5.0),
    _spec('balance_floor', float, '', '|left - right| finger level always allowed', 0.0, 2.0),
    _spec('balance_tolerance', float, '', 'plus this fraction of left + right', 0.0, 1.0),
    _spec('min_finger_level', float, '', 'each finger must be loaded this much', 0.0, 2.0),
    _spec('quiet_time', float, 's', 'no slip flag in this last part of the lift', 0.0, 60.0),
    _spec('probe_distance', float, 'm', 'set-down probe: lift this far beyond the lift '
          'height, then lower back (0: no probe)', 0.0, 0.05),
    _spec('probe_settle', float, 's', 'wait after lowering before judging', 0.0, 10.0),
    _spec('probe_window', float, 's', 'averaging time of the shear index before / after the '
          'probe', MIN_DURATION, 5.0),
    _spec('probe_unload', float, '', 'shear index fall that means the table took load',
          0.0, 2.0),
    _spec('use_wrench', bool, '', 'also require the wrist load to grow (needs arm/wrench)'),
    _spec('min_wrench_load', float, 'N', 'wrist load gained since the lift began',
          0.0, 100.0),
    _spec('wrench_timeout', float, 's', 'wrist wrench freshness bound', MIN_DURATION,
          HARD_MAX_FRESHNESS),
    _spec('stall_tolerance', float, 'rad', 'joint short of a closed command: blocked',
          MIN_ANGLE_STEP, 1.0),
    _spec('loaded_level', float, '', 'mean |filtered| of a gripper closed on something',
          MIN_LEVEL, 2.0),
    _spec('loaded_force', float, 'N', 'force estimate of a gripper closed on something',
          MIN_FORCE, HARD_MAX_FORCE),
    _spec('loaded_current', float, 'A', 'servo current rise over free closing of a gripper '
          'closed on something', MIN_CURRENT, HARD_MAX_CURRENT),
    _spec('gross_slip_reaction', bool, '', 'FORTE tightens while lifting when the fingers '
          'stay unequally loaded or the deformation decays (smooth gross slip)'),
    _spec('gross_slip_min_lift', float, 'm', 'commanded lift before unequal finger levels '
          'count as gross slip', 0.0, 0.05),
    _spec('gross_slip_decay', float, '', 'fall of the deformation level below its peak in '
          'the lift that counts as gross slip', 0.01, 1.0),
    _spec('gross_slip_interval', float, 's', 'least time between two gross-slip '
          'tightenings', MIN_DURATION, 10.0),
    _spec('contact_settle', float, 's', 'time from a grip change (lift start, tightening) to '
          'the first place of the contact on the fingers', 0.0, 10.0),
    _spec('contact_shift', float, '', 'load share the middle channels may lose in the lift '
          'after the grip last changed (more: the contact moved toward the fingertips)',
          0.0, 2.0),
), LIFT_CHECK_PREFIX)


def range_problems(values: Mapping[str, object]) -> list[str]:
    """Reasons why values are outside their parameter's range or choices.

    Parameters
    ----------
    values : mapping
        Parameter name -> value; names without an entry in :data:`CONTROLLER_PARAMETERS`,
        :data:`NODE_PARAMETERS` or :data:`LIFT_CHECK_PARAMETERS` are ignored.

    Returns
    -------
    list of str
        One reason per refused value, ``'<name>=<value> outside <range>'`` (a number) or
        ``'<name> must be one of <choices>, got <value>'`` (a text); empty when all fit
        (:func:`forte_ros.parameter_table.range_problems` over the three tables).
    """
    return table_range_problems(
        (CONTROLLER_PARAMETERS, NODE_PARAMETERS, LIFT_CHECK_PARAMETERS), values)
