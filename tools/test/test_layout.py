"""The layout rules of docs/architecture.md, checked on every tracked file.

- Size: no file over 600 lines and no function over 80 lines outside tests and generated
  code (Python by its syntax tree; C by its top-level function bodies).
- Import direction: a package imports only the packages below it in the graph of
  docs/architecture.md (forte_ros <- forte_msgs <- forte_driver <- forte_sim; forte_msgs <-
  forte_perception, forte_control; those <- forte_evaluation <- forte_bringup <-
  forte_commissioning), at run time and in its tests.
- No import circle: no module imports, through any chain of imports (deferred and
  type-checking imports included), a module that imports it back.
- Pure core, thin shell: rclpy and ROS message packages only in the ``ros/`` folder of every
  package but forte_bringup (whose launch files and runner are the shell); the pure modules
  of forte_ros (contract, parameter table, isolation) import nothing of ROS.
"""
from __future__ import annotations

import ast
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 80

#: Who may import whom (top-level import names), as in docs/architecture.md's graph.
ALLOWED_IMPORTS = {
    'forte_ros': {'forte_ros'},
    'forte_msgs': {'forte_msgs', 'forte_ros'},
    'forte_driver': {'forte_driver', 'forte_msgs', 'forte_ros'},
    'forte_sim': {'forte_sim', 'forte_driver', 'forte_msgs', 'forte_ros'},
    'forte_perception': {'forte_perception', 'forte_msgs', 'forte_ros'},
    'forte_control': {'forte_control', 'forte_msgs', 'forte_ros'},
    'forte_evaluation': {'forte_evaluation', 'forte_driver', 'forte_sim', 'forte_perception',
                         'forte_control', 'forte_msgs', 'forte_ros'},
    'forte_bringup': {'forte_bringup', 'forte_evaluation', 'forte_driver', 'forte_sim',
                      'forte_perception', 'forte_control', 'forte_msgs', 'forte_ros'},
    'forte_commissioning': {'forte_commissioning', 'forte_bringup', 'forte_evaluation',
                            'forte_driver', 'forte_sim', 'forte_perception', 'forte_control',
                            'forte_msgs', 'forte_ros'},
}
PROJECT_MODULES = set(ALLOWED_IMPORTS)
#: Import names that make a module part of the ROS shell. forte_ros counts as ROS except its
#: pure modules (:data:`PURE_FORTE_ROS`), which the cores import.
ROS_IMPORTS = re.compile(r'^(rclpy|launch|launch_ros|rosidl_\w+|rcl_interfaces|\w+_msgs|'
                         r'\w+_srvs|forte_ros)(\.|$)')
#: The modules of forte_ros that import nothing of ROS (the contract, the parameter-table
#: shape, the DDS isolation run before rclpy loads, the sensor identity check).
PURE_FORTE_ROS = ('forte_ros.contract', 'forte_ros.parameter_table', 'forte_ros.isolation',
                  'forte_ros.sensor_identity')
#: Packages that are pure Python outside their ``ros/`` folder, the ROS shell.
CORE_PACKAGES = ('forte_driver', 'forte_sim', 'forte_perception', 'forte_control',
                 'forte_evaluation', 'forte_commissioning')
#: The folder of a core package that holds its ROS shell (nodes and their parts).
SHELL_FOLDER = 'ros'


def tracked(*patterns: str) -> list[Path]:
    """Files git tracks matching ``patterns``, as they are in the working tree."""
    names = subprocess.run(['git', 'ls-files', *patterns], cwd=ROOT, capture_output=True,
                           text=True, check=True).stdout.split()
    return [ROOT / name for name in names if (ROOT / name).is_file()]


def is_test_or_generated(path: Path) -> bool:
    """Test code (test folders, test modules, conftest) or generated code (build output)."""
    parts = path.relative_to(ROOT).parts
    return (bool({'test', 'tests', 'test_vectors', 'build', 'install'} & set(parts[:-1]))
            or parts[-1].startswith('test_') or parts[-1] == 'conftest.py')


