"""Does the gripper carry the object? Evidence checks of the grasp state machine (no rclpy).

:class:`~forte_control.state_machine.drop_detector.DropDetector` watches for a held object's
load *disappearing* (LIFTING, HOLDING). It cannot see an object that never left the table: the
fingers slide up it while FORTE's tightenings make force, deformation and joint current rise
as in a good grasp.
:class:`LiftMonitor` judges the lift from four physical facts (the physics, the thresholds and
what they were measured on: docs/control.md, "Lift verification"):

1. **A free object is centred by the fingers.** Hanging, only the two finger normal forces act
   on it horizontally, so they are equal; on the table, its friction can hold the object
   against one finger. Rule: the two fingers' levels agree (necessary, not sufficient).
2. **A carried object stops slipping.** A slip flag in the last ``quiet_time`` of LIFTING means
   the fingers still move along the object. Flags while HOLDING do not count against the
   verdict (with the arm still, only gravity can make the object slip, i.e. it hangs from the
   fingers), but they delay the probe of rule 3: gravity can also slide a hanging object all
   the way down onto the table, so the probe waits until the grip is quiet
   (:meth:`LiftMonitor.hold_quiet`).
3. **A carried object goes down with the fingers; a resting one unloads them.** The set-down
   probe lifts ``probe_distance`` more, holds and lowers back; the shear index (sum over fingers
   of distal - root) must not fall by more than ``probe_unload``. Only a fall means the table
   took load: a rise is more grip (a slip tightening during the probe) or more load. The
   reference is the grip's state after the last slip flag and tightening of the hold: an
   object that slid onto the table in the hold and was tightened on there read a *rise* of
   +0.06 against a reference taken while it still hung (closed loop, soda can seed 16). A
   slip flag or a tightening during the probe voids it (the glass bottle of seed 0 fell 25 mm
   onto the table as the probe began to lower, closed loop with 40-sample updates): the arm
   goes back up and the probe starts again on the quiet grip, at most ``phases.MAX_PROBES`` times.
4. **A carried object stays where the fingers hold it.** Fingers that slide up an object the
   table holds carry its contact toward their tips by the arm's travel, and the middle leg of
   each finger loses load share (:func:`middle_shift`, scale-free: a tightening changes the
   three channels alike). The pattern of the grip as it last changed (``contact_settle`` after
   the lift began or the last tightening, :class:`ContactTrack`) and that of the end of the lift
   must not differ by more than ``contact_shift``. A smooth slide on a light grip (the Pocky
   box: 2 mu N = 0.33 N < its 0.44 N weight) passes rules 1-2 and reverses the shear by only
   2 mu N in the probe (-0.0024 to -0.0038 against ``probe_unload``); its middle channels
   lost 0.0046-0.0083 of load share, carried objects' -0.0032 to +0.0025 (closed loop,
   seed 0).

The machine (``phases.GraspPhases._lift_on``) lifts on ``quiet_time`` past a tightening of
the lift: the object slid, possibly onto the table, and hangs only as high as the lift since.

Rules 1 and 3 compare levels, so they are measured from the open gripper: the finger levels
of the first ``balance_window`` of the grasp (:class:`OpenGripperLevels`) are the zero of the
lift's levels. The tare can be minutes old; the sensor drifts meanwhile (a random walk in each
channel) and would otherwise unbalance the fingers of a carried object.

Optionally (``use_wrench``, off by default) the wrist's vertical load must have grown by
``min_wrench_load`` since the lift began.

Closing fully without a contact flag (the contact flag is a *rate*; a very soft object loads
too slowly to trip it), :func:`closed_on_object_evidence` asks whether the gripper closed on
something: the joint stopped short of its command (blocked), the tactile deformation or the
force estimate is clearly above an empty gripper's, or the servo current rose above its
free-motion level.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, fields

from forte_control.parameters import LIFT_CHECK_PREFIX, range_problems
from forte_control.state_machine.types import WrenchInput
from forte_ros.contract import DISTAL, FINGER_CHANNELS, MIDDLE, N_CHANNELS, ROOT

__all__ = ['ContactTrack', 'LiftCheckParams', 'LiftMonitor', 'LiftVerdict', 'OpenGripperLevels',
           'closed_on_object_evidence', 'deformation_level', 'finger_levels', 'middle_shift',
           'pinned_against_one_finger']


@dataclass(frozen=True)
class LiftCheckParams:
    """Thresholds of the carried-object and closed-on-object checks.

    Levels are in the normalised tared units of the filtered channels (full scale 2.0).
    """

    verify_lift: bool = True            # False: LIFTED from the commanded lift alone (old)
    balance_window: float = 0.2         # averaging time of the finger levels [s]
    balance_floor: float = 0.006        # |left - right| level always allowed [normalised]
    balance_tolerance: float = 0.015    # plus this fraction of left + right [-]
    min_finger_level: float = 0.01      # each finger must be loaded this much [normalised]
    quiet_time: float = 1.0             # no slip flag in the last quiet_time of the lift [s]
    probe_distance: float = 0.002       # set-down probe: lift beyond, then lower this [m]
    probe_settle: float = 0.4           # wait after lowering before judging [s]
    probe_window: float = 0.3           # averaging of the shear index before / after [s]
    probe_unload: float = 0.0045        # shear index fall that means unloaded [normalised]
    use_wrench: bool = False            # require the wrist load below (needs wrench input)
    min_wrench_load: float = 0.1        # wrist load gained since the lift began [N]
    wrench_timeout: float = 0.1         # wrench freshness bound [s]
    stall_tolerance: float = 0.02       # joint short of a closed command: blocked [rad]
    loaded_level: float = 0.01          # mean |filtered| of a loaded gripper [normalised]
    loaded_force: float = 0.15          # valid force estimate of a loaded gripper [N]
    loaded_current: float = 0.1         # servo current rise over free closing [A]
    gross_slip_reaction: bool = True    # FORTE tightens on gross-slip evidence while lifting
    gross_slip_min_lift: float = 0.004  # commanded lift before the balance evidence counts [m]
    gross_slip_decay: float = 0.2       # deformation fall below its lift peak that counts [-]
    gross_slip_interval: float = 0.2    # least time between two gross-slip tightenings [s]
    contact_settle: float = 0.4         # grip change to the contact's first placing [s]
    contact_shift: float = 0.0035       # middle channels' share lost: contact moved [normalised]

    def problems(self) -> list[str]:
        """Reasons why these thresholds are unusable (empty when valid).

        The ranges are those of :data:`forte_control.parameters.LIFT_CHECK_PARAMETERS`, the
        node's descriptors of the same thresholds.
        """
        values = {LIFT_CHECK_PREFIX + item.name: getattr(self, item.name)
                  for item in fields(self)}
        return range_problems(values)


@dataclass(frozen=True)
class LiftVerdict:
    """Outcome of the lift verification."""

    carried: bool
    reason: str       # the evidence, with its numbers


def shear_index(filtered: tuple[float, ...] | None) -> float | None:
    """Shear pattern of both fingers: sum over fingers of (distal - root) channel.

    Returns None without 6 finite values. Only its *change* at constant grip is used: the
    normal load raises distal and root alike in proportion, the tangential load on the pad
    raises the distal and lowers the root pressure.
    """
    if not _all_channels_finite(filtered):
        return None
    return sum(filtered[channels[DISTAL]] - filtered[channels[ROOT]]
               for channels in FINGER_CHANNELS)


def finger_levels(filtered: tuple[float, ...] | None, zero: tuple[float, float] = (0.0, 0.0)
                  ) -> tuple[float, float] | None:
    """Deformation level of each finger: sum of its three tared filtered channels.

    Parameters
    ----------
    filtered : tuple of 6 float or None
        Channels in contract order (left distal, middle, root, right distal, middle, root).
    zero : tuple of 2 float
        (left, right) levels that read as unloaded, subtracted (:class:`OpenGripperLevels`)
        [normalised].

    Returns
    -------
    tuple of 2 float or None
        (left, right) [normalised]; None without 6 finite values.
    """
    if not _all_channels_finite(filtered):
        return None
    left, right = (sum(filtered[channel] for channel in channels) for channels in FINGER_CHANNELS)
    return left - zero[0], right - zero[1]


def pinned_against_one_finger(filtered: tuple[float, ...] | None, zero: tuple[float, float],
                              min_share: float, floor: float) -> str:
    """Loading evidence: the object pinned against one finger, the other barely loaded.

    A heavy object that the first finger to touch pushes across the table is held there by
    the table's friction: that finger alone can reach the force target while the other has
    hardly touched. Lifted from there, the table's support goes and nothing holds the
    object but a one-sided grip: the fingers slide on it, smoothly, before any stick-slip
    rings.

    Parameters
    ----------
    filtered : tuple of 6 float or None
        Tared filtered channels in contract order.
    zero : tuple of 2 float
        (left, right) levels of the open gripper to subtract [normalised].
    min_share : float
        Smallest weaker / stronger finger level ratio of a grip of both fingers [-] (0: off).
    floor : float
        Stronger level below which there is no evidence (an unloaded gripper) [normalised].

    Returns
    -------
    str
        The evidence with its numbers; empty when there is none.
    """
    levels = finger_levels(filtered, zero)
    if levels is None or min_share <= 0.0:
        return ''
    left, right = levels
    stronger, weaker = max(left, right), min(left, right)
    if stronger <= floor or weaker >= min_share * stronger:
        return ''
    return (f'finger levels {left:.4f} / {right:.4f}: the weaker below {min_share:g} of the '
            'stronger, the object pinned against one finger')


def _all_channels_finite(filtered: tuple[float, ...] | None) -> bool:
    """True if ``filtered`` holds a finite value for each of the contract's channels."""
    return (filtered is not None and len(filtered) == N_CHANNELS
            and all(math.isfinite(value) for value in filtered))


