"""FORTE signal processing (median filter, tare, contact, SVR force estimation, PSD slip
detection) as a pure library, the perception node, and offline training, evaluation and
benchmark tools.
"""
