"""The phases of a grasp: one handler per active state of :class:`GraspStateMachine`.

:class:`GraspPhases` is the base class of :class:`~.machine.GraspStateMachine`: the handler
of each active state (:attr:`GraspPhases._PHASES`: CLOSING, LOADING from its base
:class:`~.loading.LoadingPhase`, LIFTING, HOLDING, RELEASING), what they share (slip
reaction, drop detection and lift evidence while the object is up, the set-down probe and
the verdict of the lift), and the state changes and servo commands they make. The machine
runs a handler only after the safety checks of the step passed. Pure Python, no rclpy.
"""
from __future__ import annotations

import math
from collections.abc import Callable

from forte_control.state_machine.controller_params import ControllerParams
from forte_control.state_machine.drop_detector import DropDetector
from forte_control.state_machine.lift_check import (
    LiftMonitor,
    closed_on_object_evidence,
    deformation_level,
)
from forte_control.state_machine.loading import LoadingPhase
from forte_control.state_machine.progress import GraspProgress, LatestInputs
from forte_control.state_machine.safety import flag_names, fresh
from forte_control.state_machine.types import (
    Controller,
    FaultFlag,
    GraspState,
    Outcome,
    PerceptionInput,
    ServoOutput,
)

__all__ = ['GraspPhases']

#: Set-down probes at most begun in one hold: each one a slip or a tightening voided sends
#: the arm back up for another.
MAX_PROBES = 3
#: The contact evidence's tightening (once per lift, two increments) lifts on this many times
#: the lift that evidence took since the grip last changed, for rule 4 to judge it over [-]
CONTACT_RECHECK = 2.0
#: Set-down probe: time constant of the approach to the end point [s], and the distance
#: from it at which the probe counts as arrived [m].
_PROBE_APPROACH = 0.2
_PROBE_END = 1e-5


