"""The launch file: it compiles, names the package's executables and existing config files, and
evaluated against a recording stand-in of the launch API it declares every argument it uses."""

import ast
import fnmatch
import py_compile
import runpy
import sys
import types
from pathlib import Path

import pytest
from exodigit_nodes.glove import MODES

PACKAGE_DIR = Path(__file__).resolve().parents[1] / 'exodigit_nodes'
LAUNCH_FILE = PACKAGE_DIR / 'launch' / 'glove.launch.py'
NODE_EXECUTABLES = {'plant', 'pressure_command', 'estimator'}


def setup_call() -> ast.Call:
    tree = ast.parse((PACKAGE_DIR / 'setup.py').read_text())
    calls = [
        node
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and getattr(node.func, 'id', '') == 'setup'
    ]
    assert len(calls) == 1
    return calls[0]


def console_scripts() -> set[str]:
    """Executable names of setup.py's console_scripts (the part before ' = ')."""
    entry_points = {k.arg: k.value for k in setup_call().keywords}['entry_points']
    groups = dict(zip(map(ast.literal_eval, entry_points.keys), entry_points.values, strict=True))
    names = set()
    for entry in groups['console_scripts'].elts:
        text = entry.values[0].value if isinstance(entry, ast.JoinedStr) else entry.value
        names.add(text.split('=')[0].strip())
    return names


def data_file_globs() -> list[str]:
    """The patterns setup.py installs into share/ with glob()."""
    return [
        node.args[0].value
        for node in ast.walk(setup_call())
        if isinstance(node, ast.Call) and getattr(node.func, 'id', '') == 'glob'
    ]


def launch_strings() -> set[str]:
    tree = ast.parse(LAUNCH_FILE.read_text())
    return {
        n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)
    }


def test_launch_file_compiles(tmp_path):
    py_compile.compile(str(LAUNCH_FILE), cfile=str(tmp_path / 'launch.pyc'), doraise=True)


def test_launch_file_starts_the_three_node_executables_of_setup_py():
    scripts = console_scripts()
    assert scripts >= NODE_EXECUTABLES
    assert launch_strings() >= NODE_EXECUTABLES


def test_launch_and_config_files_are_installed_by_setup_py():
    globs = data_file_globs()
    relative = LAUNCH_FILE.relative_to(PACKAGE_DIR).as_posix()
    assert any(fnmatch.fnmatch(relative, pattern) for pattern in globs)
    configs = sorted((PACKAGE_DIR / 'config').glob('*.yaml'))
    assert configs, 'no config/*.yaml in the package'
    for config in configs:
        assert any(fnmatch.fnmatch(config.relative_to(PACKAGE_DIR).as_posix(), p) for p in globs)


class Recorded:
    """Stand-in for a launch API class: keeps its constructor arguments."""

    def __init__(self, *args, **kwargs):
        self.args = args
        self.kwargs = kwargs


@pytest.fixture
def launch_api(monkeypatch):
    """Minimal recording replacements for launch, launch_ros and ament_index_python."""
    kinds = {
        'launch': ['LaunchDescription'],
        'launch.actions': ['DeclareLaunchArgument'],
        'launch.substitutions': ['LaunchConfiguration'],
        'launch_ros': [],
        'launch_ros.actions': ['Node'],
        'launch_ros.parameter_descriptions': ['ParameterValue'],
    }
    classes = {}
    for module_name, names in kinds.items():
        module = types.ModuleType(module_name)
        for name in names:
            classes[name] = type(name, (Recorded,), {})
            setattr(module, name, classes[name])
        monkeypatch.setitem(sys.modules, module_name, module)
    ament = types.ModuleType('ament_index_python.packages')
    ament.get_package_share_directory = lambda package: str(
        PACKAGE_DIR if package == 'exodigit_nodes' else Path('/nonexistent')
    )
    monkeypatch.setitem(sys.modules, 'ament_index_python.packages', ament)
    return classes


def test_launch_description_declares_every_argument_it_uses(launch_api):
    description = runpy.run_path(str(LAUNCH_FILE))['generate_launch_description']()
    entities = description.args[0]
    declared = {
        e.args[0]: e.kwargs for e in entities if isinstance(e, launch_api['DeclareLaunchArgument'])
    }
    assert set(declared) >= {'namespace', 'mode', 'params_file', 'joint_prefix', 'use_sim_time'}
    for name, kwargs in declared.items():
        assert kwargs.get('description', '').strip(), f'argument {name} has no description'
        assert 'default_value' in kwargs, f'argument {name} has no default'

    nodes = [e for e in entities if isinstance(e, launch_api['Node'])]
    assert {n.kwargs['executable'] for n in nodes} == NODE_EXECUTABLES

    def used_configurations(value):
        if isinstance(value, launch_api['LaunchConfiguration']):
            yield value.args[0]
        elif isinstance(value, Recorded):
            for item in list(value.args) + list(value.kwargs.values()):
                yield from used_configurations(item)
        elif isinstance(value, list | tuple):
            for item in value:
                yield from used_configurations(item)
        elif isinstance(value, dict):
            for item in value.values():
                yield from used_configurations(item)

    for node in nodes:
        assert set(used_configurations(node)) <= set(declared)
        files = [p for p in node.kwargs['parameters'] if isinstance(p, str)]
        assert files, f'{node.kwargs["executable"]} loads no config file'
        for path in files:
            assert Path(path).is_file(), f'{path} does not exist'
            assert Path(path).parent == PACKAGE_DIR / 'config'
    assert declared['mode']['choices'] == list(MODES)
    assert declared['mode']['default_value'] == 'sine'