def deformation_level(filtered: tuple[float, ...] | None) -> float | None:
    """Mean absolute tared filtered value over the finite channels (None if there is none)."""
    if filtered is None:
        return None
    values = [abs(v) for v in filtered if math.isfinite(v)]
    return sum(values) / len(values) if values else None


def middle_shift(start: tuple[float, ...], end: tuple[float, ...], floor: float
                 ) -> float | None:
    """Load share the middle channels lost between two channel patterns, at the end's scale.

    Per finger ``middle_start * level_end / level_start - middle_end`` (level: the sum of the
    finger's three channels), summed over both fingers. A change of grip scales a finger's
    three channels alike and leaves it 0; a contact moving from between the distal and the
    middle leg toward the fingertip unloads the middle leg relative to the others.

    Parameters
    ----------
    start, end : tuple of 6 float
        Mean tared filtered channels in contract order [normalised].
    floor : float
        Least level of each finger in both patterns [normalised].

    Returns
    -------
    float or None
        The shift [normalised] (positive: the middle channels lost load share); None if a
        finger is below ``floor`` in either pattern.
    """
    shift = 0.0
    for channels in FINGER_CHANNELS:
        level_start = sum(start[channel] for channel in channels)
        level_end = sum(end[channel] for channel in channels)
        if min(level_start, level_end) < floor:
            return None
        middle = channels[MIDDLE]
        shift += start[middle] * level_end / level_start - end[middle]
    return shift


