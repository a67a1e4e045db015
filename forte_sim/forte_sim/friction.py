"""Tangential contact mechanics of a grasped object: stick, stick-slip, sliding, falling.

One :meth:`FrictionModel.tick` per mechanics tick, in named steps:

1. :meth:`~FrictionModel._limits`: each finger's tangential stiffness and its kinetic and
   static friction capacity (static friction grows back with the age of a stuck contact
   and varies along the surface);
2. :meth:`~FrictionModel._free_fingers_without_contact`;
3. :meth:`~FrictionModel._fall`: an object the fingers cannot carry falls until they catch
   it or it lands;
4. :meth:`~FrictionModel._load_on_table`: while the object rests on the table, each finger
   loads its own contact as the arm moves;
5. :meth:`~FrictionModel._carry`: a lifted object's weight (and the arm's acceleration) is
   shared by the stuck contacts; the most loaded one slips or releases first;
6. :meth:`~FrictionModel._rotate`: rotational slip about the grasp axis;
7. :meth:`~FrictionModel._update_object_status`: the contact running off, held / dropped;
8. the tick's slip type (:func:`.truth.classify_slip`), recorded in
   :class:`.truth.SlipLabels`.

Each finger's shear on the object changes by its tangential stiffness times the finger's
motion relative to the object; it is limited by static friction while stuck (aging
contact) and equals kinetic friction while sliding. Stick-slip releases are placed at the
sample where the load crossed the static limit inside the tick.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from forte_ros.contract import SAMPLE_PERIOD, SAMPLE_RATE
from forte_sim.catalogue import ObjectSpec
from forte_sim.model import STANDARD_GRAVITY, GripperModel
from forte_sim.state import TICK, TICK_SAMPLES, ContactState, ObjectState, TrialDraws
from forte_sim.truth import OBJECT_DROPPED, OBJECT_HELD, OBJECT_RESTING, SlipLabels, classify_slip

_HELD_HEIGHT = 0.002        # object counts as held above this height [m]
_STICK_SLIP_MIN = 0.03      # mu_static - mu_kinetic below this slides smoothly [-]
_ROTATION_TIME = 0.15       # time constant of rotational slip [s]
_SETTLED_OFFSET = 0.003     # rotation within this of its equilibrium has stopped [rad]
GRIP_MARGIN = 0.003         # slide distance margin before the contact runs off [m]
_TEXTURE_SPACING = 0.0005   # correlation length of the surface friction variation [m]
_AGING_TIME = 0.15          # static friction recovery time of a stuck contact [s]
_MIN_RELEASE = 0.004        # static minus kinetic capacity below which slip is smooth [N]
_STICK_SLIP_HOLD = 0.1      # a release labels stick-slip for this long [s]
_SHARING_ITERATIONS = 8     # rounds of load sharing between the contacts per tick


@dataclass(slots=True)
class TickFriction:
    """What one tick's friction update works with; fixed during the tick.

    Attributes
    ----------
    tick_start, now : int
        Sample index of the start and of the end of the tick.
    forces : list of float
        Finger normal forces [N].
    in_contact : bool
        At least one finger touches the object.
    stiffness : list of float
        Tangential contact stiffness of each finger [N/m].
    kinetic, static : list of float
        Kinetic and static friction capacity of each finger [N].
    previous : list of float
        Shear of each finger at the start of the tick [N].
    ejection : float
        Force squeezing the object out of a tapered grasp [N].
    weight : float
        Object weight [N].
    """

    tick_start: int
    now: int
    forces: list[float]
    in_contact: bool
    stiffness: list[float]
    kinetic: list[float]
    static: list[float]
    previous: list[float]
    ejection: float
    weight: float


class FrictionModel:
    """Friction between the fingers and one grasped object.

    Parameters
    ----------
    obj : ObjectSpec
        The grasped object.
    draws : TrialDraws
        The trial's friction spread, centre-of-mass offset and surface texture.
    model : GripperModel
        Tangential contact stiffness of the fingers.
    """

    def __init__(self, obj: ObjectSpec, draws: TrialDraws, model: GripperModel) -> None:
        self.object = obj
        self.model = model
        self._draws = draws
        self._texture = draws.texture
        self.mu_static = obj.mu_static * draws.mu_scale * obj.wrap_gain
        self.mu_kinetic = obj.mu_kinetic * draws.mu_scale * obj.wrap_gain
        self._stick_slip = (obj.mu_static - obj.mu_kinetic) >= _STICK_SLIP_MIN
        #: Slide along the object after which the contact runs off it [m].
        self.grip_length = max(obj.height / 2.0 - GRIP_MARGIN, 0.002)
        self._rotation_decay = 1.0 - math.exp(-TICK / _ROTATION_TIME)

    def contact_width(self, contact: ContactState, body: ObjectState) -> float:
        """Object width at the current contact line [mm] (0 once the contact ran off).

        A round object narrows as the contact slides away from its equator.
        """
        if body.contact_lost:
            return 0.0
        slide = 0.5 * (contact.slide[0] + contact.slide[1])
        if slide > self.grip_length:
            return 0.0
        obj = self.object
        if obj.shape == 'round':
            ratio = slide / (obj.height / 2.0)
            return body.width_mm * math.sqrt(max(0.0, 1.0 - ratio * ratio))
        return body.width_mm

    def tick(self, contact: ContactState, body: ObjectState, labels: SlipLabels,
             forces: list[float], arm_velocity: float, tick_start: int,
             acceleration: float, lift_change: float) -> None:
        """Advance the tangential contact mechanics by one tick.

        Parameters
        ----------
        contact, body : ContactState, ObjectState
            Updated in place.
        labels : SlipLabels
            Receives the tick's slip type.
        forces : list of float
            Finger normal forces of this tick [N].
        arm_velocity : float
            Arm velocity [m/s] (a dropped object starts falling with it).
        tick_start : int
            Sample index of the start of the tick.
        acceleration : float
            Arm acceleration during the tick [m/s^2].
        lift_change : float
            Arm travel during the tick [m].
        """
        limits = self._limits(contact, body, forces, tick_start)
        self._free_fingers_without_contact(contact, limits)
        if not limits.in_contact and (body.lifted or body.falling):
            body.falling = True
            body.lifted = False
        if body.falling:
            self._fall(contact, body, limits, lift_change)
        released = False
        if not body.falling and not body.lifted:
            released = self._load_on_table(contact, body, limits, lift_change)
            lift_change = 0.0   # consumed
        if body.lifted and not body.falling:
            if self._carry(contact, body, limits, lift_change, acceleration, arm_velocity):
                released = True
        body.height = max(body.height, 0.0)
        self._rotate(body, limits)
        self._update_object_status(contact, body, limits.in_contact)
        now = limits.now
        kind = classify_slip(
            falling=body.falling, contact_lost=body.contact_lost,
            stick_slip=released or now - contact.last_release < _STICK_SLIP_HOLD * SAMPLE_RATE,
            rotating=body.rotating, sliding=contact.sliding)
        labels.record(kind, now, tick_start, contact.events)

    # ------------------------------------------------------------------ steps
    def _limits(self, contact: ContactState, body: ObjectState, forces: list[float],
                tick_start: int) -> TickFriction:
        """Stiffness and friction capacities of the tick; static friction ages."""
        model = self.model
        obj = self.object
        now = tick_start + TICK_SAMPLES
        rotation_factor = 1.0 - 0.5 * math.sin(min(abs(body.rotation), math.pi / 2.0))
        stiffness = [model.tangential_stiffness + model.tangential_stiffening * force
                     for force in forces]
        kinetic = [self.mu_kinetic * force * rotation_factor for force in forces]
        static = []
        for finger in (0, 1):
            # static friction grows back with the age of the stuck contact (aging)
            age = (now - contact.stuck_since[finger]) * SAMPLE_PERIOD
            excess = ((self.mu_static - self.mu_kinetic)
                      * self._texture_at(contact.slide[finger])
                      * (1.0 - math.exp(-age / _AGING_TIME)))
            static.append((self.mu_kinetic + excess) * forces[finger] * rotation_factor)
        return TickFriction(
            tick_start=tick_start, now=now, forces=forces,
            in_contact=forces[0] > 0.0 or forces[1] > 0.0, stiffness=stiffness,
            kinetic=kinetic, static=static, previous=list(contact.shear),
            ejection=math.sin(obj.taper_angle) * (forces[0] + forces[1]),
            weight=obj.mass * STANDARD_GRAVITY)

    @staticmethod
    def _free_fingers_without_contact(contact: ContactState, limits: TickFriction) -> None:
        """A finger without contact moves freely along the object."""
        for finger in (0, 1):
            if limits.forces[finger] <= 0.0:
                contact.shear[finger] = 0.0
                contact.sliding[finger] = False
                contact.stuck_since[finger] = limits.now

    def _fall(self, contact: ContactState, body: ObjectState, limits: TickFriction,
              lift_change: float) -> None:
        """A falling object: caught once kinetic friction carries it, else it falls on."""
        kinetic = limits.kinetic
        support = kinetic[0] + kinetic[1] - limits.ejection
        if limits.in_contact and support >= limits.weight:
            body.falling = False
            body.lifted = True
            contact.sliding = [True, True]
            return
        height_before = body.height
        body.velocity += (support / self.object.mass - STANDARD_GRAVITY) * TICK
        body.height += body.velocity * TICK
        relative = lift_change - (body.height - height_before)
        for finger in (0, 1):
            contact.slide[finger] += relative
            if limits.forces[finger] > 0.0:
                contact.sliding[finger] = True
                contact.shear[finger] = kinetic[finger]
        if body.height <= 0.0:
            body.height = 0.0
            body.velocity = 0.0
            body.falling = False
            body.lifted = False
            if body.status == OBJECT_HELD:
                body.status = OBJECT_DROPPED

    def _load_on_table(self, contact: ContactState, body: ObjectState, limits: TickFriction,
                       lift_change: float) -> bool:
        """Resting on the table: each finger loads its own contact; True on a release."""
        released = False
        for finger in (0, 1):
            if limits.forces[finger] <= 0.0:
                contact.slide[finger] += lift_change
                continue
            if self._load_finger_on_table(contact, finger, limits, lift_change):
                released = True
        if limits.in_contact and contact.shear[0] + contact.shear[1] >= limits.weight:
            body.lifted = True
        return released

    def _load_finger_on_table(self, contact: ContactState, finger: int,
                              limits: TickFriction, lift_change: float) -> bool:
        """One finger's contact on an object the table holds; True on a release."""
        stiffness = limits.stiffness[finger]
        kinetic = limits.kinetic[finger]
        static = limits.static[finger]
        candidate = limits.previous[finger] + stiffness * lift_change
        limit_value = kinetic if contact.sliding[finger] else static
        if candidate > limit_value:
            if contact.sliding[finger] or not self._can_release(static, kinetic):
                contact.sliding[finger] = True
                contact.shear[finger] = kinetic
                contact.slide[finger] += (candidate - kinetic) / stiffness
                return False
            contact.shear[finger] = candidate
            self._release(contact, finger, candidate, limits, stiffness)
            return True
        if candidate < -limit_value:
            # the arm lowers the fingers along the object the table holds: friction
            # opposes the motion both ways, so the shear reverses only down to
            # -friction and the contact slides (smoothly) beyond
            contact.sliding[finger] = True
            contact.shear[finger] = -kinetic
            contact.slide[finger] += (candidate + kinetic) / stiffness
            return False
        if contact.sliding[finger]:
            contact.sliding[finger] = False
            contact.stuck_since[finger] = limits.now
        contact.shear[finger] = candidate
        return False

    def _carry(self, contact: ContactState, body: ObjectState, limits: TickFriction,
               lift_change: float, acceleration: float, arm_velocity: float) -> bool:
        """A lifted object: the contacts share its load; True on a release."""
        forces = limits.forces
        load = self.object.mass * (STANDARD_GRAVITY + acceleration) + limits.ejection
        was_sliding = list(contact.sliding)
        # tentatively stick every finger in contact at its present shear
        stuck = [forces[finger] > 0.0 for finger in (0, 1)]
        for finger in (0, 1):
            if contact.sliding[finger]:
                contact.shear[finger] = min(contact.shear[finger], limits.kinetic[finger])
        residual_motion, released = self._share_load(contact, body, limits, load, stuck,
                                                     was_sliding, arm_velocity)
        # the object moves with the arm minus the fingers' motion relative to it
        body.height += lift_change - residual_motion
        for finger in (0, 1):
            now_sliding = forces[finger] > 0.0 and not stuck[finger]
            if contact.sliding[finger] and not now_sliding:
                contact.stuck_since[finger] = limits.now
            contact.sliding[finger] = now_sliding and not body.falling
        if body.height <= 0.0 and not body.falling:
            body.height = 0.0
            body.lifted = False
        return released

    def _share_load(self, contact: ContactState, body: ObjectState, limits: TickFriction,
                    load: float, stuck: list[bool], was_sliding: list[bool],
                    arm_velocity: float) -> tuple[float, bool]:
        """Share ``load`` between the stuck contacts; the most loaded one gives first.

        ``stuck`` is updated in place. Returns the fingers' motion relative to the object
        [m] and whether a contact released with a stick-slip jump.
        """
        forces, stiffness, kinetic = limits.forces, limits.stiffness, limits.kinetic
        residual_motion = 0.0
        released = False
        for _ in range(_SHARING_ITERATIONS):
            total_stiffness = sum(stiffness[f] for f in (0, 1) if stuck[f])
            fixed = sum(kinetic[f] for f in (0, 1) if forces[f] > 0.0 and not stuck[f])
            if total_stiffness <= 0.0:
                if fixed >= load:
                    stuck[:] = [forces[f] > 0.0 for f in (0, 1)]
                    continue
                body.falling = True
                body.velocity = arm_velocity
                break
            held = sum(contact.shear[f] for f in (0, 1) if stuck[f])
            relative = (load - fixed - held) / total_stiffness
            residual_motion += relative
            for finger in (0, 1):
                if stuck[finger]:
                    contact.shear[finger] += stiffness[finger] * relative
                elif forces[finger] > 0.0:
                    contact.shear[finger] = kinetic[finger]
                    contact.slide[finger] += relative
            worst = self._most_overloaded(contact, limits, stuck, was_sliding)
            if worst < 0:
                break
            if not was_sliding[worst] and self._can_release(limits.static[worst],
                                                            kinetic[worst]):
                released = True
                self._release(contact, worst, contact.shear[worst], limits, stiffness[worst])
                was_sliding[worst] = False
            else:
                stuck[worst] = False
                contact.slide[worst] += ((contact.shear[worst] - kinetic[worst])
                                         / stiffness[worst])
                contact.shear[worst] = kinetic[worst]
        return residual_motion, released

    @staticmethod
    def _most_overloaded(contact: ContactState, limits: TickFriction, stuck: list[bool],
                         was_sliding: list[bool]) -> int:
        """The stuck finger whose shear exceeds its friction limit most; -1 if none does."""
        worst, worst_ratio = -1, 1.0
        for finger in (0, 1):
            if not stuck[finger]:
                continue
            limit_value = (limits.kinetic[finger] if was_sliding[finger]
                           else limits.static[finger])
            ratio = contact.shear[finger] / limit_value if limit_value > 0 else math.inf
            if ratio > worst_ratio + 1e-12:
                worst, worst_ratio = finger, ratio
        return worst

    def _rotate(self, body: ObjectState, limits: TickFriction) -> None:
        """Rotational slip about the grasp axis (only once off the table)."""
        obj = self.object
        com_offset = self._draws.com_offset
        if not (body.lifted and com_offset > 0.0 and limits.in_contact):
            body.rotating = False
            return
        torque = obj.mass * STANDARD_GRAVITY * com_offset
        total = limits.forces[0] + limits.forces[1]
        mu_scale = self._draws.mu_scale
        static_torque = obj.mu_static * mu_scale * total * obj.torsion_radius
        kinetic_torque = obj.mu_kinetic * mu_scale * total * obj.torsion_radius
        if not body.rotating and torque * math.cos(body.rotation) > static_torque:
            body.rotating = True
        if body.rotating:
            equilibrium = math.acos(min(kinetic_torque / torque, 1.0))
            if equilibrium > body.rotation:
                body.rotation += (equilibrium - body.rotation) * self._rotation_decay
            if equilibrium - body.rotation < _SETTLED_OFFSET:
                body.rotating = False

    def _update_object_status(self, contact: ContactState, body: ObjectState,
                              in_contact: bool) -> None:
        """The contact running off the object; resting, held or dropped."""
        slide = 0.5 * (contact.slide[0] + contact.slide[1])
        if in_contact:
            body.had_contact = True
        if not body.contact_lost and (slide > self.grip_length or (
                body.had_contact and not in_contact and slide > GRIP_MARGIN)):
            body.contact_lost = True
        if body.status in (OBJECT_RESTING, OBJECT_HELD):
            if body.contact_lost:
                body.status = OBJECT_DROPPED
            elif body.lifted and body.height > _HELD_HEIGHT:
                body.status = OBJECT_HELD
            elif not body.lifted and not body.falling and body.height <= 0.0:
                body.status = OBJECT_RESTING     # put back down on the table

    # ------------------------------------------------------------------ helpers
    def _texture_at(self, slide: float) -> float:
        """Local static-friction excess factor at a slide position along the object [-].

        Surfaces are not uniform: the excess of static over kinetic friction varies along
        the object (piecewise linear between random values every 0.5 mm, mean 1), which
        makes stick-slip irregular as on real objects.
        """
        position = max(slide, 0.0) / _TEXTURE_SPACING
        index = int(position)
        if index + 1 >= len(self._texture):
            return 1.0
        fraction = position - index
        return self._texture[index] * (1.0 - fraction) + self._texture[index + 1] * fraction

    def _can_release(self, static: float, kinetic: float) -> bool:
        """True if a contact exceeding ``static`` releases with a stick-slip jump."""
        return self._stick_slip and static - kinetic > _MIN_RELEASE

    @staticmethod
    def _release(contact: ContactState, finger: int, load: float, limits: TickFriction,
                 stiffness: float) -> None:
        """Stick-slip release: the contact slips until the shear drops to 2 kinetic - static.

        The release is placed at the sample where the shear crossed the static limit
        inside the tick (linear interpolation from the shear at the start of the tick).
        """
        static, kinetic = limits.static[finger], limits.kinetic[finger]
        previous = limits.previous[finger]
        after = max(2.0 * kinetic - static, 0.0)
        span = load - previous
        fraction = (static - previous) / span if span > 1e-12 else 0.0
        sample = limits.tick_start + int(min(max(fraction, 0.0), 0.999) * TICK_SAMPLES)
        contact.slide[finger] += (load - after) / stiffness
        contact.shear[finger] = after
        contact.jumps[finger] += after - load
        contact.events.append((sample, finger, contact.jumps[finger]))
        contact.last_release = sample
        contact.stuck_since[finger] = sample
