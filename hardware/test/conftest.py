"""Make ``hardware/`` importable (the finger generator is not an installed package)."""
import sys
from pathlib import Path

HARDWARE = Path(__file__).resolve().parents[1]
if str(HARDWARE) not in sys.path:
    sys.path.append(str(HARDWARE))
