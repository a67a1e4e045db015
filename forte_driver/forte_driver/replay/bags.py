"""Write and read the project's ROS 2 MCAP bags (no rclpy needed).

Writing uses rosbags' rosbag2 writer with the MCAP storage plugin, so a bag is a rosbag2
folder (``metadata.yaml`` + ``<name>_0.mcap``) that ``ros2 bag info`` / ``ros2 bag play``
open, with the full ``ros2msg`` schema of every type embedded so that independent readers
(``mcap`` + ``mcap_ros2``, Foxglove, rosbags) decode it without the package installed.
The forte_msgs types are registered in the rosbags type store from their ``.msg`` text.

Messages are written as CDR bytes exactly as they came off the wire (the recorder
subscribes with ``raw=True``), so recording costs no decode/encode.

Reading is :func:`forte_driver.replay.mcap_source.read_bag` (re-exported here), which tolerates
truncated and corrupt files.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from forte_driver.replay.mcap_source import BagError, BagMessage, BagReadReport, bag_files, read_bag

__all__ = [
    'BagError',
    'BagMessage',
    'BagReadReport',
    'BagWriter',
    'TopicSpec',
    'bag_files',
    'forte_msg_folder',
    'forte_typestore',
    'read_bag',
    'DEFAULT_TOPICS',
]

#: rosbag2 metadata version written (9 = Jazzy).
ROSBAG2_VERSION = 9


@dataclass(frozen=True)
class TopicSpec:
    """A topic to record: name, ROS type and the QoS its publishers offer.

    Attributes
    ----------
    name : str
        Relative or absolute topic name; stored absolute in the bag.
    msgtype : str
        ``package/msg/Name``.
    reliable : bool
        Reliable (True) or best effort (False) publishers.
    transient_local : bool
        Transient-local durability (latched, e.g. ``grasp/state``).
    depth : int
        History depth (keep last).
    """

    name: str
    msgtype: str
    reliable: bool = True
    transient_local: bool = False
    depth: int = 10

    @property
    def absolute_name(self) -> str:
        """The name with a leading slash."""
        return self.name if self.name.startswith('/') else '/' + self.name


#: The contract's topics (docs/contracts.md) that a FORTE recording holds by default.
DEFAULT_TOPICS: tuple[TopicSpec, ...] = (
    TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames', reliable=False, depth=50),
    TopicSpec('tactile/sensor_info', 'forte_msgs/msg/SensorInfo', transient_local=True, depth=1),
    TopicSpec('tactile/state', 'forte_msgs/msg/TactileState', depth=50),
    TopicSpec('gripper/command', 'forte_msgs/msg/ServoCommand'),
    TopicSpec('joint_states', 'sensor_msgs/msg/JointState'),
    TopicSpec('arm/cmd_vel', 'geometry_msgs/msg/TwistStamped'),
    TopicSpec('grasp/state', 'forte_msgs/msg/GraspState', transient_local=True, depth=1),
    TopicSpec('sim/ground_truth', 'forte_msgs/msg/SimGroundTruth', depth=50),
    TopicSpec('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray'),
)


def forte_msg_folder() -> Path:
    """Folder holding the forte_msgs ``msg/*.msg`` definitions.

    Looks in every ``share/forte_msgs/msg`` on ``AMENT_PREFIX_PATH`` first, then in the
    source tree next to this package.

    Raises
    ------
    BagError
        If no folder with ``TactileFrames.msg`` is found.
    """
    candidates = [
        Path(prefix) / 'share' / 'forte_msgs' / 'msg'
        for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
        if prefix
    ]
    candidates.append(Path(__file__).resolve().parents[2] / 'forte_msgs' / 'msg')
    for folder in candidates:
        if (folder / 'TactileFrames.msg').is_file():
            return folder
    raise BagError('forte_msgs .msg files not found (source install/setup.bash)')


_TYPESTORE: Typestore | None = None


def forte_typestore() -> Typestore:
    """The ROS 2 Jazzy type store of rosbags with every forte_msgs message registered.

    Returns
    -------
    Typestore
        Shared instance (built once per process).
    """
    global _TYPESTORE
    if _TYPESTORE is None:
        store = get_typestore(Stores.ROS2_JAZZY)
        types = {}
        for msg_file in sorted(forte_msg_folder().glob('*.msg')):
            name = f'forte_msgs/msg/{msg_file.stem}'
            types.update(get_types_from_msg(msg_file.read_text(), name))
        store.register(types)
        _TYPESTORE = store
    return _TYPESTORE


def _qos(spec: TopicSpec) -> Qos:
    infinite = QosTime(sec=9223372036, nsec=854775807)  # rmw's "infinite" as ros2 bag writes it
    return Qos(
        history=QosHistory.KEEP_LAST,
        depth=spec.depth,
        reliability=QosReliability.RELIABLE if spec.reliable else QosReliability.BEST_EFFORT,
        durability=(
            QosDurability.TRANSIENT_LOCAL if spec.transient_local else QosDurability.VOLATILE
        ),
        deadline=infinite,
        lifespan=infinite,
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=infinite,
        avoid_ros_namespace_conventions=False,
    )


class BagWriter:
    """A rosbag2 MCAP bag being written; use as a context manager.

    Parameters
    ----------
    path : str or Path
        Bag folder to create (must not exist yet); the MCAP file inside is
        ``<folder name>.mcap`` (rosbags' layout) and ``metadata.yaml`` is written on close.

    Examples
    --------
    >>> with BagWriter('out/bag') as bag:                       # doctest: +SKIP
    ...     bag.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames'))
    ...     bag.write('tactile/frames', stamp_ns, cdr_bytes)
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f'{self.path} exists already; bags are never overwritten')
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = Writer(self.path, version=ROSBAG2_VERSION, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._connections: dict[str, object] = {}
        self._typestore = forte_typestore()
        self.counts: dict[str, int] = {}
        self.closed = False

    def add_topic(self, spec: TopicSpec) -> None:
        """Declare a topic (idempotent for the same name).

        Raises
        ------
        BagError
            If the type is unknown to the type store (neither a ROS 2 Jazzy core type nor
            a forte_msgs type), or the name was added before with another type.
        """
        name = spec.absolute_name
        if name in self._connections:
            recorded = self._connections[name].msgtype
            if recorded != spec.msgtype:
                raise BagError(f'topic {name} already recorded as {recorded}')
            return
        if spec.msgtype not in self._typestore.fielddefs:
            raise BagError(f'message type {spec.msgtype} of {name} is unknown to the type store')
        self._connections[name] = self._writer.add_connection(
            name,
            spec.msgtype,
            typestore=self._typestore,
            serialization_format='cdr',
            offered_qos_profiles=[_qos(spec)],
        )
        self.counts[name] = 0

    def write(self, topic: str, timestamp: int, data: bytes | memoryview) -> None:
        """Append one CDR-serialized message.

        Parameters
        ----------
        topic : str
            A topic added with :meth:`add_topic` (relative or absolute name).
        timestamp : int
            Receive (log) time [ns].
        data : bytes
            The CDR bytes (with the encapsulation header), e.g. from a raw subscription
            or ``rclpy.serialization.serialize_message``.
        """
        name = topic if topic.startswith('/') else '/' + topic
        self._writer.write(self._connections[name], int(timestamp), data)
        self.counts[name] += 1

    def close(self) -> None:
        """Finish the MCAP file (summary, footer) and write ``metadata.yaml``."""
        if not self.closed:
            self._writer.close()
            self.closed = True

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
