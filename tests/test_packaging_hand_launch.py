"""launch/hand.launch.py against recording stand-ins of the launch API: it starts one
``hand_nodes`` process (a console script of setup.py) without a node-name or namespace remap,
fails the launch when that process fails, declares exactly the hand's options, and the command
line it builds for given launch arguments (``estimator:=false`` too) is read by ``hand_nodes``'
own parser as the same hand."""

import runpy
import sys
import types
from pathlib import Path

import pytest
from exodigit_nodes.nodes.hand_config import command_options, hand_config
from exodigit_nodes.nodes.hand_nodes import build_parser
from test_packaging_launch import FakeEvent, Recorded, console_scripts

LAUNCH_FILE = Path(__file__).resolve().parents[1] / 'exodigit_nodes' / 'launch' / 'hand.launch.py'
API = {
    'launch': ['LaunchDescription'],
    'launch.actions': ['DeclareLaunchArgument', 'RegisterEventHandler'],
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


def hand_process(entities, api):
    """The one launched process."""
    (node,) = [e for e in entities if isinstance(e, api.Node)]
    return node


def command_line(entities, api, **arguments) -> list[str]:
    """The arguments of the process for ``name:=value`` launch arguments."""
    declared = {e.args[0]: e.kwargs for e in entities if isinstance(e, api.DeclareLaunchArgument)}
    values = {
        name: arguments.pop(name, kwargs['default_value']) for name, kwargs in declared.items()
    }
    assert not arguments, f'undeclared {sorted(arguments)}'
    for name, value in values.items():
        assert value in (declared[name]['choices'] or [value]), (name, value)
    return [
        values[item.args[0]] if isinstance(item, api.LaunchConfiguration) else item
        for item in hand_process(entities, api).kwargs['arguments']
    ]


def test_one_hand_nodes_process_of_setup_py_without_remaps(entities, api):
    node = hand_process(entities, api)
    assert node.kwargs['executable'] == 'hand_nodes' in console_scripts()
    assert 'name' not in node.kwargs and 'namespace' not in node.kwargs  # renames every node
    assert 'condition' not in node.kwargs  # estimator:=false is an option of the process


def exit_handler(entities, api):
    """The on_exit of the one exit handler, which must watch the hand's process."""
    (handler,) = [e.args[0] for e in entities if isinstance(e, api.RegisterEventHandler)]
    assert handler.kwargs['target_action'] is hand_process(entities, api)
    return handler.kwargs['on_exit']


@pytest.mark.parametrize(('returncode', 'words'), [(-9, 'SIGKILL'), (1, 'code 1')])
def test_a_failed_hand_process_fails_the_launch(entities, api, returncode, words):
    # launch turns an exception raised in an event handler into a shutdown and return code 1.
    on_exit = exit_handler(entities, api)
    for is_shutdown in (False, True):  # also when it dies while the launch stops
        with pytest.raises(Exception, match=f'hand_nodes-1 .*{words}'):
            on_exit(
                FakeEvent(returncode, 'hand_nodes-1'),
                types.SimpleNamespace(is_shutdown=is_shutdown),
            )


def test_a_clean_exit_of_the_hand_process_ends_the_launch_without_error(entities, api):
    on_exit = exit_handler(entities, api)
    for is_shutdown in (False, True):
        assert (
            on_exit(FakeEvent(0, 'hand_nodes-1'), types.SimpleNamespace(is_shutdown=is_shutdown))
            is None
        )


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
def test_hand_nodes_reads_the_launch_command_line_as_the_same_hand(entities, api, arguments):
    parsed = build_parser().parse_args(command_line(entities, api, **arguments))
    config = hand_config(parsed)
    options = {o.name: o.default for o in command_options('hand_nodes')} | arguments
    assert config.fingers == tuple(options['fingers'].split(','))
    assert config.namespace == options['namespace']
    assert config.mode == options['mode']
    assert config.clock == options['clock']
    assert config.estimator == (options['estimator'] == 'true')
    assert config.time.lockstep == (options['lockstep'] == 'true')
    assert config.time.real_time_factor == float(options['real_time_factor'])
