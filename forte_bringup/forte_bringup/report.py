"""Plots and tables of recorded grasps, from a FORTE bag (matplotlib Agg, no display).

:func:`traces_from_bag` cuts a bag into one :class:`GraspTrace` per grasp (by receive-time
windows) and decodes the topics a person wants to see; :func:`plot_grasp` draws one
figure per grasp with five panels sharing the time axis:

1. the six filtered (median 11, tared) channels, left finger solid, right dashed;
2. estimated grip force vs the simulator's true force per finger;
3. the PSD features (max over 10-50 Hz) per channel;
4. the finger-group moving variance with the slip threshold T and the true slip onsets
   (vertical lines) and the detector's slip flags (ticks);
5. servo command and lift height.

A bag recorded from a namespaced graph (``namespace:=right``: ``/right/tactile/state``, ...)
is read in its namespace: ``traces_from_bag(..., namespace=None)`` detects it, or refuses a
bag holding several namespaces' FORTE topics and asks for one
(:mod:`forte_driver.replay.bag_namespace`).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from forte_driver.replay.bag_namespace import read_namespaced
from forte_perception.evaluation.slip_metrics import format_value
from forte_ros.contract import CHANNEL_NAMES, stamp_seconds

#: Slip threshold T of the paper [dB^2].
SLIP_THRESHOLD = 2.0


@dataclass
class GraspTrace:
    """Time series of one grasp, times in seconds from the window start.

    Attributes
    ----------
    label : str
        e.g. ``raspberry / FORTE``.
    state_time : (n,) perception times; filtered (n, 6); force (n,); force_valid (n,);
    psd_max_db (n, 6); finger_variance (n, 2); slip (n,) bool
    truth_time : (m,) ground-truth times; true_force (m, 2); lift_height (m,);
    slip_onset_times : list of true slip onset times
    command_time : (k,) servo command times; command (k,) [rad]
    outcome : dict
        The Grasp result fields and the final ground-truth object state.
    """

    label: str
    state_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    filtered: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    force: np.ndarray = field(default_factory=lambda: np.zeros(0))
    force_valid: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    psd_max_db: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    finger_variance: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    slip: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    truth_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    true_force: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    lift_height: np.ndarray = field(default_factory=lambda: np.zeros(0))
    slip_onset_times: list[float] = field(default_factory=list)
    command_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    command: np.ndarray = field(default_factory=lambda: np.zeros(0))
    outcome: dict = field(default_factory=dict)


def _stamp(message) -> float:
    return stamp_seconds(message.header.stamp)


def traces_from_bag(bag: str | Path, windows: Sequence[tuple[str, int, int]],
                    namespace: str | None = None) -> list[GraspTrace]:
    """One trace per ``(label, first_log_time_ns, last_log_time_ns)`` window of the bag.

    Messages are assigned by their receive (log) time; within a trace, times are header
    stamps (sample times) relative to the first perception stamp of the window.

    Parameters
    ----------
    bag : str or Path
        rosbag2 folder or ``.mcap`` file.
    windows : sequence of (str, int, int)
        Label, first and last receive time [ns] of each grasp.
    namespace : str, optional
        Namespace of the graph that recorded the bag (``right``, ``/right``; ``/`` for the
        root); None: the only one whose topics the bag holds.

    Raises
    ------
    ValueError
        If the bag holds the topics of several namespaces and none is given, or none in
        the given one (:func:`forte_driver.replay.bag_namespace.choose_namespace`).
    """
    from rclpy.serialization import deserialize_message

    from forte_msgs.msg import ServoCommand, SimGroundTruth, TactileState

    classes = {'tactile/state': TactileState, 'sim/ground_truth': SimGroundTruth,
               'gripper/command': ServoCommand}
    rows: list[dict[str, list]] = [{key: [] for key in classes} for _ in windows]
    starts = np.array([w[1] for w in windows])
    _, found = read_namespaced(bag, tuple(classes), namespace)
    for name, messages in found.items():
        for message in messages:
            index = int(np.searchsorted(starts, message.log_time, side='right')) - 1
            if index < 0 or message.log_time > windows[index][2]:
                continue
            rows[index][name].append(deserialize_message(message.data, classes[name]))
    traces = []
    for (label, _, _), row in zip(windows, rows):
        states, truths, commands = row['tactile/state'], row['sim/ground_truth'], \
            row['gripper/command']
        origin = _stamp(states[0]) if states else (_stamp(truths[0]) if truths else 0.0)
        trace = GraspTrace(label)
        if states:
            trace.state_time = np.array([_stamp(m) for m in states]) - origin
            trace.filtered = np.array([m.filtered for m in states], dtype=float)
            trace.force = np.array([m.force for m in states], dtype=float)
            trace.force_valid = np.array([m.force_valid for m in states], dtype=bool)
            trace.psd_max_db = np.array([m.psd_max_db for m in states], dtype=float)
            trace.finger_variance = np.array([m.finger_variance for m in states], dtype=float)
            trace.slip = np.array([m.slip for m in states], dtype=bool)
        if truths:
            trace.truth_time = np.array([_stamp(m) for m in truths]) - origin
            trace.true_force = np.array([m.finger_force for m in truths], dtype=float)
            trace.lift_height = np.array([m.lift_height for m in truths], dtype=float)
            onsets = np.array([m.slip_onsets for m in truths])
            rises = np.flatnonzero(np.diff(onsets) > 0) + 1
            trace.slip_onset_times = [float(trace.truth_time[i]) for i in rises]
        if commands:
            trace.command_time = np.array([_stamp(m) for m in commands]) - origin
            trace.command = np.array([m.position for m in commands], dtype=float)
        traces.append(trace)
    return traces


def plot_grasp(trace: GraspTrace, path: str | Path) -> Path:
    """Draw the five-panel figure of one grasp to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(5, 1, figsize=(10, 12), sharex=True,
                                gridspec_kw={'hspace': 0.12})
    colors = plt.rcParams['axes.prop_cycle'].by_key()['color']
    t = trace.state_time
    ax = axes[0]
    _plot_channels(ax, t, trace.filtered, colors, linewidth=0.9)
    ax.set_ylabel('filtered\n[normalised]')
    _legend(ax, ncol=3)
    ax.set_title(_title(trace), fontsize=11)

    ax = axes[1]
    if trace.true_force.shape[0]:
        ax.plot(trace.truth_time, trace.true_force[:, 0], color='0.55', linewidth=1.0,
                label='true, left finger')
        ax.plot(trace.truth_time, trace.true_force[:, 1], color='0.55', linewidth=1.0,
                linestyle='--', label='true, right finger')
    if t.size:
        estimate = np.where(trace.force_valid, trace.force, np.nan)
        ax.plot(t, estimate, color=colors[3], linewidth=1.2, label='estimated (SVR)')
    ax.set_ylabel('grip force [N]')
    _legend(ax)

    ax = axes[2]
    _plot_channels(ax, t, trace.psd_max_db, colors, linewidth=0.8)
    ax.set_ylabel('PSD max 10-50 Hz\n[dB re 1/Hz]')

    ax = axes[3]
    if trace.finger_variance.shape[0]:
        ax.plot(t, trace.finger_variance[:, 0], color=colors[0], label='left finger')
        ax.plot(t, trace.finger_variance[:, 1], color=colors[1], linestyle='--',
                label='right finger')
        flags = t[trace.slip]
        if flags.size:
            ax.plot(flags, np.full(flags.size, SLIP_THRESHOLD * 1.1), '|', color='red',
                    markersize=8, label='slip flag')
    ax.axhline(SLIP_THRESHOLD, color='k', linewidth=0.8, linestyle=':',
               label=f'threshold T = {SLIP_THRESHOLD:g} dB²')
    for index, onset in enumerate(trace.slip_onset_times):
        ax.axvline(onset, color='red', alpha=0.35, linewidth=1.0,
                   label='true slip onset' if index == 0 else None)
    ax.set_ylabel('moving variance\n[dB²]')
    _legend(ax)

    ax = axes[4]
    if trace.command.size:
        ax.step(trace.command_time, np.degrees(trace.command), where='post', color=colors[4],
                label='servo command')
    ax.set_ylabel('servo command [deg]')
    ax.set_xlabel('time [s]')
    twin = ax.twinx()
    if trace.lift_height.size:
        twin.plot(trace.truth_time, 1000.0 * trace.lift_height, color=colors[5],
                  label='lift height')
    twin.set_ylabel('lift height [mm]')
    handles = ax.get_legend_handles_labels()
    twin_handles = twin.get_legend_handles_labels()
    ax.legend(handles[0] + twin_handles[0], handles[1] + twin_handles[1], fontsize=7,
              loc='upper left')
    for ax in axes:
        ax.grid(alpha=0.3)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90, bbox_inches='tight')
    plt.close(figure)
    return path