def python_functions(path: Path) -> list[tuple[str, int, int]]:
    """``(qualified name, first line, length in lines)`` of every function in ``path``."""
    found = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f'{prefix}{child.name}'
                if not isinstance(child, ast.ClassDef):
                    first = min([child.lineno, *(d.lineno for d in child.decorator_list)])
                    found.append((name, first, child.end_lineno - first + 1))
                visit(child, f'{name}.')

    visit(ast.parse(path.read_text(), filename=str(path)), '')
    return found


def c_functions(path: Path) -> list[tuple[str, int, int]]:
    """``(name, first line, length)`` of each top-level C function: a line that opens a
    brace at column 0 after a signature, to the matching ``}`` at column 0."""
    lines = path.read_text().splitlines()
    found, start = [], None
    for index, line in enumerate(lines):
        if line.startswith('{') and index > 0:
            signature = lines[index - 1] if '(' in lines[index - 1] else ''
            start = (index - 1, re.findall(r'(\w+)\s*\(', signature)[:1] or ['?'])
        elif line.startswith('}') and start is not None:
            found.append((start[1][0], start[0] + 1, index - start[0] + 1))
            start = None
    return found


def sources() -> list[Path]:
    return [path for path in tracked('*.py', '*.c', '*.h', '*.cpp')
            if not is_test_or_generated(path)]


def test_no_file_over_600_lines():
    too_long = [f'{path.relative_to(ROOT)}: {count} lines'
                for path in sources()
                if (count := len(path.read_text().splitlines())) > MAX_FILE_LINES]
    assert not too_long, 'split these files along their concerns:\n' + '\n'.join(too_long)


def test_no_function_over_80_lines():
    too_long = []
    for path in sources():
        functions = python_functions(path) if path.suffix == '.py' else c_functions(path)
        too_long += [f'{path.relative_to(ROOT)}:{line} {name}: {length} lines'
                     for name, line, length in functions if length > MAX_FUNCTION_LINES]
    assert not too_long, 'split these functions into named steps:\n' + '\n'.join(too_long)


