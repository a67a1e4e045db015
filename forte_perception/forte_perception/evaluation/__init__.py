"""Offline evaluation of the perception cores (no part of it runs on the robot).

- :mod:`.slip_metrics`: the one implementation of the slip metrics (onset-to-flag matching,
  event and trial-wise precision / recall / F1, latency statistics, their empty cases);
- :mod:`.recordings`: labelled recordings (``.npz``) and the slip evaluation over them
  (``forte_evaluate_slip``);
- :mod:`.labels`, :mod:`.scenes`: the labelled slip set's format and its signal-level scenes;
- :mod:`.benchmark`: runs a slip detector mode over the slip set.
"""
