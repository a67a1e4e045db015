"""The FORTE grasp state machine: a pure function of its inputs and time (no rclpy).

The procedure follows the results section of the FORTE paper:

1. CLOSING: the servo command ramps towards closed (theta decreases) at ``closing_speed``
   until the perception reports contact (``contact_mode``: either finger, the paper's "any
   channel", or both fingers).
2. LOADING: the command keeps ramping, at ``loading_speed``, until the estimated grip force
   is ``initial_force`` above the force at contact (``initial_force_mode='relative'``) or
   reaches ``initial_force`` (``'absolute'``).
3. LIFTING: the arm moves up at ``lift_speed``; with the FORTE controller every slip flag
   (outside a refractory period) tightens the servo by ``slip_increment``; the lift ends
   with success when the commanded lift height reaches ``lift_distance``.
4. HOLDING: the arm stops, the grip is held (and still tightened on slip) for
   ``hold_duration`` and until the grip is quiet, then the set-down probe; then DONE with
   outcome LIFTED, or RELEASING (gripper opens) when the goal asked for it.

Drops are detected from the sensors during LIFTING and HOLDING (see :class:`DropDetector`).
The commanded lift proves nothing about the object: at the end of the hold the evidence of
the lift (:mod:`.lift_check`: both fingers loaded equally, as only a free object can be, and
no slip in the last part of the lift) decides between LIFTED and NOT_CARRIED. Closing fully
without a contact flag ends in NO_CONTACT only if nothing was squeezed (joint not blocked,
no deformation, force or current rise); else CLOSED_ON_OBJECT.
NO_SLIP runs the same procedure without the slip reaction; ON_OFF closes fully at constant
speed without sensing and lifts (its sensors only decide the recorded outcome).

Safety is checked on every step before anything moves: freshness of perception and joint
state, validity of the perception data, force cap, tightening cap, lift cap. A safety fault
stops the arm, holds the gripper at its current command and latches until
:meth:`GraspStateMachine.reset_fault`, which is refused while the condition persists.

Time is a float in seconds on one clock shared by ``now`` and the input stamps (ROS time in
the node, simulation time in the closed loop).

The package, one module per concern:

- :mod:`.types`: states, outcomes, fault flags and controllers (mirrors of forte_msgs),
  the goal, the inputs and outputs of a step, :func:`perception_input`.
- :mod:`.controller_params`: :class:`ControllerParams` and a goal's overrides (ranges from
  the table of :mod:`forte_control.parameters`).
- :mod:`.safety`: freshness, validity, force, lift and time caps checked on every step.
- :mod:`.progress`: bookkeeping of the grasp in progress and of the latest inputs.
- :mod:`.phases`: one handler per active state, chosen from a table by the state.
- :mod:`.machine`: :class:`GraspStateMachine`: start, cancel, fault reset, step.

The lift verification and drop detection it relies on are :mod:`.lift_check`.
Every name below is importable from ``forte_control.state_machine``.
"""
from __future__ import annotations

from forte_control.state_machine.controller_params import ControllerParams as ControllerParams

# Re-exports (``X as X``): the public names of the package, wherever they are defined.
from forte_control.state_machine.drop_detector import DropDetector as DropDetector
from forte_control.state_machine.lift_check import LiftCheckParams as LiftCheckParams
from forte_control.state_machine.machine import GraspStateMachine as GraspStateMachine
from forte_control.state_machine.types import ACTIVE_STATES as ACTIVE_STATES
from forte_control.state_machine.types import PAPER_SLIP_INCREMENT as PAPER_SLIP_INCREMENT
from forte_control.state_machine.types import ControlInputs as ControlInputs
from forte_control.state_machine.types import Controller as Controller
from forte_control.state_machine.types import ControlOutputs as ControlOutputs
from forte_control.state_machine.types import FaultFlag as FaultFlag
from forte_control.state_machine.types import GraspGoal as GraspGoal
from forte_control.state_machine.types import GraspState as GraspState
from forte_control.state_machine.types import JointInput as JointInput
from forte_control.state_machine.types import Outcome as Outcome
from forte_control.state_machine.types import PerceptionInput as PerceptionInput
from forte_control.state_machine.types import ServoOutput as ServoOutput
from forte_control.state_machine.types import WrenchInput as WrenchInput
from forte_control.state_machine.types import joint_input as joint_input
from forte_control.state_machine.types import perception_input as perception_input

__all__ = [
    'ACTIVE_STATES', 'PAPER_SLIP_INCREMENT', 'ControlInputs', 'ControlOutputs', 'Controller',
    'ControllerParams', 'DropDetector', 'FaultFlag', 'GraspGoal', 'GraspState',
    'GraspStateMachine', 'JointInput', 'LiftCheckParams', 'Outcome', 'PerceptionInput',
    'ServoOutput', 'WrenchInput', 'joint_input', 'perception_input',
]
