"""forte_description on its own: the xacro expands, the mesh it names is in the package, the
launch files (the RViz view, the gripper under ros2_control) and the RViz configuration are
what their documented formats say, every folder is installed.

Needs xacro (its exec_depend) and PyYAML (RViz configurations are YAML); no FORTE Python
package. ``launch`` is used where installed (the launch kit, a ROS install): the launch files
are then loaded and their declared arguments read from the LaunchDescription itself.
"""
from __future__ import annotations

import ast
import importlib.util
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

PACKAGE = Path(__file__).resolve().parents[1]
URDF = PACKAGE / 'urdf'
RVIZ_FILE = PACKAGE / 'rviz' / 'view_gripper.rviz'
#: launch file -> (its arguments, the packages whose nodes it starts)
LAUNCH_FILES = {
    'view_gripper.launch.py': ({'prefix', 'gui', 'rviz', 'rviz_config'},
                               ('robot_state_publisher', 'joint_state_publisher_gui', 'rviz2')),
    'gripper_control.launch.py': ({'use_mock_hardware', 'initial_position',
                                   'joint_state_broadcaster', 'controllers_file'},
                                  ('robot_state_publisher', 'controller_manager')),
}


def expand(prefix: str) -> ET.Element:
    xacro = pytest.importorskip('xacro')
    document = xacro.process_file(str(URDF / 'forte_gripper.urdf.xacro'),
                                  mappings={'prefix': prefix})
    return ET.fromstring(document.toxml())


@pytest.mark.parametrize('prefix', ['', 'right_'])
def test_the_standalone_gripper_expands_with_its_prefix(prefix):
    robot = expand(prefix)
    links = {link.get('name') for link in robot.iter('link')}
    children = {joint.find('child').get('link') for joint in robot.iter('joint')}
    assert links - children == {f'{prefix}forte_base_link'}  # one root
    movable = {joint.get('name') for joint in robot.iter('joint')
               if joint.get('type') != 'fixed'}
    assert movable == {f'{prefix}forte_left_finger_joint', f'{prefix}forte_right_finger_joint'}
    assert all(name.startswith(prefix) for name in links)


def test_every_mesh_is_a_file_of_this_package():
    meshes = {mesh.get('filename') for mesh in expand('').iter('mesh')}
    assert meshes, 'the fingers have a visual mesh'
    for uri in meshes:
        assert uri.startswith('package://forte_description/'), uri
        assert (PACKAGE / uri.removeprefix('package://forte_description/')).is_file(), uri


def declared_arguments_in_source(launch_file: Path) -> dict[str, str]:
    """name -> description of ARGUMENTS in ``launch_file``, read with ``ast``."""
    tree = ast.parse(launch_file.read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and node.targets[0].id == 'ARGUMENTS':
            return {item.elts[0].value: item.elts[2].value for item in node.value.elts}
    raise AssertionError(f'no ARGUMENTS table in {launch_file.name}')


@pytest.mark.parametrize('name', sorted(LAUNCH_FILES))
def test_the_launch_files_declare_each_argument_with_a_description(name):
    launch_file = PACKAGE / 'launch' / name
    arguments = declared_arguments_in_source(launch_file)
    expected, packages = LAUNCH_FILES[name]
    assert set(arguments) == expected
    assert all(len(text) > 10 for text in arguments.values())
    text = launch_file.read_text()
    for package in packages:
        assert f"package='{package}'" in text


def test_the_control_launch_expands_the_gripper_with_its_ros2_control_tag():
    text = (PACKAGE / 'launch' / 'gripper_control.launch.py').read_text()
    assert "'forte_gripper.urdf.xacro'" in text and ' ros2_control:=true ' in text
    assert "'forte_controllers.yaml'" in text
    assert "arguments=['forte_gripper_controller']" in text
    assert "arguments=['joint_state_broadcaster']" in text


@pytest.mark.parametrize('name', sorted(LAUNCH_FILES))
def test_the_launch_files_load_where_launch_is_installed(name):
    if importlib.util.find_spec('launch_ros') is None:
        pytest.skip('launch_ros is not installed (no ROS install, no launch kit)')
    from launch.actions import DeclareLaunchArgument
    from launch.launch_description_sources import (
        get_launch_description_from_python_launch_file,
    )

    entities = get_launch_description_from_python_launch_file(
        str(PACKAGE / 'launch' / name)).entities
    declared = {entity.name: entity.description for entity in entities
                if isinstance(entity, DeclareLaunchArgument)}
    assert set(declared) == LAUNCH_FILES[name][0]


def test_the_rviz_view_shows_the_robot_description_from_its_base():
    config = yaml.safe_load(RVIZ_FILE.read_text())
    manager = config['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == 'forte_base_link'
    model = [d for d in manager['Displays'] if d['Class'] == 'rviz_default_plugins/RobotModel']
    assert len(model) == 1 and model[0]['Description Topic']['Value'] == '/robot_description'
    assert model[0]['Description Topic']['Durability Policy'] == 'Transient Local'


def test_the_package_needs_no_python_at_run_time():
    manifest = ET.parse(PACKAGE / 'package.xml').getroot()
    runtime = {e.text for e in manifest if e.tag in ('depend', 'exec_depend')}
    assert runtime and not {key for key in runtime if key.startswith('python3-')}
    assert manifest.find('export/build_type').text == 'ament_cmake'


def test_every_folder_of_the_package_is_installed():
    """Each top-level folder but test/ is in an install(DIRECTORY ...) rule to share/."""
    rules = re.findall(r'install\(DIRECTORY ([\w ]+?) DESTINATION share/\$\{PROJECT_NAME\}',
                       (PACKAGE / 'CMakeLists.txt').read_text())
    installed = {name for rule in rules for name in rule.split()}
    folders = {path.name for path in PACKAGE.iterdir()
               if path.is_dir() and not path.name.startswith(('.', '__'))} - {'test'}
    assert folders == {'urdf', 'srdf', 'config', 'scripts', 'meshes', 'rviz', 'launch'}
    assert installed == folders
