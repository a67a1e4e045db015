"""FORTE finger generator: parametric fin-ray finger with L-shaped sensing channels.

- :mod:`forte_finger.design`: parameters and derived geometry (pure Python + numpy).
- :mod:`forte_finger.cad`: solid model with the OpenCascade kernel (OCP), STEP/STL export.
- :mod:`forte_finger.measure`: measurements on a triangle mesh (sections, loops, circles,
  distances) used by the tests and the generation report.
- ``python -m forte_finger`` (run in ``hardware/``): generate the default finger.
"""
from forte_finger.design import (
    LOCATIONS,
    SURFACES,
    Channel,
    FingerDesign,
    FingerParameters,
    make_design,
)

__all__ = ['LOCATIONS', 'SURFACES', 'Channel', 'FingerDesign', 'FingerParameters',
           'make_design']
