"""Package metadata a colcon / rosdep user relies on: every package.xml parses and is consistent."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

ROOT = Path(__file__).resolve().parents[2]
PYTHON_PACKAGES = ('forte_ros', 'forte_driver', 'forte_sim', 'forte_perception', 'forte_control',
                   'forte_bringup')
ALL_PACKAGES = ('forte_msgs',) + PYTHON_PACKAGES


@pytest.mark.parametrize('name', ALL_PACKAGES)
def test_package_xml_is_valid_format_3(name):
    package = parse_package(ROOT / name / 'package.xml')  # raises on invalid content
    package.validate()
    assert package.name == name
    assert package.package_format == 3
    assert package.licenses == ['Apache-2.0']
    build_type = package.get_build_type()
    assert build_type == ('ament_cmake' if name == 'forte_msgs' else 'ament_python')


@pytest.mark.parametrize('name', PYTHON_PACKAGES)
def test_ament_python_package_layout(name):
    folder = ROOT / name
    assert (folder / 'resource' / name).is_file(), 'ament index marker missing'
    assert (folder / name / '__init__.py').is_file()
    setup_cfg = (folder / 'setup.cfg').read_text()
    assert f'script_dir=$base/lib/{name}' in setup_cfg  # where `ros2 run` looks
    setup_tree = ast.parse((folder / 'setup.py').read_text())
    names = {node.value for node in ast.walk(setup_tree)
             if isinstance(node, ast.Constant) and isinstance(node.value, str)}
    assert name in names


@pytest.mark.parametrize('name', PYTHON_PACKAGES)
def test_runtime_dependencies_use_rosdep_keys(name):
    package = parse_package(ROOT / name / 'package.xml')
    depends = {d.name for d in package.exec_depends + package.build_depends}
    # forte_ros is the bottom of the graph (docs/architecture.md): it needs no interfaces
    assert {'rclpy', 'forte_ros'} - {name} <= depends
    assert name == 'forte_ros' or 'forte_msgs' in depends
    for python_dependency in (d for d in depends if d.startswith('python')):
        assert python_dependency.startswith('python3-'), python_dependency


def test_interfaces_listed_in_cmake_exist():
    cmake = (ROOT / 'forte_msgs' / 'CMakeLists.txt').read_text()
    listed = {line.strip().strip('"') for line in cmake.splitlines()
              if line.strip().startswith('"') and line.strip().endswith('"')}
    interfaces = (ROOT / 'forte_msgs').glob('*/*')
    on_disk = {str(p.relative_to(ROOT / 'forte_msgs'))
               for p in interfaces if p.suffix in ('.msg', '.srv', '.action')}
    assert listed == on_disk


def test_every_interface_field_has_a_comment():
    """The brief asks for every field to be commented with its unit."""
    for path in (ROOT / 'forte_msgs').glob('*/*'):
        if path.suffix not in ('.msg', '.srv', '.action'):
            continue
        for line in path.read_text().splitlines():
            code = line.split('#')[0].strip()
            if code and code != '---' and '=' not in code and code.split()[0] != 'std_msgs/Header':
                assert '#' in line, f'{path.name}: field without comment: {line!r}'


def test_forte_msgs_is_interfaces_only():
    """forte_msgs generates interfaces and nothing else: no Python package of its own, and no
    run-time dependency beyond what the generated code loads (forte_ros is its own package)."""
    package = parse_package(ROOT / 'forte_msgs' / 'package.xml')
    runtime = {d.name for d in package.exec_depends + package.build_export_depends}
    assert runtime <= {'rosidl_default_runtime', 'std_msgs'}, runtime
    cmake = (ROOT / 'forte_msgs' / 'CMakeLists.txt').read_text()
    assert 'ament_python_install_package' not in cmake
    assert not [path for path in (ROOT / 'forte_msgs').rglob('*.py') if 'test' not in path.parts]
