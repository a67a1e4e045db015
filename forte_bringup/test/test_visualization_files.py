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

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from view_files import (
    NUMERIC,
    PLOTJUGGLER,
    RVIZ,
    RVIZ_TYPES,
    TOPICS,
    displays,
    field_leaf,
    load_layout,
    load_rviz,
    rviz_topics,
    split_curve,
)

from forte_bringup.robot_model import ROBOT_DESCRIPTION_TOPIC
from forte_bringup.visualization_node import MARKER_TOPIC, WRENCH_TOPICS
from forte_ros.contract import BASE_FRAME


# ---- PlotJuggler -----------------------------------------------------------------------------
@pytest.fixture(scope='module')
def layout() -> ET.Element:
    return load_layout(PLOTJUGGLER)


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
@pytest.fixture(scope='module')
def rviz() -> dict:
    return load_rviz(RVIZ)


def test_rviz_subscribes_to_sim_graph_topics_of_the_right_type(rviz):
    manager = rviz['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == BASE_FRAME
    found = {}
    for name, (message_type, display) in rviz_topics(rviz).items():
        assert name in TOPICS, f'{display["Name"]}: {name} is not a topic of the sim graph'
        assert message_type == TOPICS[name], display['Name']
        topic = display.get('Topic', display.get('Description Topic'))
        assert topic['Reliability Policy'] == 'Reliable'
        found[name] = display
    classes = {display['Class'] for display in displays(manager['Displays'])}
    assert {'rviz_default_plugins/TF', 'rviz_default_plugins/RobotModel'} <= classes
    assert set(RVIZ_TYPES) <= classes
    assert {'/' + t for t in WRENCH_TOPICS} | {'/' + MARKER_TOPIC} <= set(found)
    description = found['/' + ROBOT_DESCRIPTION_TOPIC]
    assert description['Description Source'] == 'Topic'
    # robot_state_publisher latches robot_description (transient local)
    assert description['Description Topic']['Durability Policy'] == 'Transient Local'
    assert set(found['/' + MARKER_TOPIC]['Namespaces']) == {'force', 'slip', 'grasp_state'}


# ---- installation -------------------------------------------------------------------------
def installed_share(package: str = 'forte_bringup') -> Path | None:
    """``share/<package>`` of the first ``AMENT_PREFIX_PATH`` prefix that installed it."""
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        share = Path(prefix) / 'share' / package
        if prefix and (share / 'package.xml').is_file():
            return share
    return None


#: package -> the files of the views it installs (the URDF is forte_description's).
INSTALLED = {
    'forte_bringup': ('rviz/forte.rviz', 'plotjuggler/forte.xml',
                      'config/diagnostics_aggregator.yaml'),
    'forte_description': ('urdf/forte_gripper.macro.xacro', 'urdf/forte_gripper.urdf.xacro',
                          'urdf/forte_gripper.urdf', 'meshes/forte_finger.stl',
                          'rviz/view_gripper.rviz', 'launch/view_gripper.launch.py'),
}


@pytest.mark.skipif(installed_share() is None, reason='forte_bringup is not installed')
@pytest.mark.parametrize('package', sorted(INSTALLED))
def test_the_files_are_installed(package: str):
    share = installed_share(package)
    assert share is not None, f'{package} is not installed beside forte_bringup (make setup)'
    for path in INSTALLED[package]:
        assert (share / path).is_file(), f'{package}: {path} is not installed (make setup)'
