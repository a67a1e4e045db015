"""The shipped views' topics: rviz/forte.rviz and plotjuggler/forte.xml, read as the programs
read them (not a test module).

Shared by ``test_visualization_files.py`` (offline: every topic a topic of the sim graph of
the right type, every curve a number of its message) and ``test_visualization_live.py``
(the running sim graph has them). The sim graph's topics come from docs/contracts.md's
table, forte_visualization's outputs and robot_state_publisher's; message fields from the
generated message classes (``get_fields_and_field_types``). PlotJuggler names a curve
``/<topic>/<field>/<subfield>``, an array element ``<field>[i]``.

Imported as ``from view_files import ...`` (the folder of the test files is on
``sys.path`` in pytest's default import mode; the basename is unique in the repository).
"""
from __future__ import annotations

import importlib
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import yaml

from forte_bringup.robot_model import ROBOT_DESCRIPTION_TOPIC
from forte_bringup.visualization_node import MARKER_TOPIC, WRENCH_TOPICS

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / 'forte_bringup'
RVIZ = PACKAGE / 'rviz' / 'forte.rviz'
PLOTJUGGLER = PACKAGE / 'plotjuggler' / 'forte.xml'
CONTRACTS = ROOT / 'docs' / 'contracts.md'
#: Words of the contract table's producer column that name a node of the sim graph.
SIM_PRODUCERS = ('sim', 'perception', 'control', 'every node')
#: RViz display class -> the message type it subscribes to.
RVIZ_TYPES = {
    'rviz_default_plugins/Wrench': 'geometry_msgs/msg/WrenchStamped',
    'rviz_default_plugins/MarkerArray': 'visualization_msgs/msg/MarkerArray',
    'rviz_default_plugins/RobotModel': 'std_msgs/msg/String',
}
#: Topics that exist only where robot_state_publisher runs (absolute name -> type): the
#: latched URDF (RViz's RobotModel) and the TF it broadcasts (RViz's TF display, the fixed
#: frame); a graph without robot_state_publisher has none of them.
ROBOT_STATE_PUBLISHER_TOPICS = {
    '/' + ROBOT_DESCRIPTION_TOPIC: 'std_msgs/msg/String',
    '/tf': 'tf2_msgs/msg/TFMessage',
    '/tf_static': 'tf2_msgs/msg/TFMessage',
}
NUMERIC = {'boolean', 'octet', 'float', 'double', 'int8', 'uint8', 'int16', 'uint16', 'int32',
           'uint32', 'int64', 'uint64'}


def sim_graph_topics() -> dict[str, str]:
    """Absolute topic -> message type (``pkg/msg/Name``) of the sim graph."""
    topics = {}
    for line in CONTRACTS.read_text().splitlines():
        cells = [cell.strip().strip('`') for cell in line.strip().strip('|').split('|')]
        if len(cells) != 4 or not re.fullmatch(r'\w+/\w+', cells[1]):
            continue
        producers = cells[3].split('->')[0]
        if any(word in producers for word in SIM_PRODUCERS):
            package, name = cells[1].split('/')
            topics['/' + cells[0].lstrip('/')] = f'{package}/msg/{name}'
    assert {'/tactile/frames', '/tactile/state', '/grasp/state', '/gripper/command'} <= \
        set(topics), 'the contract topic table was not found'
    topics.update({'/' + topic: 'geometry_msgs/msg/WrenchStamped' for topic in WRENCH_TOPICS})
    topics['/' + MARKER_TOPIC] = 'visualization_msgs/msg/MarkerArray'
    topics['/' + ROBOT_DESCRIPTION_TOPIC] = 'std_msgs/msg/String'
    return topics


TOPICS = sim_graph_topics()


def get_message(message_type: str) -> type:
    """The message class of ``pkg/msg/Name`` (what rosidl_runtime_py's ``get_message``
    does; the packages are forte_bringup's declared dependencies)."""
    package, _, name = message_type.split('/')
    return getattr(importlib.import_module(f'{package}.msg'), name)


def field_leaf(message_type: str, path: list[str]) -> str:
    """The type of the field at ``path`` (``['header', 'stamp', 'sec']``, ``['data[3]']``)
    of ``message_type``; raises AssertionError naming the first part that does not exist."""
    fields = get_message(message_type).get_fields_and_field_types()
    part, rest = path[0], path[1:]
    name, index = re.fullmatch(r'(\w+)(?:\[(\d+)\])?', part).groups()
    assert name in fields, f'{message_type} has no field {name!r} ({sorted(fields)})'
    kind = fields[name]
    static = re.fullmatch(r'(.+)\[(\d+)\]', kind)
    dynamic = re.fullmatch(r'sequence<([^,>]+)(?:, (\d+))?>', kind)
    if index is not None:
        assert static or dynamic, f'{message_type}.{name} ({kind}) is not an array'
        element, size = (static or dynamic).groups()
        assert size is None or int(index) < int(size), \
            f'{message_type}.{name}[{index}]: the array has {size} elements'
        kind = element
    else:
        assert not (static or dynamic), f'{message_type}.{name} ({kind}) needs an index'
    if '/' in kind:
        assert rest, f'{message_type}.{name} is a message ({kind}), not a number'
        package, type_name = kind.split('/')
        return field_leaf(f'{package}/msg/{type_name}', rest)
    assert not rest, f'{message_type}.{name} ({kind}) has no field {rest[0]!r}'
    return kind


def split_curve(curve: str) -> tuple[str, list[str]]:
    """(topic, field path) of a PlotJuggler curve name; the topic is the longest known one."""
    topic = max((t for t in TOPICS if curve.startswith(t + '/')), key=len, default=None)
    assert topic is not None, f'curve {curve!r}: its topic is not a topic of the sim graph'
    return topic, curve[len(topic) + 1:].split('/')


def load_layout(path: Path = PLOTJUGGLER) -> ET.Element:
    """The PlotJuggler layout's root element."""
    return ET.parse(path).getroot()


def plotjuggler_topics(layout: ET.Element) -> dict[str, str]:
    """Topic -> message type of every curve of the layout and every topic its streamer
    selects (the type: the sim graph's, :data:`TOPICS`; a topic of no curve must be one)."""
    topics = {split_curve(curve.get('name'))[0] for curve in layout.iter('curve')}
    selected = layout.find('Plugins/plugin/selected_topics')
    if selected is not None:
        topics |= {topic for topic in selected.get('value').split(';') if topic}
    return {topic: TOPICS[topic] for topic in topics}


def load_rviz(path: Path = RVIZ) -> dict:
    """The RViz config (YAML)."""
    return yaml.safe_load(path.read_text())


def displays(items: list[dict]) -> list[dict]:
    """Every display, those inside groups included."""
    out = []
    for item in items:
        out.append(item)
        out += displays(item.get('Displays', []))
    return out


def rviz_topics(config: dict) -> dict[str, tuple[str, dict]]:
    """Topic -> (message type its display subscribes with, the display) of every display
    with a topic (``Topic``, or a RobotModel's ``Description Topic``)."""
    found = {}
    for display in displays(config['Visualization Manager']['Displays']):
        topic = display.get('Topic', display.get('Description Topic'))
        if topic is not None:
            found[topic['Value']] = (RVIZ_TYPES[display['Class']], display)
    return found
