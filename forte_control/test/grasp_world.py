"""A grasp state machine stepped against a synthetic world: the part every closed-loop test
world of this folder shares.

A world gives the perception input (:meth:`GraspWorld.perception`); the joint follows the
servo command at once (:meth:`GraspWorld.follow`: an object may block it), and every step
is one perception update, :data:`DT` after the last.
"""
from __future__ import annotations

from forte_control import state_machine
from forte_control.state_machine import Controller, GraspState

DT = 0.01  # one perception update (20 samples at 2 kHz) [s]

#: States in which a grasp is still going on.
ACTIVE = (GraspState.CLOSING, GraspState.LOADING, GraspState.LIFTING, GraspState.HOLDING)


def squeeze_force(theta: float) -> float:
    """The grip force of an object touched from the start, growing 5 N/rad as the servo
    closes from 0.6 rad (0.4 N there) [N]."""
    return 0.4 + 5.0 * (0.6 - theta)


class GraspWorld:
    """One grasp against synthetic physics; subclasses give the tactile input.

    Parameters
    ----------
    params : ControllerParams, optional
    lift_check : LiftCheckParams, optional
    now : float
        Clock at the start [s].
    theta : float
        Joint angle at the start [rad].
    """

    def __init__(self, params: state_machine.ControllerParams | None = None,
                 lift_check: state_machine.LiftCheckParams | None = None, *,
                 now: float = 10.0, theta: float = 0.6) -> None:
        self.machine = state_machine.GraspStateMachine(
            params or state_machine.ControllerParams(), lift_check)
        self.now = now
        self.theta = theta

    def perception(self) -> state_machine.PerceptionInput:
        """The perception input at ``now``."""
        raise NotImplementedError

    def inputs(self) -> state_machine.ControlInputs:
        return state_machine.ControlInputs(
            perception=self.perception(),
            joint=state_machine.JointInput(stamp=self.now, theta=self.theta, effort=0.05))

    def follow(self, command: float) -> float:
        """The joint angle the servo reaches for ``command`` [rad] (at once, unblocked)."""
        return command

    def start(self, controller: Controller) -> None:
        assert self.machine.start(state_machine.GraspGoal(controller=controller), self.now,
                                  self.inputs())[0]

    def step(self) -> tuple[state_machine.ControlOutputs, bool]:
        """One control step; the joint follows the servo. Returns the outputs and whether
        the servo was commanded to close further than the joint stood."""
        self.now += DT
        out = self.machine.step(self.inputs(), self.now)
        closed = out.servo is not None and out.servo.position < self.theta - 1e-9
        if out.servo is not None:
            self.theta = self.follow(out.servo.position)
        return out, closed
