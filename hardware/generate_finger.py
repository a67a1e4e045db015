#!/usr/bin/env python3
"""Generate the FORTE finger (STEP, STL, port table, report) into hardware/out/.

Run from anywhere with the workspace environment sourced; see docs/hardware.md and
``python hardware/generate_finger.py --help``.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from forte_finger.cli import main  # noqa: E402

if __name__ == '__main__':
    sys.exit(main())