def imported_modules(path: Path) -> set[str]:
    """Full dotted names of the absolute imports anywhere in ``path`` (``from a.b import c``
    gives ``a.b``)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def imported_names(path: Path) -> set[str]:
    """Top-level names of the absolute imports anywhere in ``path``."""
    return {name.split('.')[0] for name in imported_modules(path)}


@pytest.mark.parametrize('package', sorted(ALLOWED_IMPORTS))
def test_imports_follow_the_package_graph(package):
    wrong = []
    for path in tracked(f'{package}/*.py'):
        forbidden = (imported_names(path) & PROJECT_MODULES) - ALLOWED_IMPORTS[package]
        wrong += [f'{path.relative_to(ROOT)} imports {name}' for name in sorted(forbidden)]
    assert not wrong, ('these imports go against docs/architecture.md\'s package graph:\n'
                       + '\n'.join(wrong))


def module_files() -> dict[str, Path]:
    """Dotted module name -> source file, for every tracked module of the packages' own
    folders (``forte_x/forte_x/...``; a package's ``__init__.py`` under the package's name)."""
    modules = {}
    for package in sorted(PROJECT_MODULES):
        for path in tracked(f'{package}/{package}/*.py'):
            parts = path.relative_to(ROOT / package).with_suffix('').parts
            name = '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)
            modules[name] = path
    return modules


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """module -> the project modules it imports, deferred and type-checking imports included.

    ``from a.b import c`` names the module ``a.b.c`` when there is one, else ``a.b``; a
    package's ``__init__`` that only the import machinery runs on the way to a submodule is
    not an edge (it is not what the importing code asked for)."""
    graph = {}
    for name, path in modules.items():
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                edges.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                for alias in node.names:
                    submodule = f'{node.module}.{alias.name}'
                    edges.add(submodule if submodule in modules else node.module)
        graph[name] = {edge for edge in edges if edge in modules and edge != name}
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for target in sorted(graph.get(node, ())):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_no_import_circle_anywhere():
    graph = import_graph(module_files())
    assert len(graph) > 100 and sum(map(len, graph.values())) > 200  # it read the tree
    found = circles(graph)
    assert not found, 'these modules import each other in a circle:\n' + '\n'.join(
        ' <-> '.join(component) for component in found)


def test_the_circle_check_sees_a_circle():
    graph = {'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}, 'e': set()}
    assert circles(graph) == [['a', 'b', 'c']]
    assert circles({'a': {'b'}, 'b': set()}) == []


def ros_imports(path: Path) -> list[str]:
    """The imports of ``path`` that make it ROS code (pure forte_ros modules excepted)."""
    return sorted(name for name in imported_modules(path)
                  if ROS_IMPORTS.match(name) and not name.startswith(PURE_FORTE_ROS))


@pytest.mark.parametrize('package', CORE_PACKAGES)
def test_ros_only_in_the_shell(package):
    wrong = []
    for path in tracked(f'{package}/{package}/*.py'):
        relative = path.relative_to(ROOT / package / package)
        if relative.parts[0] == SHELL_FOLDER:
            continue
        ros = ros_imports(path)
        wrong += [f'{package}/{package}/{relative} imports {", ".join(ros)}'] if ros else []
    assert not wrong, ('the pure core must not import ROS (move the code into the package\'s '
                       f'{SHELL_FOLDER}/ folder):\n' + '\n'.join(wrong))


def test_pure_forte_ros_modules_import_no_ros():
    """The contract, the parameter-table shape and the isolation run in pure cores and before
    rclpy loads; forte_ros's ``__init__`` imports nothing eagerly."""
    wrong = []
    for module in (*PURE_FORTE_ROS, 'forte_ros'):
        parts = module.split('.')
        path = ROOT / 'forte_ros' / Path(*parts).with_suffix('.py') if len(parts) > 1 \
            else ROOT / 'forte_ros' / 'forte_ros' / '__init__.py'
        ros = ros_imports(path)
        wrong += [f'{module} imports {", ".join(ros)}'] if ros else []
    assert not wrong, '\n'.join(wrong)


def test_the_checks_see_what_they_judge():
    """The scanners find known functions (a check that reads nothing passes anything)."""
    names = {name for name, _, _ in python_functions(Path(__file__))}
    assert {'tracked', 'python_functions', 'test_no_function_over_80_lines'} <= names
    c_files = [path for path in sources() if path.suffix == '.c']
    assert c_files and any(c_functions(path) for path in c_files)
    assert len(sources()) > 50
    assert any(ROS_IMPORTS.match(name) for name in ('rclpy', 'diagnostic_msgs', 'std_srvs'))
    assert ros_imports(ROOT / 'forte_ros' / 'forte_ros' / 'qos.py') == ['rclpy.qos']


#: The sensor contract's names (forte_ros.contract) and the aliases they used to have.
CONTRACT_NAMES = {'CHANNEL_NAMES', 'N_CHANNELS', 'CHANNEL_COUNT', 'FINGERS', 'FINGER_CHANNELS',
                  'FINGER_NAMES', 'SAMPLE_RATE', 'SAMPLE_PERIOD', 'FS', 'QUANTUM', 'LSB',
                  'COUNTS_PER_FULL_SCALE', 'VALUE_RANGE'}
CONTRACT_MODULE = ROOT / 'forte_ros' / 'forte_ros' / 'contract.py'
#: A name that holds a sample rate (an assignment or a default argument).
RATE_NAME = re.compile(r'(^|_)(fs|sample_rate|rate_hz)$', re.IGNORECASE)


