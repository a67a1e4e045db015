"""The RViz view of a graph, written for its namespace and prefix (``rviz:=true``).

Pure Python (no rclpy, no launch). ``rviz/forte.rviz`` names the root graph's topics and the
unprefixed fixed frame; a graph started with ``namespace:=right prefix:=right_`` publishes
``/right/visualization/markers`` and frames ``right_forte_...``, so that file would show
nothing. :func:`write_view` rewrites it at launch:

- every topic of a display (``Topic`` / ``Description Topic`` values) moves into the
  namespace, except the ROS-wide ones (``/tf``, ``/tf_static``);
- the robot model: ``<namespace>/robot_description`` when the graph runs its own
  robot_state_publisher, else the robot's ``/robot_description`` (its URDF includes the
  gripper: forte_description's macro, with the same prefix);
- the fixed frame gets the prefix (``<prefix>forte_base_link``).

:func:`view_topics` reads the topics a view subscribes to, as RViz does (also for tests).
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import yaml

from forte_ros.contract import check_prefix, graph_namespace

__all__ = ['DISPLAY_TYPES', 'GLOBAL_TOPICS', 'VIEW_FILE', 'view_document', 'view_topics',
           'write_view']

#: Topics that stay ROS-wide in every graph (TF is one tree for the whole robot).
GLOBAL_TOPICS = ('/tf', '/tf_static')
#: RViz display class -> the message type it subscribes to.
DISPLAY_TYPES = {
    'rviz_default_plugins/Wrench': 'geometry_msgs/msg/WrenchStamped',
    'rviz_default_plugins/MarkerArray': 'visualization_msgs/msg/MarkerArray',
    'rviz_default_plugins/RobotModel': 'std_msgs/msg/String',
}
#: The view of the root graph.
VIEW_FILE = 'forte.rviz'
#: Keys of a display whose ``Value`` is a topic name.
_TOPIC_KEYS = ('Topic', 'Description Topic')


def view_folder() -> Path:
    """``rviz/`` of forte_bringup: the source tree's when it has the view (editable
    install), else ``share/forte_bringup/rviz`` of the first prefix that has it."""
    source = Path(__file__).resolve().parents[1] / 'rviz'
    if (source / VIEW_FILE).is_file():
        return source
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        folder = Path(prefix) / 'share' / 'forte_bringup' / 'rviz'
        if prefix and (folder / VIEW_FILE).is_file():
            return folder
    return source


def _displays(node: object) -> Iterator[dict]:
    """Every display mapping of a view (those with a ``Class``), groups included."""
    if isinstance(node, dict):
        if 'Class' in node:
            yield node
        for value in node.values():
            yield from _displays(value)
    elif isinstance(node, list):
        for item in node:
            yield from _displays(item)


def view_document(namespace: str = '', prefix: str = '', own_model: bool = True,
                  source: str | Path | None = None) -> dict:
    """The view for a graph, as the YAML document RViz reads.

    Parameters
    ----------
    namespace : str
        The graph's namespace (``right`` or ``/right``; '' = root).
    prefix : str
        The graph's frame prefix (:func:`forte_ros.contract.check_prefix`).
    own_model : bool
        The graph runs its own robot_state_publisher (``robot_description`` in the
        namespace); False: the robot's ``/robot_description``.
    source : str or Path, optional
        The root view (default ``rviz/forte.rviz`` of :func:`view_folder`).

    Returns
    -------
    dict
        The rewritten document.

    Raises
    ------
    ValueError
        An invalid namespace or prefix.
    """
    check_prefix(prefix)
    namespace = graph_namespace(namespace)
    path = Path(source) if source is not None else view_folder() / VIEW_FILE
    document = yaml.safe_load(path.read_text(encoding='utf-8'))
    for display in _displays(document):
        for key in _TOPIC_KEYS:
            setting = display.get(key)
            if not isinstance(setting, dict) or not isinstance(setting.get('Value'), str):
                continue
            topic = setting['Value']
            if topic in GLOBAL_TOPICS:
                continue
            robot_model = key == 'Description Topic'
            if robot_model and not own_model:
                setting['Value'] = topic if topic.startswith('/') else f'/{topic}'
            else:
                setting['Value'] = f'{namespace}/{topic.lstrip("/")}'
    options = document['Visualization Manager']['Global Options']
    options['Fixed Frame'] = f'{prefix}{options["Fixed Frame"]}'
    return document


def write_view(namespace: str = '', prefix: str = '', own_model: bool = True) -> Path:
    """:func:`view_document` written to a file for ``rviz2 -d`` (in ``<tmp>/forte-rviz/``,
    named after its content: one file per namespace, prefix and model source)."""
    text = yaml.safe_dump(view_document(namespace, prefix, own_model), sort_keys=False)
    folder = Path(tempfile.gettempdir()) / 'forte-rviz'
    folder.mkdir(parents=True, exist_ok=True)
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    path = folder / f'forte_{digest}.rviz'
    if not path.is_file():
        partial = path.with_suffix(f'.{os.getpid()}.part')
        partial.write_text(text, encoding='utf-8')
        partial.replace(path)
    return path


def view_topics(document: dict) -> dict[str, str]:
    """The topics a view names: absolute name -> the message type RViz subscribes with.

    The displays' ``Topic`` / ``Description Topic`` values (types by
    :data:`DISPLAY_TYPES`). The TF display names none: it reads ``/tf`` and ``/tf_static``.
    """
    topics: dict[str, str] = {}
    for display in _displays(document):
        kind = DISPLAY_TYPES.get(display['Class'])
        for key in _TOPIC_KEYS:
            setting = display.get(key)
            if kind and isinstance(setting, dict) and isinstance(setting.get('Value'), str):
                topics[setting['Value']] = kind
    return topics
