"""Normal-direction mechanics of one tick: servo, fin-ray fingers, object placement, arm.

The servo moves toward its goal at the profile velocity and stalls where the finger force
reaches its current limit; the fingers (nonlinear spring with stress relaxation, in series
with the object's contact stiffness) press on the object; the object slides sideways on the
table until the two finger forces balance; fragile objects fail above their break force;
the arm lifts at an acceleration-limited velocity. The tangential side (friction, lift,
slip) is :mod:`.friction`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from forte_sim.catalogue import ObjectSpec
from forte_sim.model import STANDARD_GRAVITY, GripperModel, finger_force_elastic, solve_finger
from forte_sim.state import TICK, ArmState, GripperState, ObjectState, TrialDraws
from forte_sim.truth import OBJECT_BROKEN, OBJECT_CRUSHED

_LATERAL_STEP = 0.025       # largest sideways slide of the object per tick (5 mm/s) [mm]
_LATERAL_TOLERANCE = 1e-4   # force imbalance ignored by the lateral placement [N]
_STALL_BISECTIONS = 12      # bisection steps locating the servo's stall angle
_CRUSHED_WIDTH_SHARE = 0.5  # share of the compression a crushed object keeps [-]
_BROKEN_WIDTH = 0.85        # width of a broken object relative to before [-]


@dataclass(slots=True)
class FingerSolution:
    """Finger deflection [mm], force [N] and local contact stiffness [N/mm], left and right."""

    deflections: list[float]
    forces: list[float]
    stiffness: list[float]


class GripperMechanics:
    """Servo, fingers and arm of one scene, advanced one tick at a time.

    Parameters
    ----------
    model : GripperModel
        Gripper parameters.
    scale : float
        Finger stiffness factor of the contact location [-].
    obj : ObjectSpec or None
        Grasped object (its contact stiffness and break force).
    draws : TrialDraws
        The trial's break force spread and object temperature.
    """

    def __init__(self, model: GripperModel, scale: float, obj: ObjectSpec | None,
                 draws: TrialDraws) -> None:
        self.model = model
        self.scale = scale
        self.object = obj
        #: Local contact stiffness of the object [N/mm]; None = rigid.
        self.object_stiffness = obj.stiffness if obj is not None else None
        self._break_force = (obj.break_force * draws.break_scale
                             if obj is not None and obj.break_force is not None else math.inf)
        self._object_temperature = draws.temperature
        self._relax_decay = tuple(1.0 - math.exp(-TICK / tau) for tau in model.relaxation_times)
        self._temperature_decay = 1.0 - math.exp(-TICK / model.temperature_time)

    def solve_fingers(self, gripper: GripperState, width_mm: float, theta: float,
                      lateral: float) -> FingerSolution:
        """Both fingers at servo angle ``theta`` with the object ``lateral`` mm to the right."""
        model = self.model
        overlap = width_mm - model.gap_per_radian * 1000.0 * theta
        solution = FingerSolution([0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
        for finger, sign in ((0, -1.0), (1, 1.0)):
            penetration = 0.5 * overlap + sign * lateral
            deflection, force, stiffness = solve_finger(
                model, penetration, gripper.relax_fast[finger], gripper.relax_slow[finger],
                self.scale, self.object_stiffness, gripper.deflection[finger])
            solution.deflections[finger] = deflection
            solution.forces[finger] = force
            solution.stiffness[finger] = stiffness
        return solution

    def move_servo(self, gripper: GripperState, width_mm: float,
                   lateral: float) -> tuple[float, FingerSolution]:
        """Servo angle after one tick at the profile velocity, stalled at the current limit.

        Returns the new angle [rad] and the fingers there.
        """
        model = self.model
        theta_old = gripper.theta
        limit = gripper.profile_velocity * TICK
        theta = theta_old + min(max(gripper.command - theta_old, -limit), limit)
        fingers = self.solve_fingers(gripper, width_mm, theta, lateral)
        torque_limit = model.torque_constant * max(gripper.max_current
                                                   - model.friction_current, 0.0)
        force_limit = torque_limit / model.lever_arm
        if theta < theta_old and max(fingers.forces) > force_limit:
            low, high = theta, theta_old
            for _ in range(_STALL_BISECTIONS):
                middle = 0.5 * (low + high)
                trial = self.solve_fingers(gripper, width_mm, middle, lateral)
                if max(trial.forces) > force_limit:
                    low = middle
                else:
                    high = middle
            theta = high
            fingers = self.solve_fingers(gripper, width_mm, theta, lateral)
        return theta, fingers

    def place_laterally(self, gripper: GripperState, body: ObjectState, shear: list[float],
                        width_mm: float, theta: float,
                        fingers: FingerSolution) -> FingerSolution:
        """Table friction holds the object sideways until the finger force imbalance wins.

        Moves ``body.lateral`` and returns the fingers at the new placement.
        """
        if body.lifted or body.falling:
            resist = 0.0
        else:
            resist = self.model.table_friction * max(
                self.object.mass * STANDARD_GRAVITY - shear[0] - shear[1], 0.0)
        imbalance = fingers.forces[0] - fingers.forces[1]
        if not abs(imbalance) > resist + _LATERAL_TOLERANCE:
            return fingers
        target = imbalance - math.copysign(resist, imbalance)
        total = fingers.stiffness[0] + fingers.stiffness[1]
        if not total > 0.0:
            return fingers
        # the object slides sideways at a finite speed, not in one jump
        shift = target / total
        body.lateral += min(max(shift, -_LATERAL_STEP), _LATERAL_STEP)
        return self.solve_fingers(gripper, width_mm, theta, body.lateral)

    def settle_fingers(self, gripper: GripperState, theta: float,
                       fingers: FingerSolution) -> None:
        """Take the tick's servo angle and fingers: currents, relaxation, temperature."""
        model = self.model
        gripper.velocity = (theta - gripper.theta) / TICK
        gripper.theta = theta
        gripper.deflection = fingers.deflections
        gripper.force = fingers.forces
        for finger in (0, 1):
            current = (model.friction_current
                       + fingers.forces[finger] * model.lever_arm / model.torque_constant)
            gripper.current[finger] = min(current, gripper.max_current)
            elastic = finger_force_elastic(model, fingers.deflections[finger], self.scale)
            gripper.relax_fast[finger] += ((elastic - gripper.relax_fast[finger])
                                           * self._relax_decay[0])
            gripper.relax_slow[finger] += ((elastic - gripper.relax_slow[finger])
                                           * self._relax_decay[1])
            contact = 1.0 if fingers.forces[finger] > 0.0 else 0.0
            gripper.temperature[finger] += ((contact * self._object_temperature
                                             - gripper.temperature[finger])
                                            * self._temperature_decay)

    def check_failure(self, body: ObjectState, forces: list[float]) -> None:
        """A fragile object breaks or is crushed above its break force (it gets narrower)."""
        if self.object is None or body.status in (OBJECT_BROKEN, OBJECT_CRUSHED):
            return
        if not max(forces) > self._break_force:
            return
        if self.object.failure == 'crushed':
            body.status = OBJECT_CRUSHED
            compression = max(forces) / (self.object_stiffness or math.inf)
            body.width_mm -= _CRUSHED_WIDTH_SHARE * compression
        else:
            body.status = OBJECT_BROKEN
            body.width_mm *= _BROKEN_WIDTH

    def move_arm(self, arm: ArmState) -> tuple[float, float]:
        """Arm velocity toward its command (acceleration-limited), lift on; not below 0.

        Returns the acceleration [m/s^2] and the lift travel of the tick [m].
        """
        change = arm.command - arm.velocity
        limit = self.model.arm_acceleration * TICK
        change = min(max(change, -limit), limit)
        arm.velocity += change
        acceleration = change / TICK
        lift_before = arm.lift
        arm.lift += arm.velocity * TICK
        if arm.lift < 0.0:
            arm.lift = 0.0
            arm.velocity = max(arm.velocity, 0.0)
        return acceleration, arm.lift - lift_before
