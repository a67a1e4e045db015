"""The gripper's robot model for a graph: the URDF of a prefix, and robot_state_publisher.

Pure Python (no rclpy, no launch): what a graph needs to publish the gripper's TF (body,
fingers following ``joint_states``, contact pads) through ``robot_state_publisher``:

- :func:`expand_gripper` expands forte_description's ``urdf/forte_gripper.urdf.xacro`` for a
  name prefix and
  returns the URDF text, the value of robot_state_publisher's ``robot_description``
  parameter (:func:`robot_state_publisher_parameters`);
- :func:`robot_state_publisher_executable` finds robot_state_publisher as ``ros2 run`` would
  (the ament index of every ``AMENT_PREFIX_PATH`` prefix); a bare machine has none (there is
  no wheel of it), and a graph then prints :data:`ROBOT_STATE_PUBLISHER_MISSING` once and
  runs without it (:func:`robot_state_publisher_message`).

The URDF folder is forte_description's in the source tree beside this package when it
exists (editable install), else ``share/forte_description/urdf`` of the first prefix that has
it (:func:`urdf_folder`).
"""
from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from forte_ros.contract import check_prefix

__all__ = ['GRIPPER_XACRO', 'MACRO_XACRO', 'ROBOT_DESCRIPTION_TOPIC', 'ROBOT_STATE_PUBLISHER',
           'ROBOT_STATE_PUBLISHER_MISSING', 'RVIZ_MISSING', 'expand_gripper',
           'installed_executable', 'robot_state_publisher_available',
           'robot_state_publisher_executable', 'robot_state_publisher_message',
           'robot_state_publisher_parameters', 'urdf_folder']

#: The standalone gripper (argument ``prefix``) and the macro an arm's URDF includes.
GRIPPER_XACRO = 'forte_gripper.urdf.xacro'
MACRO_XACRO = 'forte_gripper.macro.xacro'
#: Package and executable of robot_state_publisher (``ros2 run <package> <executable>``).
ROBOT_STATE_PUBLISHER = ('robot_state_publisher', 'robot_state_publisher')
#: Topic robot_state_publisher latches the URDF on (RViz's RobotModel display reads it).
ROBOT_DESCRIPTION_TOPIC = 'robot_description'
#: The one line a graph prints when robot_state_publisher is not installed.
ROBOT_STATE_PUBLISHER_MISSING = (
    'robot_state_publisher is not installed here (no ROS 2 install; it has no wheel): the '
    "gripper's TF (body, fingers, pads) and robot_description are not published; on a "
    'ROS 2 Jazzy machine: apt install ros-jazzy-robot-state-publisher')
#: The one line a graph prints for ``rviz:=true`` where rviz2 is not installed.
RVIZ_MISSING = (
    'rviz2 is not installed here (no ROS 2 install; it has no wheel): rviz:=true starts '
    'nothing; on a ROS 2 Jazzy machine: apt install ros-jazzy-rviz2')

def urdf_folder(environ: Mapping[str, str] | None = None) -> Path:
    """Folder of the gripper's xacro files.

    Parameters
    ----------
    environ : mapping, optional
        Environment whose ``AMENT_PREFIX_PATH`` is searched (default ``os.environ``).

    Returns
    -------
    Path
        ``forte_description/urdf`` of the source tree when it holds :data:`GRIPPER_XACRO`, else
        ``<prefix>/share/forte_description/urdf`` of the first prefix that holds it, else the
        source path (whose absence the caller's open reports).
    """
    source = Path(__file__).resolve().parents[2] / 'forte_description' / 'urdf'
    if (source / GRIPPER_XACRO).is_file():
        return source
    environ = os.environ if environ is None else environ
    for prefix in environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        folder = Path(prefix) / 'share' / 'forte_description' / 'urdf'
        if prefix and (folder / GRIPPER_XACRO).is_file():
            return folder
    return source


def expand_gripper(prefix: str = '', xacro_file: str | Path | None = None) -> str:
    """The gripper's URDF for ``prefix``, expanded by xacro.

    Parameters
    ----------
    prefix : str
        Prepended to every link, joint and material name, as the graphs' ``prefix``
        argument (:func:`forte_ros.contract.check_prefix`: letters, digits, underscores,
        inner slashes), e.g. ``'right_'``; ``''`` gives the names of docs/contracts.md.
    xacro_file : str or Path, optional
        A xacro file with a ``prefix`` argument (default: :data:`GRIPPER_XACRO` of
        :func:`urdf_folder`).

    Returns
    -------
    str
        The URDF document (XML text), e.g. for robot_state_publisher's
        ``robot_description``.

    Raises
    ------
    ValueError
        Invalid prefix.
    OSError
        The xacro file cannot be read.
    """
    import xacro  # deferred: graph descriptions import this module without expanding

    check_prefix(prefix)
    path = Path(xacro_file) if xacro_file is not None else urdf_folder() / GRIPPER_XACRO
    if not path.is_file():
        raise FileNotFoundError(f'{path}: no such xacro file')
    document = xacro.process_file(str(path), mappings={'prefix': prefix})
    return document.toprettyxml(indent='  ')


def robot_state_publisher_parameters(prefix: str = '') -> dict[str, str]:
    """Parameters of robot_state_publisher for the gripper: ``{'robot_description': URDF}``.

    Parameters
    ----------
    prefix : str
        Name prefix of the gripper's links and joints (:func:`expand_gripper`).
    """
    return {'robot_description': expand_gripper(prefix)}


def installed_executable(package: str, executable: str,
                         environ: Mapping[str, str] | None = None) -> Path | None:
    """A package's executable as ``ros2 run`` finds it, or None.

    A prefix of ``AMENT_PREFIX_PATH`` provides it when its ament index registers the
    package (``share/ament_index/resource_index/packages/<package>``) and it installed the
    executable (``lib/<package>/<executable>``).

    Parameters
    ----------
    package, executable : str
        E.g. ``robot_state_publisher``, ``robot_state_publisher``.
    environ : mapping, optional
        Environment to search (default ``os.environ``).

    Returns
    -------
    Path or None
        The executable of the first prefix that has it.
    """
    environ = os.environ if environ is None else environ
    for prefix in environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if not prefix:
            continue
        root = Path(prefix)
        marker = root / 'share' / 'ament_index' / 'resource_index' / 'packages' / package
        candidate = root / 'lib' / package / executable
        if marker.is_file() and candidate.is_file() and os.access(candidate, os.X_OK):
            return candidate
    return None


def robot_state_publisher_executable(environ: Mapping[str, str] | None = None) -> Path | None:
    """robot_state_publisher's executable (:func:`installed_executable`), or None."""
    return installed_executable(*ROBOT_STATE_PUBLISHER, environ)


def robot_state_publisher_available(environ: Mapping[str, str] | None = None) -> bool:
    """True when :func:`robot_state_publisher_executable` finds it."""
    return robot_state_publisher_executable(environ) is not None


def robot_state_publisher_message(environ: Mapping[str, str] | None = None) -> str | None:
    """:data:`ROBOT_STATE_PUBLISHER_MISSING` when robot_state_publisher is not installed,
    None when it is (the graph starts it)."""
    return None if robot_state_publisher_available(environ) else ROBOT_STATE_PUBLISHER_MISSING
