"""Slip detection from spectral power (FORTE paper, Sec. slip), streaming and batch.

- :mod:`.detector`: :class:`SlipDetector` and :func:`slip_features` (the derivation);
- :mod:`.params`: :class:`SlipParams`, the detector modes and the recommended one;
- :mod:`.decision`, :mod:`.robust`: the decision rules of the ``paper`` and ``robust`` modes;
- :mod:`.reference`: the slow reference implementation the streaming one is checked against;
- :mod:`.mask`: decisions with masked (invalid) channels.
"""
