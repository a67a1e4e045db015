"""Slip detection evaluation on labelled recordings (FORTE paper, slip metrics).

Labelled recording: one ``.npz`` (no pickle) with

- ``frames`` (n, 6) float: sensor values in contract channel order (raw normalised;
  median-filtered here unless ``filtered`` is true);
- ``fs`` () float: sampling rate [Hz];
- ``onsets`` (k,) int64: rows of ``frames`` where a slip starts (k may be 0);
- ``trial`` (n,) int, optional: trial id per row, contiguous runs (default: one trial);
- ``filtered`` () bool, optional: frames are already median-filtered;
- ``mask`` (n,) bool, optional: rows where detection is evaluated (e.g. the lift phase, as
  in the paper); flags on other rows are ignored.

Each trial runs through a fresh slip detector. Trial-wise (as in the paper): a trial is
positive when it has at least one onset, predicted positive when any detector update in it
flags slip; accuracy, precision, recall and F1 of these trials
(:class:`~forte_perception.evaluation.slip_metrics.TrialScores`: NaN where undefined, e.g.
precision when nothing was flagged). Per onset
(:func:`~forte_perception.evaluation.slip_metrics.match_onsets`, next-onset cut): the first
flag at or after the onset and before the next onset, within ``max_latency``, gives the
onset-to-flag latency; otherwise the onset is missed. Flag runs (consecutive flagged
updates) that start outside every ``[onset, onset + max_latency]`` window are false alarms.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from forte_perception.evaluation.slip_metrics import (
    MAX_LATENCY,
    TrialScores,
    flag_runs,
    match_onsets,
    outside_windows,
)
from forte_perception.median import MEDIAN_WINDOW, running_median
from forte_perception.slip.detector import SlipParams, slip_features

__all__ = ['LabelledRecording', 'evaluate_slip', 'load_labelled', 'save_labelled']


@dataclass
class LabelledRecording:
    """Frames (n, 6), fs [Hz], onsets (k,) row indices, trial (n,) ids, filtered flag."""

    frames: np.ndarray
    fs: float
    onsets: np.ndarray
    trial: np.ndarray | None = None
    filtered: bool = False
    name: str = field(default='')
    mask: np.ndarray | None = None


def save_labelled(path: str | Path, recording: LabelledRecording) -> None:
    """Write a labelled recording (format above)."""
    arrays = {'frames': np.asarray(recording.frames, np.float64),
              'fs': np.float64(recording.fs),
              'onsets': np.asarray(recording.onsets, np.int64),
              'filtered': np.bool_(recording.filtered)}
    if recording.trial is not None:
        arrays['trial'] = np.asarray(recording.trial, np.int64)
    if recording.mask is not None:
        arrays['mask'] = np.asarray(recording.mask, bool)
    np.savez_compressed(path, **arrays)


def load_labelled(path: str | Path) -> LabelledRecording:
    """Read and check a labelled recording; raises ValueError with a reason."""
    with np.load(path, allow_pickle=False) as data:
        for key in ('frames', 'fs', 'onsets'):
            if key not in data.files:
                raise ValueError(f'{path}: missing key {key!r}')
        frames = data['frames'].astype(np.float64)
        rec = LabelledRecording(frames, float(data['fs']), data['onsets'].astype(np.int64),
                                data['trial'] if 'trial' in data.files else None,
                                bool(data['filtered']) if 'filtered' in data.files else False,
                                Path(path).name,
                                data['mask'].astype(bool) if 'mask' in data.files else None)
    if frames.ndim != 2 or frames.shape[1] != 6:
        raise ValueError(f'{path}: frames must be (n, 6), got {frames.shape}')
    if rec.onsets.size and (rec.onsets.min() < 0 or rec.onsets.max() >= frames.shape[0]):
        raise ValueError(f'{path}: onsets outside 0..{frames.shape[0] - 1}')
    if rec.trial is not None and rec.trial.shape != (frames.shape[0],):
        raise ValueError(f'{path}: trial must have one id per row')
    if rec.mask is not None and rec.mask.shape != (frames.shape[0],):
        raise ValueError(f'{path}: mask must have one flag per row')
    return rec


def _trials(rec: LabelledRecording) -> list[tuple[int, int]]:
    n = rec.frames.shape[0]
    if rec.trial is None:
        return [(0, n)]
    bounds = np.concatenate([[0], np.flatnonzero(np.diff(rec.trial)) + 1, [n]])
    return list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True))


def evaluate_slip(recordings: list[LabelledRecording], params: SlipParams | None = None,
                  median_window: int = MEDIAN_WINDOW, max_latency: float = MAX_LATENCY,
                  skip: float = 0.0) -> dict:
    """Trial-wise confusion counts and scores, per-onset latencies, false alarms.

    Parameters
    ----------
    recordings : list of LabelledRecording
    params : SlipParams, optional
    median_window : int
        Median filter applied to unfiltered recordings [samples].
    max_latency : float
        Longest onset-to-flag delay that counts as a detection [s]; rounded to samples.
    skip : float
        Ignore flags in the first ``skip`` seconds of every trial [s] (in addition to the
        recording's ``mask``).

    Returns
    -------
    dict
        ``trials`` (:class:`~forte_perception.evaluation.slip_metrics.TrialScores`),
        ``latencies_s`` (list, one per caught onset [s]), ``missed_onsets``,
        ``false_alarms``, ``per_trial`` (list of dicts).
    """
    params = params or SlipParams()
    truth_and_flag: list[tuple[bool, bool]] = []
    latencies: list[float] = []
    missed = false_alarms = 0
    per_trial = []
    for rec in recordings:
        fs = rec.fs
        frames = rec.frames if rec.filtered else running_median(rec.frames, median_window)
        window = int(round(max_latency * fs))
        for a, b in _trials(rec):
            onsets = np.sort(rec.onsets[(rec.onsets >= a) & (rec.onsets < b)]) - a
            res = slip_features(frames[a:b], fs=fs, params=params)
            flags = res.sample_index[res.slip]
            keep = flags >= int(round(skip * fs))
            if rec.mask is not None:
                keep &= rec.mask[a + flags]
            flags = flags[keep]
            truth_and_flag.append((onsets.size > 0, flags.size > 0))
            latency = match_onsets(onsets, flags, window, before_next_onset=True)
            trial_latencies = [float(v) / fs for v in latency[~np.isnan(latency)]]
            missed += latency.size - len(trial_latencies)
            latencies.extend(trial_latencies)
            run_starts = flag_runs(flags, params.hop)[:, 0]
            alarms = int(outside_windows(run_starts, run_starts,
                                         np.stack([onsets, onsets + window], axis=1)).sum())
            false_alarms += alarms
            per_trial.append({'recording': rec.name, 'start': a, 'stop': b,
                              'onsets': int(onsets.size), 'flagged_updates': int(flags.size),
                              'latencies_s': trial_latencies, 'false_alarms': alarms})
    return {'trials': TrialScores.count(truth_and_flag),
            'latencies_s': latencies, 'missed_onsets': int(missed),
            'false_alarms': false_alarms, 'per_trial': per_trial}
