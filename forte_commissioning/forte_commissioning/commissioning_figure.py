"""The commissioning report's figure (matplotlib Agg, no display).

Three panels: (1) every channel over the run, its offset at rest removed, the protocol's
phases shaded and named; (2) each press's response per channel, the failed channels
marked; (3) the leak test: each channel's retained level share relative to the others,
with the threshold. The title carries the verdict.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from forte_commissioning.sensor_checks import CommissioningRecording, CommissioningResult
from forte_commissioning.sensor_checks.idle import FAIL
from forte_ros.contract import CHANNEL_NAMES, N_CHANNELS, SAMPLE_RATE

__all__ = ['draw_figure']

_PHASE_COLOURS = {'rest': '#ffffff', 'press': '#dbe9f6', 'squeeze': '#fde2c8'}


def _failed_channels(result: CommissioningResult) -> set[int]:
    return {CHANNEL_NAMES.index(check.subject) for check in result.checks
            if check.status == FAIL and check.subject in CHANNEL_NAMES}


def _plot_readings(axis, recording: CommissioningRecording, result: CommissioningResult,
                   colours: list[str]) -> None:
    offset = result.idle.offset if result.idle is not None else np.zeros(N_CHANNELS)
    first = recording.sequence[0]
    seconds = (recording.sequence - first) / SAMPLE_RATE
    step = max(len(seconds) // 4000, 1)
    for channel in range(N_CHANNELS):
        axis.plot(seconds[::step], recording.frames[::step, channel] - offset[channel],
                  color=colours[channel], linewidth=0.8, label=CHANNEL_NAMES[channel])
    for phase in recording.phases:
        left, right = (phase.start - first) / SAMPLE_RATE, (phase.stop - first) / SAMPLE_RATE
        axis.axvspan(left, right, color=_PHASE_COLOURS[phase.kind], zorder=0)
        if phase.kind != 'rest':
            axis.text(left, 0.02, phase.name.replace('press_', ''), rotation=90, fontsize=7,
                      va='bottom', transform=axis.get_xaxis_transform())
    axis.set_xlabel('time [s]')
    axis.set_ylabel('reading - offset at rest [-]')
    axis.legend(fontsize=7, ncol=3, loc='upper left')


def _plot_presses(axis, result: CommissioningResult, colours: list[str]) -> None:
    presses = result.presses
    if presses is None or not presses.responses:
        axis.text(0.5, 0.5, 'no press recorded', ha='center', transform=axis.transAxes)
        return
    names = [f'{("left", "right")[finger]} {place}' for finger, place in presses.responses]
    width = 0.8 / N_CHANNELS
    failed = _failed_channels(result)
    for channel in range(N_CHANNELS):
        values = [response[channel] for response in presses.responses.values()]
        positions = np.arange(len(names)) + (channel - N_CHANNELS / 2 + 0.5) * width
        axis.bar(positions, values, width, color=colours[channel],
                 edgecolor='red' if channel in failed else 'none', linewidth=1.5)
    axis.axhline(0.0, color='black', linewidth=0.6)
    axis.set_xticks(np.arange(len(names)), names)
    axis.set_ylabel('press response [-]')
    axis.set_title('guided press test (red edge: a failed check of that channel)', fontsize=9)


def _plot_leak(axis, result: CommissioningResult, colours: list[str], limit: float) -> None:
    shares = result.leak_relative
    axis.bar(np.arange(N_CHANNELS), np.nan_to_num(shares, nan=0.0), color=colours)
    axis.axhline(limit, color='red', linestyle='--', linewidth=1.0, label='leak threshold')
    axis.set_xticks(np.arange(N_CHANNELS), CHANNEL_NAMES, rotation=20, fontsize=7)
    axis.set_ylim(0.0, max(1.2, float(np.nanmax(shares, initial=1.0)) + 0.1))
    axis.set_ylabel('level kept / others [-]')
    axis.set_title('leak test (held squeeze)', fontsize=9)
    axis.legend(fontsize=7)


def draw_figure(recording: CommissioningRecording, result: CommissioningResult,
                path: str | os.PathLike, leak_limit: float = 0.75) -> Path:
    """Write the figure as PNG to ``path``; returns the path.

    Parameters
    ----------
    recording : CommissioningRecording
    result : CommissioningResult
        :func:`forte_commissioning.sensor_checks.evaluate` of ``recording``.
    path : path-like
        Output file (``.png``).
    leak_limit : float
        The leak threshold drawn in the third panel [-].
    """
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    colours = plt.rcParams['axes.prop_cycle'].by_key()['color'][:N_CHANNELS]
    figure = plt.figure(figsize=(11, 9), layout='constrained')
    grid = figure.add_gridspec(2, 2, height_ratios=(1.2, 1.0))
    _plot_readings(figure.add_subplot(grid[0, :]), recording, result, colours)
    _plot_presses(figure.add_subplot(grid[1, 0]), result, colours)
    _plot_leak(figure.add_subplot(grid[1, 1]), result, colours, leak_limit)
    verdict = 'PASS' if result.passed and not result.findings else 'FAIL'
    causes = ', '.join(f'{finding.kind}' + (f' ({", ".join(finding.channel_names)})'
                                             if finding.channels else '')
                       for finding in result.findings)
    figure.suptitle(f'FORTE sensor commissioning: {verdict}' + (f': {causes}' if causes
                                                                 else ''), fontsize=11)
    path = Path(path)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