class ContactTrack:
    """Where the contact sits on the fingers, after the grip last changed and at the end of
    the lift (rule 4 of :class:`LiftMonitor`).

    The pattern of the first ``window`` seconds that start ``settle`` after the grip last
    changed (the lift began or the controller tightened: the weight transfers and a slipping
    object is caught within that time) and the pattern of the last ``window`` seconds of the
    lift.

    Parameters
    ----------
    settle : float
        Time from a grip change to the first pattern [s].
    window : float
        Averaging time of each pattern [s].
    """

    def __init__(self, settle: float, window: float) -> None:
        self.settle = settle
        self.window = window
        self._change: float | None = None     # stamp of the last grip change [s]
        self._latest = -math.inf               # stamp of the latest sample [s]
        self._start: list[float] = [0.0] * N_CHANNELS
        self._start_count = 0
        self._tail: deque[tuple[float, tuple[float, ...]]] = deque()

    def grip_changed(self) -> None:
        """The grip changed (a tightening) after the latest sample: the first pattern again."""
        self._change = self._latest
        self._start = [0.0] * N_CHANNELS
        self._start_count = 0

    def update(self, stamp: float, filtered: tuple[float, ...]) -> None:
        """Take one valid sample of the lift (6 finite tared filtered channels)."""
        if self._change is None:
            self._change = stamp  # the lift began
        self._latest = stamp
        begin = self._change + self.settle
        if begin <= stamp < begin + self.window:
            self._start = [total + value for total, value in zip(self._start, filtered,
                                                                 strict=True)]
            self._start_count += 1
        self._tail.append((stamp, tuple(filtered)))
        while self._tail and self._tail[0][0] <= stamp - self.window:
            self._tail.popleft()

    def patterns(self) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
        """(first, last) mean patterns; None unless the first window is complete and over
        before the last one begins."""
        if self._change is None or not self._start_count or not self._tail:
            return None
        if self._tail[0][0] < self._change + self.settle + self.window:
            return None
        first = tuple(total / self._start_count for total in self._start)
        last = tuple(sum(item[1][channel] for item in self._tail) / len(self._tail)
                     for channel in range(N_CHANNELS))
        return first, last


