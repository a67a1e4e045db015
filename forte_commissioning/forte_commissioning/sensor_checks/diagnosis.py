"""From a recording to every check's verdict and the findings: what to fix, where (pure).

A finding names one cause (``kind``), the channels it concerns and the fix, and explains
the failed checks it causes (a dead channel fails ``stuck`` and ``press_response``; a
channel pair swapped inside a finger fails ``press_order``): the report lists each cause
once. Finding kinds: ``swapped_fingers``, ``swapped_pair``, ``wrong_finger``, ``reversed``,
``dead``, ``no_response``, ``stuck``, ``railed``, ``offset``, ``noisy``, ``leaking``,
``order``, ``shift``, ``press_not_detected``, ``sample_rate``, ``dropped_frames``,
``corrupt_frames``, ``host_rate``, ``missing_phase``.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from forte_commissioning.sensor_checks.idle import (
    FAIL,
    SKIP,
    CheckResult,
    IdleStatistics,
    idle_checks,
    idle_statistics,
    link_checks,
)
from forte_commissioning.sensor_checks.leak import leak_checks, leak_levels
from forte_commissioning.sensor_checks.limits import DEFAULT_LIMITS, CommissioningLimits
from forte_commissioning.sensor_checks.press import PressAnalysis, analyse_presses, press_checks
from forte_commissioning.sensor_checks.run_record import CommissioningRecording
from forte_ros.contract import CHANNEL_NAMES, FINGER_CHANNELS, FINGER_NAMES, N_CHANNELS

__all__ = ['CommissioningResult', 'Finding', 'evaluate']

_SLOTS = ('distal', 'middle', 'root')


@dataclass(frozen=True)
class Finding:
    """One cause found, with its fix.

    Attributes
    ----------
    kind : str
        See the module docstring.
    channels : tuple of int
        Channels concerned (contract indices; empty for the link or both fingers).
    message : str
        What was measured.
    fix : str
        What to do about it.
    """

    kind: str
    channels: tuple[int, ...]
    message: str
    fix: str

    @property
    def channel_names(self) -> tuple[str, ...]:
        """Names of :attr:`channels`."""
        return tuple(CHANNEL_NAMES[channel] for channel in self.channels)


@dataclass
class CommissioningResult:
    """Everything a commissioning run concluded.

    Attributes
    ----------
    checks : list of CheckResult
    findings : list of Finding
    idle : IdleStatistics or None
    presses : PressAnalysis or None
    leak_relative : numpy.ndarray, shape (6,)
        Each channel's retained level share relative to the others (NaN: not judged).
    """

    checks: list[CheckResult]
    findings: list[Finding]
    idle: IdleStatistics | None = None
    presses: PressAnalysis | None = None
    leak_relative: np.ndarray = field(default_factory=lambda: np.full(N_CHANNELS, np.nan))

    @property
    def passed(self) -> bool:
        """True when no check failed."""
        return not any(check.status == FAIL for check in self.checks)

    def failed(self, check: str | None = None) -> list[CheckResult]:
        """The failed checks (of name ``check`` if given)."""
        return [result for result in self.checks if result.status == FAIL
                and (check is None or result.check == check)]


def _finger_of(channel: int) -> int:
    return 0 if channel in FINGER_CHANNELS[0] else 1


def _status(checks: list[CheckResult], check: str, subject: str) -> str | None:
    for result in checks:
        if result.check == check and result.subject == subject:
            return result.status
    return None


def _link_findings(checks: list[CheckResult]) -> list[Finding]:
    fixes = {
        'sample_rate': 'the board does not sample at 2 kHz: send SET_RATE 2000 (the driver '
                       'does at configure) and check the firmware\'s timer (docs/firmware.md)',
        'dropped_frames': 'frames are lost between board and host: use a short USB cable '
                          'straight to the computer (no hub), check the host load',
        'corrupt_frames': 'frames arrive damaged: replace or shorten the USB cable, keep it '
                          'away from the servo power lines, check the common ground',
        'host_rate': 'the host does not keep up with 2 kHz: lighten its load or run the '
                     'driver on a core of its own',
    }
    return [Finding(result.check, (), result.detail, fixes[result.check])
            for result in checks if result.subject == 'link' and result.status == FAIL]


def _idle_findings(checks: list[CheckResult], analysis: PressAnalysis | None,
                   limits: CommissioningLimits) -> list[Finding]:
    findings = []
    responds = (analysis.responds(limits) if analysis is not None
                else (np.zeros(N_CHANNELS, bool), np.zeros(N_CHANNELS, bool)))
    for channel, name in enumerate(CHANNEL_NAMES):
        pin = f'GPIO{channel + 1} = ADC1_CH{channel}'
        if _status(checks, 'stuck', name) == FAIL:
            if not (responds[0][channel] or responds[1][channel]):
                findings.append(Finding('dead', (channel,), f'{name} is dead: a constant '
                                        'reading, no noise, no response to any press',
                                        f'check the transducer\'s supply and its signal wire '
                                        f'to the ADC pin ({pin}, docs/hardware.md wiring), '
                                        're-seat both connectors; replace the transducer if '
                                        'it stays constant'))
            else:
                findings.append(Finding('stuck', (channel,), f'{name} is constant at rest '
                                        'but responds to a press', 'check the ADC pin '
                                        f'({pin}) for a solder bridge; update the firmware'))
        if _status(checks, 'railed', name) == FAIL:
            findings.append(Finding('railed', (channel,), f'{name} sits at a rail of its '
                                    'range', 'the transducer is saturated (a pinched or '
                                    'kinked tube holding pressure, a finger pressed by its '
                                    f'mount) or its ADC pin ({pin}) touches supply or ground'))
        if _status(checks, 'offset', name) == FAIL:
            findings.append(Finding('offset', (channel,), f'{name}: zero offset beyond '
                                    f'+-{limits.offset_limit:g}', 'check that nothing presses '
                                    'the finger at rest and that the tube is not kinked; '
                                    'check the transducer\'s supply'))
        if _status(checks, 'noise', name) == FAIL:
            findings.append(Finding('noisy', (channel,), f'{name} is noisy (> '
                                    f'{limits.noise_limit_lsb:g} LSB rms at rest)',
                                    f'check its signal wire to {pin}: shielding, ground, a '
                                    'loose crimp; keep it away from the servo power lines; '
                                    'check the transducer\'s supply decoupling'))
    return findings


def _press_findings(analysis: PressAnalysis, checks: list[CheckResult],
                    limits: CommissioningLimits, dead: set[int]) -> list[Finding]:
    findings = [Finding('press_not_detected', (), f'{FINGER_NAMES[finger]} {place} press: '
                        'no channel responded', 'repeat the press test and press firmly '
                        '(2-5 N) when prompted')
                for (finger, place), seen in analysis.detected.items() if not seen]
    own, foreign = analysis.responds(limits)
    wrong = [channel for channel in range(N_CHANNELS) if foreign[channel] and not own[channel]]
    if len(wrong) == N_CHANNELS:
        findings.append(Finding('swapped_fingers', (), 'every channel responds to a press '
                                'on the other finger only: the fingers are swapped',
                                'exchange the left and right finger\'s tube bundles (or '
                                'their connectors) so that the left finger feeds '
                                f'{", ".join(CHANNEL_NAMES[c] for c in FINGER_CHANNELS[0])} '
                                '(docs/hardware.md tubing map)'))
        wrong = []
    left = [channel for channel in wrong if _finger_of(channel) == 0]
    right = [channel for channel in wrong if _finger_of(channel) == 1]
    if len(left) == 1 and len(right) == 1:
        pair = (left[0], right[0])
        findings.append(Finding('swapped_pair', pair, f'{CHANNEL_NAMES[pair[0]]} and '
                                f'{CHANNEL_NAMES[pair[1]]} each respond to the other '
                                'finger: their tubes are swapped', 'exchange the tubes of '
                                f'{CHANNEL_NAMES[pair[0]]} and {CHANNEL_NAMES[pair[1]]} at '
                                'the transducers (docs/hardware.md tubing map)'))
    else:
        findings += [Finding('wrong_finger', (channel,), f'{CHANNEL_NAMES[channel]} responds '
                             'to the other finger', 'trace its tube back to the finger and '
                             'reconnect it as the tubing map says') for channel in wrong]
    for channel, name in enumerate(CHANNEL_NAMES):
        if _status(checks, 'press_sign', name) == FAIL:
            findings.append(Finding('reversed', (channel,), f'{name} reads negative on a '
                                    'press', 'its transducer\'s ports are reversed: swap its '
                                    'two tubes (inner channel to port P1, outer to P2)'))
        elif (not own[channel] and not foreign[channel] and channel not in dead
              and _status(checks, 'press_response', name) == FAIL):
            findings.append(Finding('no_response', (channel,), f'{name} does not respond to '
                                    'a press although it is live', 'its tube is off, '
                                    'blocked or leaking badly: check the tube from the '
                                    'finger\'s port to the transducer'))
    for finger, channels in enumerate(FINGER_CHANNELS):
        findings += _finger_findings(analysis, checks, finger, channels)
    return findings


def _finger_findings(analysis: PressAnalysis, checks: list[CheckResult], finger: int,
                     channels: tuple[int, ...]) -> list[Finding]:
    name = FINGER_NAMES[finger]
    if _status(checks, 'press_order', name) == FAIL:
        levels = np.abs(analysis.responses[(finger, 'tip')][list(channels)])
        order = tuple(int(slot) for slot in np.argsort(-levels))
        misplaced = [slot for slot in range(3) if order[slot] != slot]
        if len(misplaced) == 2:
            pair = tuple(channels[slot] for slot in misplaced)
            return [Finding('swapped_pair', pair, f'{name} tip press reads '
                            f'{_SLOTS[misplaced[0]]} and {_SLOTS[misplaced[1]]} in the wrong '
                            f'order: {CHANNEL_NAMES[pair[0]]} and {CHANNEL_NAMES[pair[1]]} '
                            'are swapped', f'exchange the tubes of {CHANNEL_NAMES[pair[0]]} '
                            f'and {CHANNEL_NAMES[pair[1]]} at the transducers '
                            '(docs/hardware.md tubing map)')]
        return [Finding('order', channels, f'{name} tip press does not read distal > middle '
                        f'> root (largest first: {", ".join(_SLOTS[s] for s in order)})',
                        f'reconnect the {name} finger\'s three tubes as the tubing map says; '
                        'check them for kinks')]
    if _status(checks, 'press_shift', name) == FAIL:
        return [Finding('shift', channels, f'{name}: a root press does not move the response '
                        'toward the root pair', f'check the {name} root pair\'s tube for a '
                        'kink or blockage and the tubing map order')]
    return []


def _leak_findings(checks: list[CheckResult]) -> list[Finding]:
    return [Finding('leaking', (CHANNEL_NAMES.index(result.subject),),
                    f'{result.subject} leaks: {result.detail}',
                    'reseal the channel pair: the tube on its port, the port in the finger '
                    '(docs/hardware.md, leak test); repeat the leak test')
            for result in checks if result.check == 'leak' and result.status == FAIL]


def _skip_explained(checks: list[CheckResult], leaking: set[int]) -> list[CheckResult]:
    """A finger's order and shift are not judged while one of its channels leaks."""
    fingers = {FINGER_NAMES[_finger_of(channel)] for channel in leaking}
    return [replace(result, status=SKIP, detail='not judged: a channel of this finger '
                    'leaks (see leak)')
            if result.check in ('press_order', 'press_shift') and result.subject in fingers
            and result.status == FAIL else result for result in checks]