def contract_redefinitions(path: Path) -> list[str]:
    """Places in ``path`` that declare a fact of the sensor contract again.

    An assignment to a contract name; a channel name written as a string; a finger group
    written as an index tuple; 2000 (the sample rate) assigned to, or the default of, a
    rate-like name. Docstrings are text, not declarations, and are not looked at.
    """
    from forte_ros.contract import CHANNEL_NAMES, FINGER_CHANNELS, SAMPLE_RATE

    tree = ast.parse(path.read_text(), filename=str(path))
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                       ast.AsyncFunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr)}
    # ``A, B, C = 0, 1, 2`` unpacks three constants; it writes no index tuple
    unpacked = {id(node.value) for node in ast.walk(tree)
                if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Tuple)}
    found = []

    def is_rate(value: ast.AST | None) -> bool:
        return isinstance(value, ast.Constant) and not isinstance(value.value, bool) \
            and value.value == SAMPLE_RATE

    for node in ast.walk(tree):
        where = f'{path.relative_to(ROOT)}:{getattr(node, "lineno", "?")}'
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names = [target.id for target in targets if isinstance(target, ast.Name)]
            found += [f'{where} assigns {name}' for name in names if name in CONTRACT_NAMES]
            found += [f'{where} assigns the sample rate to {name}' for name in names
                      if RATE_NAME.search(name) and is_rate(node.value)]
        elif isinstance(node, ast.arguments):
            positional = node.posonlyargs + node.args
            pairs = list(zip(positional[len(positional) - len(node.defaults):], node.defaults))
            pairs += [(arg, default) for arg, default in zip(node.kwonlyargs, node.kw_defaults)]
            found += [f'{where} defaults {arg.arg} to the sample rate' for arg, default in pairs
                      if RATE_NAME.search(arg.arg) and is_rate(default)]
        elif isinstance(node, ast.Constant) and id(node) not in docstrings \
                and node.value in CHANNEL_NAMES:
            found.append(f'{where} writes the channel name {node.value!r}')
        elif isinstance(node, ast.Tuple) and id(node) not in unpacked \
                and all(isinstance(e, ast.Constant) for e in node.elts) \
                and tuple(e.value for e in node.elts) in FINGER_CHANNELS:
            found.append(f'{where} writes a finger group {tuple(e.value for e in node.elts)}')
    return found


def test_the_contract_is_declared_once():
    """Channel names, finger groups, the sample rate and the value scale are declared in
    forte_ros.contract only; runtime code, tools and benchmarks import them (tests may
    write the documented values themselves, as an outsider would)."""
    wrong = [place for path in tracked('*.py')
             if path.suffix == '.py' and path != CONTRACT_MODULE
             and not is_test_or_generated(path)
             for place in contract_redefinitions(path)]
    assert not wrong, ('declare these with forte_ros.contract instead:\n' + '\n'.join(wrong))


def test_the_redefinition_check_sees_a_redefinition():
    """The scanner finds each kind of redefinition (a check that finds nothing passes all)."""
    sample = ROOT / 'tools' / 'test' / '_redefinition_sample.py'
    sample.write_text('"""left_distal in a docstring is text."""\n'
                      "CHANNEL_NAMES = ('left_distal',)\n"
                      'GROUP = (3, 4, 5)\n'
                      'LOW, MIDDLE, HIGH = 0, 1, 2\n'
                      'fs = 2000.0\n'
                      'def f(x, sample_rate=2000):\n'
                      '    return x\n')
    try:
        found = contract_redefinitions(sample)
    finally:
        sample.unlink()
    assert len(found) == 5, found
    assert any('assigns CHANNEL_NAMES' in place for place in found)
    assert any("channel name 'left_distal'" in place for place in found)
    assert any('finger group (3, 4, 5)' in place for place in found)
    assert any('assigns the sample rate to fs' in place for place in found)
    assert any('defaults sample_rate' in place for place in found)


def test_no_module_is_loaded_by_file_path():
    """Modules are imported by name from installed packages (colcon's and pip's view), never
    executed from a file path: such an edge is invisible to the import-direction test."""
    loaders = re.compile(r'\b(spec_from_file_location|SourceFileLoader|run_path|load_source)\b')
    wrong = [f'{path.relative_to(ROOT)}:{number}'
             for path in tracked('*.py') if path != Path(__file__)
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if loaders.search(line)]
    assert not wrong, 'import these by module name instead:\n' + '\n'.join(wrong)
