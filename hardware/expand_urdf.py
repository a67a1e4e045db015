#!/usr/bin/env python3
"""Expand forte_description/urdf/forte_gripper.urdf.xacro into forte_gripper.urdf.

The pre-expanded URDF lets tools without xacro load the gripper. Run after editing the
xacro (hardware/test/test_urdf.py fails while the two disagree)::

    python hardware/expand_urdf.py           # rewrite the URDF
    python hardware/expand_urdf.py --check   # exit 1 if the URDF is out of date
"""
import argparse
import sys
from pathlib import Path

import xacro

ROOT = Path(__file__).resolve().parents[1]
XACRO = Path('forte_description/urdf/forte_gripper.urdf.xacro')
URDF = Path('forte_description/urdf/forte_gripper.urdf')


def expand() -> str:
    """The URDF text produced by xacro from the committed xacro file."""
    document = xacro.process_file(str(ROOT / XACRO))
    text = document.toprettyxml(indent='  ')
    # xacro names the input in a banner comment; make it independent of the checkout path
    return text.replace(str(ROOT / XACRO), str(XACRO))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--check', action='store_true', help='only compare, do not write')
    args = parser.parse_args(argv)
    text = expand()
    target = ROOT / URDF
    if args.check:
        current = target.read_text() if target.exists() else ''
        if current != text:
            print(f'{URDF} is out of date: run python hardware/expand_urdf.py',
                  file=sys.stderr)
            return 1
        print(f'{URDF} is up to date')
        return 0
    target.write_text(text)
    print(f'wrote {URDF}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