class OpenGripperLevels:
    """The finger levels of the open gripper at the start of a grasp: the lift check's zero.

    The mean of :func:`finger_levels` over the samples of the first ``window`` seconds after
    the first one (the fingers are still open: a grasp starts from an open gripper). A start
    whose level exceeds ``limit`` on a finger is a loaded start (the gripper already touches
    something); its load is real, not drift, and the zero is then (0, 0).

    Parameters
    ----------
    window : float
        Averaging time from the first sample [s].
    limit : float
        Largest |finger level| taken for drift [normalised].
    """

    def __init__(self, window: float, limit: float) -> None:
        self.window = window
        self.limit = limit
        self._first: float | None = None
        self._sums = [0.0, 0.0]
        self._count = 0

    def update(self, stamp: float, filtered: tuple[float, ...] | None) -> None:
        """Take one valid perception sample (stamp [s], tared filtered channels)."""
        levels = finger_levels(filtered)
        if levels is None:
            return
        if self._first is None:
            self._first = stamp
        if stamp - self._first <= self.window:
            self._sums = [total + level for total, level in zip(self._sums, levels, strict=True)]
            self._count += 1

    def zero(self) -> tuple[float, float]:
        """(left, right) levels to subtract [normalised]; (0, 0) without samples or for a
        loaded start."""
        if not self._count:
            return 0.0, 0.0
        left, right = (total / self._count for total in self._sums)
        if max(abs(left), abs(right)) > self.limit:
            return 0.0, 0.0
        return left, right


