"""Keep every ROS 2 process this project starts on this machine and in its own DDS domain.

Fast DDS discovers peers by UDP multicast unless told otherwise. Tests, demos and benchmarks
call :func:`isolate_ros_network` before ``rclpy.init`` so that discovery stays on loopback
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) and each run gets a domain id no other
concurrent run on this machine holds (an exclusive lock file per id, released when the
process exits). Child processes inherit both variables through ``os.environ``.

This module must not import rclpy: it has to run before the middleware reads the environment.
"""
from __future__ import annotations

import fcntl
import os
import tempfile
from pathlib import Path

#: Domain ids handed out, inclusive. 0 (the default domain) is never used. Ids above 101
#: collide with the ephemeral port range on Linux.
DOMAIN_ID_RANGE = (1, 100)

_held_lock = None  # the open lock file of the domain id this process holds


def _lock_folder() -> Path:
    folder = Path(tempfile.gettempdir()) / 'forte-ros-domains'
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def reserve_domain_id() -> int:
    """Reserve a DDS domain id no other live process of this project holds.

    Returns
    -------
    int
        The domain id, locked until this process exits.

    Raises
    ------
    RuntimeError
        If every id in :data:`DOMAIN_ID_RANGE` is held.
    """
    global _held_lock
    if _held_lock is not None:
        return int(Path(_held_lock.name).stem)
    first, last = DOMAIN_ID_RANGE
    start = first + os.getpid() % (last - first + 1)
    for offset in range(last - first + 1):
        domain_id = first + (start - first + offset) % (last - first + 1)
        handle = open(_lock_folder() / f'{domain_id}.lock', 'w')  # noqa: SIM115 (held for life)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        _held_lock = handle
        return domain_id
    raise RuntimeError(f'all ROS domain ids {first}..{last} are in use on this machine')


def isolate_ros_network(domain_id: int | None = None) -> int:
    """Confine ROS 2 discovery of this process (and its children) to this machine.

    Parameters
    ----------
    domain_id : int, optional
        Domain id to use; by default a free one is reserved with :func:`reserve_domain_id`.

    Returns
    -------
    int
        The domain id now in ``ROS_DOMAIN_ID``.
    """
    if domain_id is None:
        domain_id = reserve_domain_id()
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ['ROS_DOMAIN_ID'] = str(domain_id)
    os.environ.pop('ROS_STATIC_PEERS', None)
    os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
    return domain_id