def evaluate(recording: CommissioningRecording,
             limits: CommissioningLimits = DEFAULT_LIMITS) -> CommissioningResult:
    """Judge a commissioning recording: every check, the findings and their fixes.

    The recording needs a ``rest`` phase (the first is used for the idle statistics),
    press phases (finger and place) and a ``squeeze`` phase; a missing part makes its
    checks SKIP and adds a ``missing_phase`` finding.
    """
    checks = link_checks(recording.link, limits)
    findings: list[Finding] = []
    rest = next((phase for phase in recording.phases if phase.kind == 'rest'), None)
    frames = recording.frames[recording.rows(rest.start, rest.stop)] if rest else None
    if frames is None or len(frames) < 3:
        findings.append(Finding('missing_phase', (), 'no rest phase recorded', 'repeat'))
        return CommissioningResult(checks, findings + _link_findings(checks))
    idle = idle_statistics(frames)
    checks += idle_checks(idle, limits)
    presses = analyse_presses(recording, limits)
    if presses.responses:
        checks += press_checks(presses, limits)
    else:
        findings.append(Finding('missing_phase', (), 'no press recorded', 'repeat'))
    squeeze = next((phase for phase in recording.phases if phase.kind == 'squeeze'), None)
    levels = leak_levels(recording, squeeze, idle.offset, limits) if squeeze else None
    leak_results, relative = leak_checks(levels, limits)
    checks += leak_results
    leaking = {CHANNEL_NAMES.index(result.subject) for result in leak_results
               if result.status == FAIL}
    checks = _skip_explained(checks, leaking)
    findings += _link_findings(checks) + _idle_findings(checks, presses, limits)
    dead = {finding.channels[0] for finding in findings if finding.kind == 'dead'}
    if presses.responses:
        findings += _press_findings(presses, checks, limits, dead)
    findings += _leak_findings(checks)
    return CommissioningResult(checks, findings, idle, presses, relative)
