"""``python -m forte_finger``: see :mod:`forte_finger.cli`."""
import sys

from forte_finger.cli import main

sys.exit(main())
