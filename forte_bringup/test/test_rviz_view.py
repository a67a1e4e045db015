"""The RViz view written for a graph's namespace and prefix (forte_bringup.rviz_view), and
the graph arguments that start rviz2 and set use_sim_time (pure: no rclpy, no launch)."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from forte_bringup.graph import GRAPHS, argument_settings, node_arguments, params_file
from forte_bringup.graph_nodes import started_nodes
from forte_bringup.robot_model import RVIZ_MISSING
from forte_bringup.rviz_view import view_document, view_topics, write_view

ROOT_TOPICS = {
    '/robot_description': 'std_msgs/msg/String',
    '/visualization/left_pad_wrench': 'geometry_msgs/msg/WrenchStamped',
    '/visualization/right_pad_wrench': 'geometry_msgs/msg/WrenchStamped',
    '/visualization/markers': 'visualization_msgs/msg/MarkerArray',
}


def fixed_frame(document: dict) -> str:
    return document['Visualization Manager']['Global Options']['Fixed Frame']


def test_the_root_view_is_the_shipped_file():
    document = view_document()
    assert view_topics(document) == ROOT_TOPICS
    assert fixed_frame(document) == 'forte_base_link'


@pytest.mark.parametrize('namespace', ['right', '/right', '/robots/right'])
def test_a_namespaced_prefixed_view_moves_every_topic_into_the_namespace(namespace):
    document = view_document(namespace, 'right_', own_model=True)
    inside = '/' + namespace.strip('/')
    expected = {f'{inside}{topic}': kind for topic, kind in ROOT_TOPICS.items()}
    assert view_topics(document) == expected
    assert fixed_frame(document) == 'right_forte_base_link'


def test_without_its_own_model_the_view_reads_the_robots_description():
    topics = view_topics(view_document('right', 'right_', own_model=False))
    assert '/robot_description' in topics and '/right/robot_description' not in topics
    assert '/right/visualization/markers' in topics


@pytest.mark.parametrize('namespace, prefix', [('1right', ''), ('', '/right_'),
                                               ('', 'right-')])
def test_an_invalid_namespace_or_prefix_is_refused(namespace, prefix):
    with pytest.raises(ValueError):
        view_document(namespace, prefix)


def test_the_written_file_is_the_document_and_one_per_setting():
    first = write_view('right', 'right_', False)
    assert yaml.safe_load(first.read_text()) == view_document('right', 'right_', False)
    assert write_view('right', 'right_', False) == first
    assert write_view('left', 'left_', False) != first


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_every_graph_has_rviz_and_use_sim_time_and_rviz_gets_its_view(graph: str):
    spec = GRAPHS[graph]
    assert spec.argument('rviz').default == 'false'
    assert spec.argument('use_sim_time').default == ''
    rviz = spec.node('rviz2')
    flag, path = node_arguments(rviz, {'namespace': 'right', 'prefix': 'right_'}, spec)
    own_model = graph != 'hardware'
    assert flag == '-d'
    assert yaml.safe_load(Path(path).read_text()) == view_document('right', 'right_', own_model)
    # rviz off by default; on, but not installed here: one line, the graph goes on
    nodes, notes = started_nodes(spec, {}, environ={'AMENT_PREFIX_PATH': ''})
    assert 'rviz2' not in {node.name for node in nodes} and RVIZ_MISSING not in notes
    nodes, notes = started_nodes(spec, {'rviz': 'true'}, environ={'AMENT_PREFIX_PATH': ''})
    assert 'rviz2' not in {node.name for node in nodes} and RVIZ_MISSING in notes


def test_the_hardware_graph_leaves_the_robot_model_to_the_robot():
    assert GRAPHS['hardware'].argument('robot_state_publisher').default == 'false'
    assert GRAPHS['sim'].argument('robot_state_publisher').default == 'true'
    assert GRAPHS['replay'].argument('robot_state_publisher').default == 'true'


@pytest.mark.parametrize('value, expected', [('true', True), ('false', False), ('1', True)])
def test_use_sim_time_reaches_every_node(value: str, expected: bool):
    graph = GRAPHS['hardware']
    for spec in graph.nodes:
        _, parameters = argument_settings(spec, {'use_sim_time': value}, graph)
        assert parameters['use_sim_time'] is expected, spec.name


def test_use_sim_time_empty_leaves_the_yaml_which_gives_rviz_the_graphs_time():
    for name, clock in (('sim', True), ('hardware', False), ('replay', False)):
        graph = GRAPHS[name]
        for spec in graph.nodes:
            _, parameters = argument_settings(spec, {}, graph)
            assert 'use_sim_time' not in parameters
        document = yaml.safe_load(params_file(name).read_text())
        assert document['rviz2']['ros__parameters'].get('use_sim_time', False) is clock, name
    with pytest.raises(ValueError, match='use_sim_time'):
        argument_settings(GRAPHS['sim'].node('perception'), {'use_sim_time': 'maybe'},
                          GRAPHS['sim'])
