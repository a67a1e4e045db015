"""A made-up robot_state_publisher install for the front ends' tests (not a test module).

robot_state_publisher has no wheel, so a bare machine never has it; the bringup and launch
tests check both branches (installed: started with the gripper's URDF; not installed: one
line, and the graph without it) by giving ``AMENT_PREFIX_PATH`` an ament prefix that
registers it (:func:`fake_robot_state_publisher`) or that lacks it
(:func:`without_robot_state_publisher`). The fake executable is never run: only command
lines and launch actions are checked; the real node runs in the live tests where it is
installed.

Imported as ``from robot_model_probe import ...`` (the folder of the test files is on
``sys.path`` in pytest's default import mode; the basename is unique in the repository).
"""
from __future__ import annotations

import os
from pathlib import Path

from forte_bringup.robot_model import robot_state_publisher_executable


def without_robot_state_publisher() -> str:
    """This machine's ``AMENT_PREFIX_PATH`` without any prefix that has robot_state_publisher."""
    return os.pathsep.join(
        prefix for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
        if prefix and robot_state_publisher_executable({'AMENT_PREFIX_PATH': prefix}) is None)


def fake_robot_state_publisher(root: Path) -> Path:
    """An ament prefix at ``root`` that registers robot_state_publisher with an executable
    (a script that exits 1 if it is ever run); returns the executable."""
    index = root / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    (index / 'robot_state_publisher').write_text('')
    executable = root / 'lib' / 'robot_state_publisher' / 'robot_state_publisher'
    executable.parent.mkdir(parents=True)
    executable.write_text('#!/bin/sh\nexit 1\n')
    executable.chmod(0o755)
    return executable
