"""rviz/forte.rviz and plotjuggler/forte.xml name only topics of the sim graph and fields of
their messages.

Pure (no ROS graph): the topics are those of docs/contracts.md's table that the sim graph
produces (simulator, perception, control, every node's /diagnostics), plus the outputs of
forte_visualization and robot_state_publisher's ``robot_description``; message fields are
read from the generated message classes (``get_fields_and_field_types``). PlotJuggler curve
names are ``/<topic>/<field>/<subfield>``, array elements ``<field>[i]``; each must end at a
number or a bool. Also the layout's XML structure as PlotJuggler 3 reads it, and the
installed copies.
"""
from __future__ import annotations

import importlib
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

from forte_bringup.robot_model import ROBOT_DESCRIPTION_TOPIC
from forte_bringup.visualization_node import MARKER_TOPIC, WRENCH_TOPICS
from forte_ros.contract import BASE_FRAME

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


# ---- PlotJuggler -----------------------------------------------------------------------------
@pytest.fixture(scope='module')
def layout() -> ET.Element:
    return ET.parse(PLOTJUGGLER).getroot()


def test_the_layout_has_the_structure_plotjuggler_reads(layout):
    assert layout.tag == 'root'
    (window,) = layout.findall('tabbed_widget')
    assert window.get('parent') == 'main_window'
    tabs = window.findall('Tab')
    assert len(tabs) >= 3 and window.find('currentTabIndex') is not None
    for tab in tabs:
        containers = tab.findall('Container')
        assert tab.get('tab_name') and int(tab.get('containers')) == len(containers) == 1
        for splitter in containers[0].iter('DockSplitter'):
            children = list(splitter)
            assert splitter.get('orientation') in ('-', '|')
            assert int(splitter.get('count')) == len(children)
            sizes = [float(v) for v in splitter.get('sizes').split(';')]
            assert len(sizes) == len(children) and sum(sizes) == pytest.approx(1.0, abs=1e-5)
            assert {child.tag for child in children} <= {'DockArea', 'DockSplitter'}
        for area in containers[0].iter('DockArea'):
            (plot,) = area.findall('plot')
            assert plot.get('mode') == 'TimeSeries' and plot.findall('curve')
    (streamer,) = layout.find('Plugins').findall('plugin')
    assert streamer.get('ID') == 'ROS2 Topic Subscriber'
    assert layout.find('previouslyLoaded_Streamer').get('name') == 'ROS2 Topic Subscriber'


def test_every_curve_is_a_number_of_a_sim_graph_topic(layout):
    curves = [curve.get('name') for curve in layout.iter('curve')]
    assert curves and all(curves)
    plotted = set()
    for curve in curves:
        topic, path = split_curve(curve)
        assert field_leaf(TOPICS[topic], path) in NUMERIC, curve
        plotted.add(topic)
    selected = layout.find("Plugins/plugin/selected_topics").get('value').split(';')
    assert set(selected) == plotted, 'the streamer subscribes to exactly the plotted topics'
    # what the layout is for: raw and filtered channels, PSD, finger variance, force, slip,
    # servo command
    for needed in ('/tactile/frames/data[5]', '/tactile/state/filtered[5]',
                   '/tactile/state/psd_max_db[5]', '/tactile/state/finger_variance[1]',
                   '/tactile/state/force', '/tactile/state/slip', '/gripper/command/position'):
        assert needed in curves, needed


def test_the_raw_batch_fits_the_streamer_array_limit(layout):
    plugin = layout.find('Plugins/plugin')
    limit = int(plugin.find('max_array_size').get('value'))
    assert limit >= 20 * 6, 'a TactileFrames batch (20 x 6 values) would be discarded'


@pytest.mark.parametrize('curve, problem', [
    ('/tactile/state/filtered[6]', 'has 6 elements'),
    ('/tactile/state/forces', 'no field'),
    ('/tactile/state/header', 'not a number'),
    ('/tactile/state/filtered', 'needs an index'),
])
def test_the_field_check_finds_mistakes(curve, problem):
    topic, path = split_curve(curve)
    with pytest.raises(AssertionError, match=problem):
        field_leaf(TOPICS[topic], path)


# ---- RViz ------------------------------------------------------------------------------
def displays(items: list[dict]) -> list[dict]:
    """Every display, those inside groups included."""
    out = []
    for item in items:
        out.append(item)
        out += displays(item.get('Displays', []))
    return out


@pytest.fixture(scope='module')
def rviz() -> dict:
    return yaml.safe_load(RVIZ.read_text())


def test_rviz_subscribes_to_sim_graph_topics_of_the_right_type(rviz):
    manager = rviz['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == BASE_FRAME
    found = {}
    for display in displays(manager['Displays']):
        topic = display.get('Topic', display.get('Description Topic'))
        if topic is None:
            continue
        name = topic['Value']
        assert name in TOPICS, f'{display["Name"]}: {name} is not a topic of the sim graph'
        assert RVIZ_TYPES[display['Class']] == TOPICS[name], display['Name']
        assert topic['Reliability Policy'] == 'Reliable'
        found[name] = display
    classes = {display['Class'] for display in displays(manager['Displays'])}
    assert {'rviz_default_plugins/TF', 'rviz_default_plugins/RobotModel'} <= classes
    assert {'/' + t for t in WRENCH_TOPICS} | {'/' + MARKER_TOPIC} <= set(found)
    description = found['/' + ROBOT_DESCRIPTION_TOPIC]
    assert description['Description Source'] == 'Topic'
    # robot_state_publisher latches robot_description (transient local)
    assert description['Description Topic']['Durability Policy'] == 'Transient Local'
    assert set(found['/' + MARKER_TOPIC]['Namespaces']) == {'force', 'slip', 'grasp_state'}


# ---- installation -------------------------------------------------------------------------
def installed_share() -> Path | None:
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        share = Path(prefix) / 'share' / 'forte_bringup'
        if prefix and (share / 'package.xml').is_file():
            return share
    return None


@pytest.mark.skipif(installed_share() is None, reason='forte_bringup is not installed')
def test_the_files_are_installed():
    share = installed_share()
    for path in ('rviz/forte.rviz', 'plotjuggler/forte.xml',
                 'config/diagnostics_aggregator.yaml', 'urdf/forte_gripper.macro.xacro',
                 'urdf/forte_gripper.urdf.xacro', 'urdf/forte_gripper.urdf'):
        assert (share / path).is_file(), f'{path} is not installed (make setup)'