def _plot_channels(ax, t: np.ndarray, values: np.ndarray, colors: Sequence[str],
                   linewidth: float) -> None:
    """The six channels of ``values`` (n, 6) over ``t``: one colour per position along the
    finger, left finger solid, right dashed (nothing if there are no rows)."""
    if not values.shape[0]:
        return
    for channel, name in enumerate(CHANNEL_NAMES):
        ax.plot(t, values[:, channel], color=colors[channel % 3],
                linestyle='-' if channel < 3 else '--', linewidth=linewidth, label=name)


def _legend(ax, ncol: int = 1) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(ncol=ncol, fontsize=7, loc='upper left')


def _title(trace: GraspTrace) -> str:
    outcome = trace.outcome
    parts = [trace.label]
    if outcome.get('outcome'):
        parts.append(f"outcome {outcome['outcome']}")
    if outcome.get('object_state'):
        parts.append(f"object {outcome['object_state']}")
    if not math.isnan(outcome.get('lift_height', math.nan)):
        parts.append(f"lift {1000 * outcome['lift_height']:.1f} mm")
    return ' | '.join(parts)


def outcome_table(rows: Sequence[dict]) -> str:
    """Markdown table of grasp outcomes (one row per grasp).

    The column "agrees" says whether the controller's outcome and the ground truth agree on
    whether the object was carried (:func:`forte_evaluation.metrics.carrying_agreement`, as the
    evaluation judges it): ``yes``, ``NO``, or ``-`` where the outcome makes no claim about
    carrying or the truth cannot judge it (BROKEN, CRUSHED). A missing number prints ``n/a``.
    """
    from forte_evaluation.metrics import carrying_agreement

    header = ['object', 'controller', 'outcome', 'object (truth)', 'object height [mm]',
              'agrees', 'lift [mm]', 'final force [N]', 'max true force [N]', 'slip events',
              'tightening [deg]', 'true slip onsets', 'duration [s]']
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '|'.join('---' for _ in header) + '|']
    for row in rows:
        outcome = row.get('outcome', '')
        height = row.get('object_height', math.nan)
        state = row.get('object_state', '')
        agrees = {True: 'yes', False: 'NO', None: '-'}[carrying_agreement(outcome, state)]
        cells = [row.get('object', ''), row.get('controller', ''), outcome, state,
                 format_value(1000 * height, 1), agrees,
                 format_value(1000 * row.get('lift_height', math.nan), 1),
                 format_value(row.get('final_force', math.nan)),
                 format_value(row.get('max_true_force', math.nan)),
                 str(row.get('slip_events', '')),
                 format_value(math.degrees(row.get('tightening', math.nan))),
                 str(row.get('true_slip_onsets', '')),
                 format_value(row.get('duration', math.nan), 1)]
        lines.append('| ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)