class LiftMonitor:
    """Collect the evidence of one lift (LIFTING and HOLDING) and judge it at the end.

    Parameters
    ----------
    params : LiftCheckParams
    zero : tuple of 2 float
        Finger levels (left, right) that read as unloaded (:class:`OpenGripperLevels`)
        [normalised].
    """

    def __init__(self, params: LiftCheckParams, zero: tuple[float, float] = (0.0, 0.0)) -> None:
        self.params = params
        self.zero = zero
        # (stamp, left level, right level, shear index)
        self._levels: deque[tuple[float, float, float, float]] = deque()
        self._probe_reference: float | None = None  # shear index before the probe
        self._probe_start = math.inf      # stamp at which the probe began [s]
        self._last_flag = -math.inf       # stamp of the last slip flag while lifting [s]
        self._last_hold_flag = -math.inf  # stamp of the last slip flag while holding [s]
        self._hold_start: float | None = None
        self._wrench_start: float | None = None
        self._wrench: WrenchInput | None = None
        self._now = -math.inf             # time of the latest update [s]
        self._peak_level = 0.0            # largest left + right level of the lift so far
        self._contact = ContactTrack(params.contact_settle, params.probe_window)
        self._latest = -math.inf          # stamp of the latest sample [s]

    def update(self, stamp: float, filtered: tuple[float, ...] | None, slip_flag: bool,
               holding: bool, wrench: WrenchInput | None = None, now: float | None = None
               ) -> None:
        """Feed one fresh, valid perception sample of the lift.

        Parameters
        ----------
        stamp : float
            Sample time of the perception [s].
        filtered : tuple of 6 float or None
            Tared filtered channels.
        slip_flag : bool
            The slip detector (active, valid data) flagged slip since the previous sample.
        holding : bool
            True in HOLDING (arm stopped), False while LIFTING.
        wrench : WrenchInput, optional
            Latest wrist reading (used when fresh at ``now``).
        now : float, optional
            Current time for the wrench freshness [s] (default ``stamp``).
        """
        p = self.params
        levels = finger_levels(filtered, self.zero)
        if levels is not None:
            self._levels.append((stamp, levels[0], levels[1], shear_index(filtered)))
            self._peak_level = max(self._peak_level, levels[0] + levels[1])
            keep = max(p.balance_window, p.probe_window)
            while self._levels and self._levels[0][0] < stamp - keep:
                self._levels.popleft()
            if not holding:
                self._contact.update(stamp, filtered)
        self._latest = max(self._latest, stamp)
        if holding and self._hold_start is None:
            self._hold_start = stamp
        if slip_flag and not holding:
            self._last_flag = max(self._last_flag, stamp)
        elif slip_flag:
            self._last_hold_flag = max(self._last_hold_flag, stamp)
        now = stamp if now is None else now
        self._now = now
        if wrench is not None and math.isfinite(wrench.force_z) \
                and now - wrench.stamp <= p.wrench_timeout:
            if self._wrench_start is None:
                self._wrench_start = wrench.force_z
            self._wrench = wrench

    def _mean_shear(self) -> float | None:
        recent = [item[3] for item in self._levels
                  if item[0] >= self._levels[-1][0] - self.params.probe_window]
        return sum(recent) / len(recent) if recent else None

    def lift_flag_age(self) -> float:
        """Time from the last slip flag of the lift to the latest sample [s] (inf: none)."""
        return self._latest - self._last_flag if math.isfinite(self._last_flag) else math.inf

    def grip_changed(self) -> None:
        """The controller tightened the grip (after the latest sample). While lifting, the
        contact's place is taken again ``contact_settle`` later (rule 4)."""
        if self._hold_start is None:
            self._contact.grip_changed()

    def contact_moved(self) -> str:
        """Rule 4: the contact moved toward the fingertip after the grip last changed.

        Returns
        -------
        str
            The evidence with its numbers; empty when there is none.
        """
        p = self.params
        patterns = self._contact.patterns()
        if patterns is None:
            return ''
        shift = middle_shift(*patterns, p.min_finger_level)
        if shift is None or shift <= p.contact_shift:
            return ''
        return (f'the middle channels lost {shift:.4f} > {p.contact_shift:g} of their load share '
                'during the lift after the grip last changed: the contact moved toward the '
                'fingertips, i.e. the fingers slid up the object')

    def hold_quiet(self, quiet: float) -> bool:
        """True when no slip flag came in the last ``quiet`` seconds of the hold [s]."""
        return not self._levels or self._levels[-1][0] - self._last_hold_flag >= quiet

    def begin_probe(self) -> None:
        """The set-down probe starts: remember the shear index of the carried grip."""
        self._probe_reference = self._mean_shear() if self._levels else None
        self._probe_start = self._levels[-1][0] if self._levels else self._now

    def probe_disturbed(self) -> bool:
        """A slip flag came after the probe began: its reference no longer holds."""
        return math.isfinite(self._last_hold_flag) and self._last_hold_flag >= self._probe_start

    def _balance(self) -> tuple[float, float, float]:
        """Mean left and right finger levels over the balance window and the allowed
        difference."""
        p = self.params
        recent = [item for item in self._levels
                  if item[0] >= self._levels[-1][0] - p.balance_window]
        left = sum(item[1] for item in recent) / len(recent)
        right = sum(item[2] for item in recent) / len(recent)
        return left, right, p.balance_floor + p.balance_tolerance * (left + right)

    def unequal_while_lifting(self, lift_height: float) -> str:
        """Gross-slip evidence: the fingers still unequally loaded after the minimum lift.

        Parameters
        ----------
        lift_height : float
            Commanded lift so far [m].

        Returns
        -------
        str
            The evidence with its numbers; empty when there is none.
        """
        p = self.params
        if not self._levels or lift_height < p.gross_slip_min_lift:
            return ''
        left, right, allowed = self._balance()
        if abs(left - right) <= allowed or min(left, right) < p.min_finger_level:
            return ''
        return (f'finger levels {left:.4f} / {right:.4f} unequal by {abs(left - right):.4f} > '
                f'{allowed:.4f} after {lift_height * 1000:.1f} mm of lift: the table still '
                'holds the object')

    def deformation_decay(self) -> str:
        """Gross-slip evidence: the deformation level fell below its lift peak.

        Returns
        -------
        str
            The evidence with its numbers; empty when there is none.
        """
        p = self.params
        if not self._levels or self._peak_level < 2 * p.min_finger_level:
            return ''
        level = self._levels[-1][1] + self._levels[-1][2]
        if level >= (1.0 - p.gross_slip_decay) * self._peak_level:
            return ''
        return (f'deformation {level:.4f} fell below {1.0 - p.gross_slip_decay:g} x its lift '
                f'peak {self._peak_level:.4f}: the contact slides off')

    def verdict(self) -> LiftVerdict:
        """Judge the lift from the evidence so far (called when the hold is over)."""
        p = self.params
        if not p.verify_lift:
            return LiftVerdict(True, 'lift not verified (verify_lift off)')
        if not self._levels:
            return LiftVerdict(False, 'no tactile data during the lift to verify it')
        left, right, allowed = self._balance()
        pattern = f'finger levels {left:.4f} / {right:.4f}'
        if min(left, right) < p.min_finger_level:
            return LiftVerdict(False, f'{pattern}: a finger is not loaded')
        if abs(left - right) > allowed:
            return LiftVerdict(False, f'{pattern} unequal by {abs(left - right):.4f} > '
                               f'{allowed:.4f}: the table still holds the object')
        end = self._hold_start if self._hold_start is not None else self._levels[-1][0]
        if self._last_flag > end - p.quiet_time:
            return LiftVerdict(False, f'{pattern}; slip {end - self._last_flag:.2f} s before '
                               'the end of the lift: the fingers were still sliding')
        moved = self.contact_moved()
        if moved:
            return LiftVerdict(False, f'{pattern}; {moved}')
        evidence = f'{pattern} equal, no slip in the last {p.quiet_time:g} s of the lift'
        if self._probe_reference is not None:
            change = self._mean_shear() - self._probe_reference
            if change < -p.probe_unload:
                return LiftVerdict(False, f'{evidence}; set down {p.probe_distance * 1000:g} mm'
                                   f', shear index changed {change:+.4f}: the object does not '
                                   'hang from the fingers (the table took load)')
            evidence += f', shear index {change:+.4f} when set down'
        if p.use_wrench:
            if self._wrench is None or self._wrench_start is None \
                    or self._now - self._wrench.stamp > p.wrench_timeout:
                return LiftVerdict(False, f'{evidence}; no fresh wrist wrench')
            gained = self._wrench.force_z - self._wrench_start
            if gained < p.min_wrench_load:
                return LiftVerdict(False, f'{evidence}; wrist load grew {gained:.3f} N < '
                                   f'{p.min_wrench_load:g} N')
            evidence += f', wrist load +{gained:.3f} N'
        return LiftVerdict(True, evidence)


