"""The commissioning report as text: the verdict, what to fix, every check (pure).

The figure (readings of each phase, the press responses and the leak shares) is drawn by
``forte_commissioning.commissioning_figure`` (matplotlib lives with the tools that draw).
"""
from __future__ import annotations

import math

from forte_commissioning.sensor_checks.diagnosis import CommissioningResult
from forte_commissioning.sensor_checks.idle import FAIL, PASS, SKIP

__all__ = ['text_report']


def _value(value: float, unit: str) -> str:
    if not math.isfinite(value):
        return ''
    return f'{value:.4g} {unit}'.rstrip()


def text_report(result: CommissioningResult, title: str = 'FORTE sensor commissioning',
                context: dict[str, str] | None = None) -> str:
    """The report: overall verdict, findings with their fixes, then every check.

    Parameters
    ----------
    result : CommissioningResult
    title : str
        First line.
    context : dict, optional
        ``label -> text`` lines printed under the title (device, date, fault injected...).

    Returns
    -------
    str
        The report, lines ending in newlines.
    """
    counts = {status: sum(check.status == status for check in result.checks)
              for status in (PASS, FAIL, SKIP)}
    verdict = PASS if result.passed and not result.findings else FAIL
    lines = [title, '=' * len(title)]
    lines += [f'{label}: {text}' for label, text in (context or {}).items()]
    lines += ['', f'VERDICT: {verdict}  ({counts[PASS]} PASS, {counts[FAIL]} FAIL, '
              f'{counts[SKIP]} SKIP)', '']
    if result.findings:
        lines.append('What to fix:')
        for number, finding in enumerate(result.findings, 1):
            where = f' [{", ".join(finding.channel_names)}]' if finding.channels else ''
            lines.append(f'{number}. {finding.kind}{where}: {finding.message}')
            lines.append(f'   fix: {finding.fix}')
    else:
        lines.append('Nothing to fix: every check passed.')
    lines += ['', 'Checks:', f'{"status":<6} {"check":<16} {"subject":<14} {"value":>16} '
              f'{"limit":>16}  detail']
    for check in result.checks:
        lines.append(f'{check.status:<6} {check.check:<16} {check.subject:<14} '
                     f'{_value(check.value, check.unit):>16} '
                     f'{_value(check.limit, check.unit):>16}  {check.detail}')
    return '\n'.join(lines) + '\n'