class GraspPhases(LoadingPhase):
    """The handlers of the active states and the state changes they make.

    A handler is called as ``handler(machine, now, perception, valid)`` (``valid``: the
    perception may be acted on in this step) and returns True if it commanded a slip
    tightening. The attributes are those of :class:`~.machine.GraspStateMachine`, which
    sets them up.
    """

    _params: ControllerParams               # node-level parameters
    _state: GraspState
    _controller: Controller                 # controller of the current / last grasp
    _grasp: GraspProgress | None            # the grasp in progress (or the last one)
    _fault_flags: FaultFlag                 # latched faults
    _last_outcome: Outcome
    _servo: ServoOutput | None              # the servo command (None: never commanded)
    _arm_velocity: float                    # vertical arm velocity commanded [m/s]
    _latest: LatestInputs
    _message: str
    _finished_pending: bool                 # the grasp reached its outcome in this step

    # -- one handler per active state --------------------------------------------------------
    def _closing(self, now: float, perception: PerceptionInput | None, valid: bool) -> bool:
        """CLOSING: ramp towards closed until contact, or closed fully without one."""
        grasp = self._grasp
        joint = self._latest.joint
        assert grasp is not None and joint is not None
        p = grasp.params
        if valid and perception is not None and grasp.open_levels is not None:
            grasp.open_levels.update(perception.stamp, perception.filtered)
        if self._controller == Controller.ON_OFF:
            return self._closing_without_sensing(now)
        if valid and self._contact(perception):
            assert perception is not None
            grasp.contact_force = perception.force if perception.force_valid else None
            self._enter(GraspState.LOADING, now)
            self._update_target(perception)
            self._message = (f'contact at {grasp.ramp_start_angle:.3f} rad, loading to '
                             f'{grasp.target_force:.3f} N')
            return self._loading(now, perception, valid)
        if not valid:
            # hold the command until the data is valid again (never act on bad data)
            self._hold_ramp(now)
            return False
        command = self._ramp(now, p.closing_speed, p.min_angle)
        self._command(command, p.closing_speed)
        if joint.effort is not None and math.isfinite(joint.effort):
            grasp.free_current = joint.effort if grasp.free_current is None \
                else min(grasp.free_current, joint.effort)
        if self._settled(now, command, p.min_angle, p.no_contact_settle):
            self._finish_closed(command, perception)
        return False

    def _closing_without_sensing(self, now: float) -> bool:
        """CLOSING of ON_OFF: to theta = 0 at constant speed, wait on_off_settle, lift."""
        assert self._grasp is not None
        p = self._grasp.params
        command = self._ramp(now, p.on_off_closing_speed, 0.0, paced=False)
        self._command(command, p.on_off_closing_speed)
        if self._settled(now, command, 0.0, p.on_off_settle):
            self._enter_lifting(now, 'ON_OFF: closed fully, lifting')
        return False

    def _lifting(self, now: float, perception: PerceptionInput | None, valid: bool) -> bool:
        """LIFTING: the grip watched (:meth:`_watch_grip`), the arm up to the lift height."""
        reacted, ended = self._watch_grip(now, perception, valid)
        if not ended:
            self._lift_arm(now)
        return reacted

    def _holding(self, now: float, perception: PerceptionInput | None, valid: bool) -> bool:
        """HOLDING: the grip watched (:meth:`_watch_grip`), the hold and its verdict."""
        reacted, ended = self._watch_grip(now, perception, valid)
        if not ended:
            self._hold(now)
        return reacted

    def _releasing(self, now: float, perception: PerceptionInput | None, valid: bool) -> bool:
        """RELEASING: open to open_angle; DONE when there or after release_timeout."""
        grasp = self._grasp
        joint = self._latest.joint
        assert grasp is not None and joint is not None
        p = grasp.params
        self._arm_velocity = 0.0
        self._command(p.open_angle, p.release_speed)
        if joint.theta >= p.open_angle - p.release_tolerance \
                or now - grasp.phase_start >= p.release_timeout:
            self._state = GraspState.DONE
            self._finished_pending = True
            self._message = 'released'
        return False

    #: The handler of each active state.
    _PHASES: dict[GraspState, Callable[[GraspPhases, float, PerceptionInput | None,
                                        bool], bool]] = {
        GraspState.CLOSING: _closing,
        GraspState.LOADING: LoadingPhase._loading,
        GraspState.LIFTING: _lifting,
        GraspState.HOLDING: _holding,
        GraspState.RELEASING: _releasing,
    }

    # -- what the handlers share -----------------------------------------------------------
    def _watch_grip(self, now: float, perception: PerceptionInput | None, valid: bool
                    ) -> tuple[bool, bool]:
        """LIFTING / HOLDING: slip reaction, drop detection, lift evidence.

        Returns ``(tightened, ended)``: a slip tightening was commanded; the grasp ended in
        this step (tightening cap or drop).
        """
        grasp = self._grasp
        assert grasp is not None
        state = self._state
        if valid and perception is not None:
            self._count_slipping(perception)
        reacted = self._tighten_on_slip(now, perception, valid)
        if self._state == GraspState.FAULT:  # the tightening cap
            return False, True
        if not valid:
            return reacted, False
        assert perception is not None
        if grasp.drop is not None and grasp.drop.update(perception, now):
            self._finish(Outcome.DROPPED, f'dropped in {state.name}: {grasp.drop.reason}')
            return reacted, True
        if grasp.lift is not None:
            grasp.lift.update(perception.stamp, perception.filtered,
                              perception.slip and perception.slip_active,
                              state == GraspState.HOLDING, self._latest.wrench, now)
            if state == GraspState.LIFTING:  # counted apart: not a slip flag's reaction
                self._tighten_on_gross_slip(now)
        return reacted, False

    def _tighten_on_gross_slip(self, now: float) -> None:
        """FORTE, LIFTING: tighten by slip_increment on the lift monitor's gross-slip
        evidence, at most every ``gross_slip_interval`` and never past max_tightening (no
        fault: the lift verification judges the outcome); while the contact slides off
        (deformation decay) and a tightening is still possible, the arm waits
        (``grasp.regrip``). The contact moving along the fingers (rule 4, read during the
        lift) tightens once per lift, by two increments, and sets ``grasp.recheck_lift``
        (``CONTACT_RECHECK``): the verdict must see the tightened grip over more travel than
        the slide took to show, or a grip that missed the object would pass (control.md)."""
        grasp = self._grasp
        assert grasp is not None and grasp.lift is not None and self._servo is not None
        check, p = grasp.lift_check, grasp.params
        grasp.regrip = False
        if not (self._controller == Controller.FORTE and check.gross_slip_reaction):
            return
        position = max(p.min_angle, self._servo.position - p.slip_increment)
        if position >= self._servo.position \
                or grasp.tightening + p.slip_increment > p.max_tightening + 1e-12:
            return
        sliding_off = grasp.lift.deformation_decay()
        grasp.regrip = bool(sliding_off)
        # the contact evidence answers once per lift: recheck_lift is set by its tightening
        moved = '' if sliding_off or grasp.recheck_lift else grasp.lift.contact_moved()
        evidence = sliding_off or moved or grasp.lift.unequal_while_lifting(grasp.lift_height)
        if not evidence or now - grasp.last_tightening_time < max(check.gross_slip_interval,
                                                                   p.slip_refractory):
            return
        grasp.gross_slip_events += 1
        if moved:  # the verdict's rule 4 gets twice the travel this evidence took
            grasp.recheck_lift = grasp.lift_height + CONTACT_RECHECK * (
                grasp.lift_height - grasp.grip_change_lift)
            if grasp.tightening + 2.0 * p.slip_increment <= p.max_tightening + 1e-12:
                position = max(p.min_angle, position - p.slip_increment)  # two increments
        self._tighten_to(now, position)
        self._message = f'gross slip {grasp.gross_slip_events} ({evidence}): tightened to ' \
                        f'{position:.4f} rad'

    def _count_slipping(self, perception: PerceptionInput) -> None:
        """Add the time since the previous perception state to the slip duration if that
        state was slipping (sample times, so message delays do not count)."""
        grasp = self._grasp
        assert grasp is not None
        if grasp.slipping_stamp is not None and perception.stamp > grasp.slipping_stamp:
            grasp.slip_duration += perception.stamp - grasp.slipping_stamp
        if perception.slipping:
            if grasp.slipping_stamp is None or perception.stamp > grasp.slipping_stamp:
                grasp.slipping_stamp = perception.stamp
            grasp.last_slipping_stamp = max(grasp.last_slipping_stamp, perception.stamp)
        else:
            grasp.slipping_stamp = None

    def _tighten_on_slip(self, now: float, perception: PerceptionInput | None,
                         valid: bool) -> bool:
        """FORTE: a new slip flag outside the refractory time tightens by slip_increment
        (a fault if that would exceed max_tightening): the paper's reaction, all of
        ``slip_reaction`` 'events'. With 'sliding' so does a slipping state that persists
        ``slipping_interval`` after the last tightening, i.e. a state sampled in the last
        half interval and after the tightening said slipping (never past max_tightening,
        no fault: the grasp goes on at the cap). True if it tightened on a
        flag (a re-tightening while slipping is counted in slip_events but is no flag's
        reaction)."""
        grasp = self._grasp
        assert grasp is not None
        if not (self._controller == Controller.FORTE and valid and perception is not None
                and perception.slip_active):
            return False
        p = grasp.params
        if perception.slip and perception.stamp > grasp.last_slip_stamp:
            grasp.last_slip_stamp = perception.stamp
            if now - grasp.last_tightening_time < p.slip_refractory:
                return False
            if grasp.tightening + p.slip_increment > p.max_tightening + 1e-12:
                self._fault(FaultFlag.TIGHTENING_LIMIT, 'slip tightening would exceed the '
                            f'cap {p.max_tightening:.4f} rad')
                return False
            reason = 'slip'
        elif (p.slip_reaction == 'sliding' and p.slipping_interval > 0.0
              and grasp.last_slipping_stamp >= max(grasp.last_tightening_time,
                                                   now - p.slipping_interval / 2)
              and grasp.tightening > 0.0  # after a tightening: it did not stop the slide
              and now - grasp.last_tightening_time >= max(p.slipping_interval,
                                                          p.slip_refractory)
              and grasp.tightening + p.slip_increment <= p.max_tightening + 1e-12):
            reason = 'still slipping'
        else:
            return False
        assert self._servo is not None
        position = max(p.min_angle, self._servo.position - p.slip_increment)
        grasp.slip_events += 1
        self._tighten_to(now, position)
        self._message = f'{reason} {grasp.slip_events}: tightened to {position:.4f} rad'
        return reason == 'slip'  # a flag's reaction (its latency is measured); not a re-tightening

    def _tighten_to(self, now: float, position: float) -> None:
        """Command a tightening to ``position`` [rad] at slip_speed and account for it."""
        grasp = self._grasp
        assert grasp is not None and self._servo is not None
        grasp.tightening += self._servo.position - position
        grasp.last_tightening_time = now
        grasp.grip_change_lift = grasp.lift_height
        if grasp.lift is not None:
            grasp.lift.grip_changed()
        self._command(position, grasp.params.slip_speed)

    def _hold(self, now: float) -> None:
        """HOLDING: arm still for hold_duration and until the grip is quiet, then the set-down
        probe (again, from the top, if a slip or a tightening disturbed it), then the
        verdict."""
        grasp = self._grasp
        assert grasp is not None and grasp.lift is not None
        p = grasp.params
        probe = self._probe_depth()
        bottom = grasp.lift_target - probe
        if grasp.probe_phase in ('down', 'settle') and (
                grasp.last_tightening_time >= grasp.probe_began or grasp.lift.probe_disturbed()):
            if grasp.probes >= MAX_PROBES:
                self._finish(Outcome.NOT_CARRIED, f'lift of {grasp.lift_height:.4f} m '
                             f'commanded, not verified: slip or tightening in each of '
                             f'{grasp.probes} set-down probes, the grip never settled')
                return
            grasp.probe_phase = 'up'
        if grasp.probe_phase == 'up':
            self._lift_on(now)  # a tightening in the hold: as high again as after one lifting
            if grasp.lift_height < grasp.lift_target - 1e-12:
                self._arm_velocity = p.lift_speed
                self._message = 'set-down probe disturbed: back up to probe again'
                return
            grasp.probe_phase = ''
        if not grasp.probe_phase:
            self._arm_velocity = 0.0
            if now - grasp.phase_start < p.hold_duration or not self._grip_quiet(now):
                return
            if probe <= 0.0:
                self._judge_lift(now)
                return
            grasp.probe_phase = 'down'
            grasp.probe_began = now
            grasp.probes += 1
            grasp.lift.begin_probe()
            self._message = f'set-down probe: lowering {probe * 1000:.1f} mm'
        if grasp.probe_phase == 'down':
            remaining = grasp.lift_height - bottom
            if remaining > _PROBE_END:
                # slow down exponentially into the end point: stopping a downward motion
                # accelerates the object upward, and a carried object's friction must carry
                # m x that acceleration on top of its weight
                self._arm_velocity = -min(p.lift_speed, remaining / _PROBE_APPROACH)
                return
            grasp.probe_phase = 'settle'
            grasp.probe_since = now
        self._arm_velocity = 0.0
        if now - grasp.probe_since >= grasp.lift_check.probe_settle:
            self._judge_lift(now)

    def _grip_quiet(self, now: float) -> bool:
        """The hold's evidence may be judged: no slip flag and no tightening for the probe's
        settle and averaging time, so the probe's reference (or the verdict's levels) is the
        grip as it now is, not a grip that was still sliding or being tightened."""
        grasp = self._grasp
        assert grasp is not None and grasp.lift is not None
        check = grasp.lift_check
        quiet = check.probe_settle + check.probe_window
        if not check.verify_lift or (now - grasp.last_tightening_time >= quiet
                                     and grasp.lift.hold_quiet(quiet)):
            return True
        self._message = 'holding: slip or tightening in the hold, waiting for a quiet grip'
        return False

    def _lift_arm(self, now: float) -> None:
        """Arm command while LIFTING: on up to the lift height (and beyond, see
        :meth:`_lift_on`), then HOLDING."""
        grasp = self._grasp
        assert grasp is not None
        p = grasp.params
        if grasp.lift_height >= grasp.lift_target - 1e-12 and not self._lift_on(now):
            self._arm_velocity = 0.0
            self._enter(GraspState.HOLDING, now)
            self._message = f'lifted {grasp.lift_height:.4f} m, holding'
        elif grasp.regrip:  # the contact slides off: tighten before lifting further
            self._arm_velocity = 0.0
        else:
            self._arm_velocity = p.lift_speed

    def _lift_on(self, now: float) -> bool:
        """Lift on while the last ``quiet_time`` of the lift holds slip evidence: a
        tightening or a slip flag (at the lift target, and going back up after a disturbed
        set-down probe).

        A tightening answers slip evidence: the object slid along the fingers by an unknown
        distance, possibly down onto the table, and is only known to hang as high as the lift
        since (docs/control.md). So the lift target moves up until ``quiet_time`` of lift has
        passed since the last tightening, plus the probe's depth (as ``lift_target`` is
        ``lift_distance`` plus it), within ``max_lift_distance``; the probe then leaves the
        object ``quiet_time`` of lift above where it was caught. The slip flags of the lift
        count too, so that the lift ends as rule 2 of the verdict wants it. After the
        tightening on the contact moving along the fingers the top is at least
        ``grasp.recheck_lift``. True while the arm has to go on up (lift, or wait for a regrip).
        """
        grasp = self._grasp
        assert grasp is not None and grasp.lift is not None
        p, check = grasp.params, grasp.lift_check
        remaining = max(grasp.last_tightening_time + check.quiet_time - now,
                        check.quiet_time - grasp.lift.lift_flag_age())
        if not check.verify_lift:
            return False
        # quiet_time past the evidence and the contact's recheck, and the set-down probe on
        # top as on top of lift_distance: the probe must not take back the lift since the catch
        top = grasp.recheck_lift
        if remaining > 0.0:
            top = max(top, grasp.lift_height + p.lift_speed * remaining)
        target = min(max(grasp.lift_target, top + self._probe_depth()), p.max_lift_distance)
        if target <= grasp.lift_height + 1e-12:
            return False
        grasp.lift_target = target
        reason = ('the contact moved along the fingers' if top == grasp.recheck_lift
                  else f'tightened {check.quiet_time - remaining:.2f} s ago')
        self._message = f'{reason}: lifting on to {target:.4f} m'
        return True

    def _probe_depth(self) -> float:
        """How far the set-down probe lowers from the top of the lift [m]: ``probe_distance``,
        0 without the lift verification or without room for it under ``max_lift_distance``."""
        grasp = self._grasp
        assert grasp is not None
        check, p = grasp.lift_check, grasp.params
        if not check.verify_lift or p.lift_distance + check.probe_distance > p.max_lift_distance:
            return 0.0
        return check.probe_distance

    def _judge_lift(self, now: float) -> None:
        """End of the hold: LIFTED (or RELEASING) if the object is carried, else NOT_CARRIED."""
        grasp = self._grasp
        assert grasp is not None and grasp.lift is not None
        p = grasp.params
        verdict = grasp.lift.verdict()
        evidence = f': {verdict.reason}'
        if not verdict.carried:
            self._finish(Outcome.NOT_CARRIED, f'lift of {grasp.lift_height:.4f} m commanded, '
                         f'object not carried: {verdict.reason}')
        elif grasp.goal.release_after:
            grasp.outcome = Outcome.LIFTED
            self._last_outcome = Outcome.LIFTED
            self._arm_velocity = 0.0
            self._enter(GraspState.RELEASING, now)
            self._command(p.open_angle, p.release_speed)
            self._message = 'lifted and held; releasing' + evidence
        else:
            self._finish(Outcome.LIFTED, f'lifted {grasp.lift_height:.4f} m and held '
                         f'{p.hold_duration:g} s{evidence}')

    def _settled(self, now: float, command: float, floor: float, settle: float) -> bool:
        """True once the closing command has stayed at ``floor`` for ``settle`` seconds."""
        grasp = self._grasp
        assert grasp is not None
        if command <= floor:
            if grasp.at_min_since is None:
                grasp.at_min_since = now
            return now - grasp.at_min_since >= settle
        return False

    def _hold_ramp(self, now: float) -> None:
        """Freeze the ramp at the current command (restarts from there later)."""
        grasp = self._grasp
        assert grasp is not None
        if self._servo is not None:
            grasp.ramp_start_angle = self._servo.position
        grasp.phase_start = now

    def _contact(self, perception: PerceptionInput | None) -> bool:
        """Contact while closing: the perception's contact flags (either or both fingers,
        ``contact_mode``), or a deformation level (mean |tared filtered|) of at least
        ``contact_level``: a very soft object loads the fingers too slowly for the rate-based
        contact flag, and closing on until the servo stops crushes it."""
        if perception is None:
            return False
        left, right = perception.contact
        grasp = self._grasp
        if grasp is not None and grasp.params.contact_mode == 'both':
            flagged = bool(left and right)
        else:
            flagged = bool(left or right)
        level = deformation_level(perception.filtered)
        return flagged or (grasp is not None and level is not None
                           and 0.0 < grasp.params.contact_level <= level)

    def _enter_lifting(self, now: float, message: str) -> None:
        grasp = self._grasp
        assert grasp is not None
        self._enter(GraspState.LIFTING, now)
        grasp.drop = DropDetector(grasp.params)
        grasp.lift = LiftMonitor(grasp.lift_check, grasp.levels_zero())
        grasp.lift_target = grasp.params.lift_distance + self._probe_depth()
        perception = self._latest.perception
        if perception is not None and perception.data_valid \
                and fresh(perception.stamp, now, grasp.params.perception_timeout):
            grasp.drop.update(perception, now)  # references from the grip at lift start
        self._arm_velocity = grasp.params.lift_speed
        self._message = message

    def _finish_closed(self, command: float, perception: PerceptionInput | None) -> None:
        """Closed fully without a contact flag: NO_CONTACT, or CLOSED_ON_OBJECT on evidence."""
        grasp = self._grasp
        joint = self._latest.joint
        assert grasp is not None and joint is not None
        filtered = force = None
        if perception is not None and perception.data_valid:
            filtered = perception.filtered
            if perception.force_valid:
                force = perception.force
        evidence = closed_on_object_evidence(grasp.lift_check, command, joint.theta, filtered,
                                             force, joint.effort, grasp.free_current)
        if evidence:
            self._finish(Outcome.CLOSED_ON_OBJECT, 'closed fully without a contact flag, '
                         f'but on something (possibly squeezed): {evidence}')
        else:
            self._finish(Outcome.NO_CONTACT, 'closed fully without contact')

    # -- state changes and commands --------------------------------------------------------
    def _fault(self, flags: FaultFlag, message: str, outcome: Outcome = Outcome.FAULT) -> None:
        """Latch ``flags``: arm stopped, gripper held, FAULT; the grasp's outcome unless it
        had one already."""
        self._fault_flags |= flags
        self._halt(GraspState.FAULT, f'FAULT {flag_names(flags)}: {message}')
        if self._grasp is not None and self._grasp.outcome == Outcome.NONE:
            self._record_outcome(outcome)

    def _finish(self, outcome: Outcome, message: str) -> None:
        """End the grasp with ``outcome``: arm stopped, gripper held, DONE."""
        self._halt(GraspState.DONE, message)
        self._record_outcome(outcome)

    def _halt(self, state: GraspState, message: str) -> None:
        """Stop the arm and go to ``state`` (DONE or FAULT) with ``message``."""
        self._arm_velocity = 0.0
        self._state = state
        self._message = message

    def _record_outcome(self, outcome: Outcome) -> None:
        """The grasp reached ``outcome`` in this step."""
        grasp = self._grasp
        assert grasp is not None
        grasp.outcome = outcome
        self._last_outcome = outcome
        self._finished_pending = True

    def _enter(self, state: GraspState, now: float) -> None:
        grasp = self._grasp
        assert grasp is not None
        self._state = state
        grasp.phase_start = now
        if self._servo is not None:
            grasp.ramp_start_angle = self._servo.position

    def _command(self, position: float, speed: float) -> None:
        params = self._grasp.params if self._grasp is not None else self._params
        self._servo = ServoOutput(position=float(position), max_current=params.max_current,
                                  profile_velocity=float(speed))

    def _ramp(self, now: float, speed: float, floor: float, paced: bool = True) -> float:
        """The ramp's command at ``now`` [rad]: from ``ramp_start_angle`` towards ``floor``
        at ``speed``. ``paced``: never more than ``speed * ramp_lead`` beyond the command
        that was in force at the latest perception sample, i.e. the ramp waits for the
        sensors to see where it went (a perception trailing by 0.6 s at 0.25 rad/s would
        otherwise close 0.15 rad blind); when it waits, the ramp restarts from there."""
        grasp = self._grasp
        assert grasp is not None
        command = max(floor, grasp.ramp_start_angle - speed * (now - grasp.phase_start))
        perception = self._latest.perception
        if paced and perception is not None and math.isfinite(perception.stamp):
            seen = grasp.ramp_commands.at(perception.stamp, grasp.ramp_start_angle)
            bound = seen - speed * grasp.params.ramp_lead
            if command < bound:
                command = min(bound, self._servo.position if self._servo else bound)
                grasp.ramp_start_angle, grasp.phase_start = command, now
            grasp.ramp_commands.record(now, command)
        return command