def closed_on_object_evidence(params: LiftCheckParams, command: float, theta: float,
                              filtered: tuple[float, ...] | None, force: float | None,
                              current: float | None, free_current: float | None) -> str:
    """Evidence that a gripper which closed fully without a contact flag holds something.

    Parameters
    ----------
    params : LiftCheckParams
    command : float
        The (closed) servo command [rad].
    theta : float
        Measured joint angle [rad].
    filtered : tuple of 6 float or None
        Latest tared filtered channels (None: no fresh valid perception).
    force : float or None
        Latest valid force estimate [N] (None: none).
    current : float or None
        Latest servo current [A] (None: not reported).
    free_current : float or None
        Servo current while closing freely at the start of the grasp [A].

    Returns
    -------
    str
        The evidence found, empty when the gripper closed on nothing.
    """
    found = []
    if math.isfinite(theta) and theta > command + params.stall_tolerance:
        found.append(f'joint stopped at {theta:.3f} rad, {theta - command:.3f} rad short of '
                     'the command')
    level = deformation_level(filtered)
    if level is not None and level >= params.loaded_level:
        found.append(f'deformation {level:.4f} >= {params.loaded_level:g}')
    if force is not None and math.isfinite(force) and force >= params.loaded_force:
        found.append(f'force {force:.3f} N >= {params.loaded_force:g} N')
    if current is not None and free_current is not None and math.isfinite(current) \
            and current - free_current >= params.loaded_current:
        found.append(f'servo current {current:.3f} A, +{current - free_current:.3f} A over '
                     'free closing')
    return '; '.join(found)
