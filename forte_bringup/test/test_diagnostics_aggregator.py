"""config/diagnostics_aggregator.yaml sorts every FORTE status into exactly one analyzer.

Pure: the status names are read from the node sources (the first argument of every
``diagnostic_status(...)`` call, an f-string whose fields become wildcards) and compared
with :data:`STATUS_NAMES`, the names as published under the nodes' own names and under
their names in the graphs; each of those must be matched by exactly one GenericAnalyzer of
the file, with the matching rules of ROS 2 Jazzy's diagnostic_aggregator
(``GenericAnalyzer::match``: ``regex`` must match the whole name, ``expected`` is an exact
name, ``startswith`` a prefix, ``contains`` a substring; ``name`` is not read in ROS 2).
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
import yaml

from forte_ros.contract import CHANNEL_NAMES

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / 'forte_bringup' / 'config' / 'diagnostics_aggregator.yaml'
PACKAGES = ('forte_driver', 'forte_sim', 'forte_perception', 'forte_control', 'forte_bringup')

#: Parameters ROS 2's GenericAnalyzer reads (diagnostic_aggregator 4.x, generic_analyzer.cpp).
GENERIC_KEYS = {'type', 'path', 'startswith', 'contains', 'regex', 'expected', 'remove_prefix',
                'find_and_remove_prefix', 'timeout', 'num_items', 'discard_stale'}
MATCH_KEYS = ('startswith', 'contains', 'regex', 'expected', 'find_and_remove_prefix')
#: Parameters of the aggregator itself (node "analyzers").
AGGREGATOR_KEYS = {'path', 'pub_rate', 'base_path', 'other_as_errors', 'history_depth',
                   'critical'}

#: Every status FORTE's nodes publish in the root namespace: under the executables' own node
#: names (serial_sensor_node, forte_sim) and under the graphs' (serial_sensor, sim); the
#: gripper servos with their default ids (right 1, left 2).
ROOT_STATUS_NAMES = (
    'serial_sensor_node: tactile sensor', 'serial_sensor: tactile sensor',
    'forte_sim: simulated scene', 'sim: simulated scene',
    'bag_replay: bag replay',
    'gripper_driver: driver', 'gripper_driver: left finger servo (id 2)',
    'gripper_driver: right finger servo (id 1)',
    'perception: pipeline', *(f'perception: channel {name}' for name in CHANNEL_NAMES),
    'grasp_controller: grasp controller',
)
#: The same in a graph launched with namespace:=right: the node path starts the name.
STATUS_NAMES = (*ROOT_STATUS_NAMES, *(f'right/{name}' for name in ROOT_STATUS_NAMES))
#: The analyzer path (below FORTE) each status belongs to.
EXPECTED_PATHS = {
    'tactile sensor': 'Sensor', 'simulated scene': 'Sensor', 'bag replay': 'Sensor',
    'driver': 'Gripper', 'finger servo': 'Gripper', 'pipeline': 'Perception/Pipeline',
    'channel': 'Perception/Channels', 'grasp controller': 'Controller',
}


def status_templates() -> dict[str, str]:
    """Regular expression of every status name in the nodes' sources -> its file.

    The first argument of each ``diagnostic_status(...)`` call: a text, or an f-string whose
    replacement fields (``{self.get_name()}``, ``{name}``, ...) become ``.+``.
    """
    templates = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package / package).rglob('*.py')):
            tree = ast.parse(path.read_text(), filename=str(path))
            for node in ast.walk(tree):
                if not (isinstance(node, ast.Call) and node.args and getattr(
                        node.func, 'attr', getattr(node.func, 'id', None)) == 'diagnostic_status'):
                    continue
                first = node.args[0]
                if isinstance(first, ast.Constant):
                    pattern = re.escape(first.value)
                elif isinstance(first, ast.JoinedStr):
                    pattern = ''.join(re.escape(part.value) if isinstance(part, ast.Constant)
                                      else '.+' for part in first.values)
                else:
                    raise AssertionError(f'{path}:{node.lineno}: status name is not a literal')
                templates[pattern] = str(path.relative_to(ROOT))
    return templates


def leaf_analyzers(block: dict, path: str = '') -> dict[str, dict]:
    """Every GenericAnalyzer below an aggregator or AnalyzerGroup block: full path -> its
    parameters."""
    leaves = {}
    for key, value in block.items():
        if key in AGGREGATOR_KEYS | {'type', 'analyzers'} or not isinstance(value, dict):
            continue
        kind = value.get('type', '')
        name = f"{path}/{value['path']}".lstrip('/')
        if kind == 'diagnostic_aggregator/AnalyzerGroup':
            leaves.update(leaf_analyzers(value.get('analyzers', {}), name))
        else:
            assert kind == 'diagnostic_aggregator/GenericAnalyzer', (key, kind)
            leaves[name] = value
    return leaves


def matches(analyzer: dict, name: str) -> bool:
    """``GenericAnalyzer::match`` of ROS 2 Jazzy for one status ``name``."""
    return (any(re.fullmatch(pattern, name) for pattern in analyzer.get('regex', []))
            or name in analyzer.get('expected', [])
            or any(name.startswith(prefix) for prefix in
                   [*analyzer.get('startswith', []), *analyzer.get('find_and_remove_prefix', [])])
            or any(text in name for text in analyzer.get('contains', [])))


@pytest.fixture(scope='module')
def analyzers() -> dict[str, dict]:
    document = yaml.safe_load(CONFIG.read_text())
    assert set(document) == {'analyzers'}, 'the aggregator node is called "analyzers"'
    parameters = document['analyzers']['ros__parameters']
    assert parameters['path'] == 'FORTE'
    return leaf_analyzers(parameters)


def test_every_analyzer_uses_parameters_ros2_reads(analyzers):
    assert len(analyzers) >= 5
    for path, analyzer in analyzers.items():
        assert set(analyzer) <= GENERIC_KEYS, (path, set(analyzer) - GENERIC_KEYS)
        assert any(analyzer.get(key) for key in MATCH_KEYS), f'{path} matches nothing'
        for key in MATCH_KEYS:
            values = analyzer.get(key, [])
            assert isinstance(values, list) and all(isinstance(v, str) and v for v in values), \
                f'{path}.{key}: a list of strings (read with as_string_array)'
        assert isinstance(analyzer.get('timeout', 5.0), float)


def test_the_status_list_is_what_the_nodes_publish():
    templates = status_templates()
    assert len(templates) >= 8, templates
    for pattern, where in templates.items():
        assert any(re.fullmatch(pattern, name) for name in STATUS_NAMES), \
            f'{where} publishes {pattern!r}: add its names to STATUS_NAMES and an analyzer'
    for name in STATUS_NAMES:
        assert any(re.fullmatch(pattern, name) for pattern in templates), \
            f'{name!r} is published by no node any more'


@pytest.mark.parametrize('name', STATUS_NAMES)
def test_each_status_has_exactly_one_analyzer(analyzers, name):
    found = [path for path, analyzer in analyzers.items() if matches(analyzer, name)]
    assert len(found) == 1, f'{name!r} is matched by {found}'
    part = next(key for key in EXPECTED_PATHS if key in name.split(': ', 1)[1])
    assert found == [EXPECTED_PATHS[part]]


def test_two_namespaced_graphs_publish_distinct_status_names():
    root = set(ROOT_STATUS_NAMES)
    right = set(STATUS_NAMES) - root
    assert len(right) == len(root) and not root & right


def test_other_nodes_statuses_stay_outside(analyzers):
    for name in ('arm_controller: joint 1', 'ur_driver: robot', 'camera: frame rate'):
        assert not any(matches(analyzer, name) for analyzer in analyzers.values()), name


def test_the_matching_rules():
    assert matches({'regex': ['a.*z']}, 'abcz') and not matches({'regex': ['b']}, 'abc')
    assert matches({'startswith': ['ab']}, 'abc') and not matches({'startswith': ['bc']}, 'abc')
    assert matches({'contains': ['bc']}, 'abcd') and matches({'expected': ['abc']}, 'abc')
