"""launch/hand.launch.py against recording stand-ins of the launch API: it starts two
``hand_nodes`` processes (a console script of setup.py), ``--part gloves`` and, unless
``estimator:=false``, ``--part estimators``, without a node-name or namespace remap, declares
exactly the hand's options, and the command lines it builds for given launch arguments are read
by ``hand_nodes``' own parser as the same hand."""

import runpy
import sys
import types
from pathlib import Path

import pytest
from exodigit_nodes.nodes.hand_config import command_options, hand_config
from exodigit_nodes.nodes.hand_nodes import build_parser
from test_packaging_launch import Recorded, console_scripts

LAUNCH_FILE = Path(__file__).resolve().parents[1] / 'exodigit_nodes' / 'launch' / 'hand.launch.py'
API = {
    'launch': ['LaunchDescription'],
    'launch.actions': ['DeclareLaunchArgument', 'RegisterEventHandler', 'Shutdown'],
    'launch.conditions': ['IfCondition'],
    'launch.event_handlers': ['OnProcessExit'],
    'launch.substitutions': ['LaunchConfiguration'],
    'launch_ros': [],
    'launch_ros.actions': ['Node'],
}


@pytest.fixture
def api(monkeypatch):
    classes = {}
    for module_name, names in API.items():
        module = types.ModuleType(module_name)
        for name in names:
            classes[name] = type(name, (Recorded,), {})
            setattr(module, name, classes[name])
        monkeypatch.setitem(sys.modules, module_name, module)
    return types.SimpleNamespace(**classes)


@pytest.fixture
def entities(api):
    description = runpy.run_path(str(LAUNCH_FILE))['generate_launch_description']()
    return description.args[0]


def processes(entities, api) -> dict:
    """The launched processes by the ``--part`` they are given."""
    nodes = [e for e in entities if isinstance(e, api.Node)]
    parts = {}
    for node in nodes:
        arguments = node.kwargs['arguments']
        parts[arguments[arguments.index('--part') + 1]] = node
    assert len(parts) == len(nodes)
    return parts


def command_line(entities, api, part, **arguments) -> list[str]:
    """The arguments of the ``--part`` process for ``name:=value`` launch arguments."""
    declared = {e.args[0]: e.kwargs for e in entities if isinstance(e, api.DeclareLaunchArgument)}
    values = {
        name: arguments.pop(name, kwargs['default_value']) for name, kwargs in declared.items()
    }
    assert not arguments, f'undeclared {sorted(arguments)}'
    for name, value in values.items():
        assert value in (declared[name]['choices'] or [value]), (name, value)
    return [
        values[item.args[0]] if isinstance(item, api.LaunchConfiguration) else item
        for item in processes(entities, api)[part].kwargs['arguments']
    ]


def test_two_hand_nodes_processes_of_setup_py_without_remaps(entities, api):
    parts = processes(entities, api)
    assert sorted(parts) == ['estimators', 'gloves']
    for node in parts.values():
        assert node.kwargs['executable'] == 'hand_nodes' in console_scripts()
        assert 'name' not in node.kwargs and 'namespace' not in node.kwargs  # renames every node
    assert 'condition' not in parts['gloves'].kwargs
    (condition,) = parts['estimators'].kwargs['condition'].args
    assert isinstance(condition, api.LaunchConfiguration) and condition.args == ('estimator',)


def test_a_failed_process_of_either_part_ends_the_launch(entities, api):
    handlers = [e.args[0] for e in entities if isinstance(e, api.RegisterEventHandler)]
    targets = [handler.kwargs['target_action'] for handler in handlers]
    assert sorted(map(id, targets)) == sorted(map(id, processes(entities, api).values()))


def test_the_launch_arguments_are_the_hand_options(entities, api):
    declared = {e.args[0]: e.kwargs for e in entities if isinstance(e, api.DeclareLaunchArgument)}
    assert {name: kwargs['default_value'] for name, kwargs in declared.items()} == {
        option.name: option.default for option in command_options('hand_nodes')
    }


@pytest.mark.parametrize(
    'arguments',
    [
        {},
        {'fingers': 'index,ring', 'namespace': '/left', 'mode': 'staircase'},
        {'clock': 'sim', 'lockstep': 'true', 'real_time_factor': '0.0', 'estimator': 'false'},
    ],
)
@pytest.mark.parametrize('part', ['gloves', 'estimators'])
def test_hand_nodes_reads_the_launch_command_line_as_the_same_hand(entities, api, arguments, part):
    parsed = build_parser().parse_args(command_line(entities, api, part, **arguments))
    assert parsed.part == part
    config = hand_config(parsed)
    options = {o.name: o.default for o in command_options('hand_nodes')} | arguments
    assert config.fingers == tuple(options['fingers'].split(','))
    assert config.namespace == options['namespace']
    assert config.mode == options['mode']
    assert config.clock == options['clock']
    assert config.estimator == (options['estimator'] == 'true')
    assert config.time.lockstep == (options['lockstep'] == 'true')
    assert config.time.real_time_factor == float(options['real_time_factor'])
