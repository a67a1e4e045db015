"""Slip onset labels from a CSV file: the label source of recordings made on a robot.

In simulation the slip onsets of a recording come from the simulator's ground truth; on a
robot an operator marks them from a video of the trials (as the paper did) and writes them
to a CSV file that this module reads and attaches to the recordings
(:class:`~forte_perception.evaluation.labelled_recordings.LabelledRecording`).

Format (UTF-8 text, comma separated):

- lines starting with ``#`` and blank lines are ignored;
- the first other line is the header; it must contain the columns ``recording`` and
  ``onset_s`` (any order; other columns, e.g. ``note``, are ignored);
- every further line is one slip onset: ``recording`` = the file name of the labelled
  recording (``apple.npz``; the name without the folder, with or without ``.npz``) and
  ``onset_s`` = the onset time [s] from the recording's first sample (row 0 is 0.0 s; a
  recording of several trials counts from its first row, not from each trial's);
- a recording that was labelled and has no slip at all is listed once with an empty
  ``onset_s`` (``jar_trial3.npz,``): every recording a sweep uses must appear in the file,
  so that "no onset" is a statement of the operator, never a forgotten file.

Example::

    # operator: A. N. Other, video 2026-11-20, frame rate 60 Hz
    recording,onset_s,note
    apple.npz,4.213,stick-slip at the right finger
    apple.npz,7.950,
    jam_jar.npz,

A wrist force/torque drop as a third label source (an onset where the vertical load the
wrist sensor carries drops while the arm lifts) is not implemented: mark such onsets in
this file instead.
"""
from __future__ import annotations

import csv
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from forte_perception.evaluation.labelled_recordings import LabelledRecording

__all__ = ['LabelError', 'apply_onset_labels', 'load_onset_csv', 'recording_key',
           'write_onset_csv']

#: Columns the header must have.
REQUIRED_COLUMNS = ('recording', 'onset_s')


class LabelError(ValueError):
    """A label file that cannot be used (the message names the file, the line, the reason)."""


def recording_key(name: str | Path) -> str:
    """The key a recording is labelled under: its file name without folder and ``.npz``."""
    base = Path(str(name)).name
    return base[:-4] if base.endswith('.npz') else base


def _header(rows: list[tuple[int, list[str]]], path: Path) -> tuple[int, dict[str, int]]:
    if not rows:
        raise LabelError(f'{path}: no header line (expected columns '
                         f'{", ".join(REQUIRED_COLUMNS)})')
    line, cells = rows[0]
    columns = {cell.strip(): i for i, cell in enumerate(cells)}
    missing = [c for c in REQUIRED_COLUMNS if c not in columns]
    if missing:
        raise LabelError(f'{path}:{line}: header lacks column(s) {", ".join(missing)} '
                         f'(got {", ".join(columns) or "nothing"})')
    return line, columns


def _onset(text: str, path: Path, line: int) -> float | None:
    text = text.strip()
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        raise LabelError(f'{path}:{line}: onset_s {text!r} is not a number') from None
    if not math.isfinite(value) or value < 0.0:
        raise LabelError(f'{path}:{line}: onset_s must be a finite time >= 0 s, got {text}')
    return value


def load_onset_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Read a label file (format in the module docstring).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict of str -> ndarray, shape (k,), float64
        Recording key (:func:`recording_key`) -> its onset times [s], sorted; an empty
        array for a recording listed without onset.

    Raises
    ------
    LabelError
        Unreadable file, missing header or column, a row with too few cells, an onset that
        is not a finite number >= 0, an empty recording name. The message names the line.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except (OSError, UnicodeDecodeError) as exc:
        raise LabelError(f'{path}: cannot read the label file ({exc})') from exc
    rows = [(number, cells) for number, cells in enumerate(csv.reader(text.splitlines()), 1)
            if cells and any(c.strip() for c in cells) and not cells[0].lstrip().startswith('#')]
    _, columns = _header(rows, path)
    width = max(columns.values()) + 1
    labels: dict[str, list[float]] = {}
    for line, cells in rows[1:]:
        if len(cells) <= columns['recording']:
            raise LabelError(f'{path}:{line}: expected {width} cells, got {len(cells)}')
        cells = cells + [''] * (width - len(cells))  # a trailing empty onset_s may be cut
        key = recording_key(cells[columns['recording']].strip())
        if not key:
            raise LabelError(f'{path}:{line}: empty recording name')
        onset = _onset(cells[columns['onset_s']], path, line)
        labels.setdefault(key, [])
        if onset is not None:
            labels[key].append(onset)
    return {key: np.sort(np.asarray(values, np.float64)) for key, values in labels.items()}


def apply_onset_labels(recording: LabelledRecording, labels: dict[str, np.ndarray],
                       source: str = 'labels') -> LabelledRecording:
    """The recording with its onsets replaced by those of ``labels``.

    Parameters
    ----------
    recording : LabelledRecording
        Its ``name`` (file name) selects the labels (:func:`recording_key`).
    labels : dict of str -> ndarray (k,)
        Onset times [s] per recording key (:func:`load_onset_csv`).
    source : str
        Name of the label file, for the error message.

    Returns
    -------
    LabelledRecording
        A copy whose ``onsets`` are ``round(onset_s * fs)`` [rows].

    Raises
    ------
    LabelError
        The recording is not in the labels, or an onset lies beyond its last row.
    """
    key = recording_key(recording.name)
    if key not in labels:
        raise LabelError(f'{source}: recording {key!r} is not labelled (list it with an '
                         'empty onset_s if it has no slip)')
    rows = np.rint(np.asarray(labels[key], np.float64) * recording.fs).astype(np.int64)
    n = recording.frames.shape[0]
    if rows.size and rows.max() >= n:
        raise LabelError(f'{source}: {key}: onset at {rows.max() / recording.fs:.3f} s is '
                         f'beyond the recording ({n / recording.fs:.3f} s)')
    return replace(recording, onsets=rows)


def write_onset_csv(path: str | Path, onsets: dict[str, np.ndarray], comment: str = '') -> None:
    """Write onset times [s] per recording key in the format above (one empty row for a
    recording without onset), e.g. the simulator's ground truth as a label file."""
    lines = [f'# {line}' for line in comment.splitlines()] + ['recording,onset_s']
    for key, values in onsets.items():
        values = np.asarray(values, np.float64)
        lines += [f'{key},{v:.4f}' for v in values] if values.size else [f'{key},']
    Path(path).write_text('\n'.join(lines) + '\n', encoding='utf-8')
