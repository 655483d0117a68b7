"""The launch file: it compiles, names the package's executables and existing config files, and
evaluated against recording stand-ins of the launch API it declares every argument it uses, passes
the simulated-time arguments to the nodes the venv runner passes them to, takes its modes and
defaults from the node table, and ends the whole launch when any node exits (failing it when the
node failed)."""

import ast
import fnmatch
import py_compile
import runpy
import sys
import types
from pathlib import Path

import pytest
import yaml
from exodigit_model.control import MODES
from exodigit_nodes.glove import GLOVE
from exodigit_nodes.nodes.catalog import NODES
from exodigit_nodes.nodes.run_options import TIME_OPTIONS
from exodigit_nodes.runner import hand_runner

PACKAGE_DIR = Path(__file__).resolve().parents[1] / 'exodigit_nodes'
LAUNCH_FILE = PACKAGE_DIR / 'launch' / 'glove.launch.py'
NODE_EXECUTABLES = {'plant', 'pressure_command', 'estimator'}
LAUNCHED = NODE_EXECUTABLES | {'hardware'}
"""Every node executable the launch file names (the bridge in the plant's place on a board)."""
SIM_TIME_ARGUMENTS = {'clock', 'real_time_factor', 'lockstep', 'use_sim_time'}
RUNNER_ONLY = {'start_paused'}
"""Plant parameters the runner sets for its live summary, not the launch file."""


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


def test_launch_file_compiles(tmp_path):
    py_compile.compile(str(LAUNCH_FILE), cfile=str(tmp_path / 'launch.pyc'), doraise=True)


def test_launch_file_starts_the_node_executables_of_setup_py(entities, launch_api):
    scripts = console_scripts()
    assert scripts >= LAUNCHED
    assert set(nodes_by_executable(entities, launch_api)) == LAUNCHED


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


LAUNCH_API = {
    'launch': ['LaunchDescription'],
    'launch.actions': [
        'DeclareLaunchArgument',
        'ExecuteProcess',
        'RegisterEventHandler',
        'Shutdown',
    ],
    'launch.conditions': ['IfCondition', 'UnlessCondition'],
    'launch.event_handlers': ['OnProcessExit'],
    'launch.substitutions': [
        'AndSubstitution',
        'EqualsSubstitution',
        'IfElseSubstitution',
        'LaunchConfiguration',
        'NotEqualsSubstitution',
        'OrSubstitution',
    ],
    'launch_ros': [],
    'launch_ros.actions': ['Node'],
    'launch_ros.parameter_descriptions': ['ParameterValue'],
}


@pytest.fixture
def launch_api(monkeypatch):
    """Minimal recording replacements for launch, launch_ros and ament_index_python."""
    classes = {}
    for module_name, names in LAUNCH_API.items():
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
    return types.SimpleNamespace(**classes)


@pytest.fixture
def launch_file(launch_api):
    """The launch file's module globals, run against the stand-ins."""
    return runpy.run_path(str(LAUNCH_FILE))


@pytest.fixture
def entities(launch_file, launch_api):
    """The entities of the launch description, in order."""
    description = launch_file['generate_launch_description']()
    assert isinstance(description, launch_api.LaunchDescription)
    return description.args[0]


def of_kind(entities, kind) -> list:
    return [e for e in entities if isinstance(e, kind)]


def declared_arguments(entities, api) -> dict[str, dict]:
    return {e.args[0]: e.kwargs for e in of_kind(entities, api.DeclareLaunchArgument)}


def nodes_by_executable(entities, api) -> dict[str, Recorded]:
    return {n.kwargs['executable']: n for n in of_kind(entities, api.Node)}


def used_configurations(value, api):
    """Names of every LaunchConfiguration inside a (nested) stand-in value."""
    if isinstance(value, api.LaunchConfiguration):
        yield value.args[0]
    elif isinstance(value, Recorded):
        for item in list(value.args) + list(value.kwargs.values()):
            yield from used_configurations(item, api)
    elif isinstance(value, list | tuple):
        for item in value:
            yield from used_configurations(item, api)
    elif isinstance(value, dict):
        for item in value.values():
            yield from used_configurations(item, api)


def truth(text: str) -> bool:
    assert text in ('true', 'false'), text
    return text == 'true'


def resolve(value, configurations: dict[str, str], api):
    """What launch makes of a stand-in substitution or parameter value (the subset used)."""
    if isinstance(value, str):
        return value
    if isinstance(value, list | tuple):
        return ''.join(resolve(item, configurations, api) for item in value)
    if isinstance(value, api.LaunchConfiguration):
        return configurations[value.args[0]]
    if isinstance(value, api.EqualsSubstitution | api.NotEqualsSubstitution):
        left, right = (resolve(side, configurations, api) for side in value.args)
        equal = left == right
        return str(equal if isinstance(value, api.EqualsSubstitution) else not equal).lower()
    if isinstance(value, api.AndSubstitution | api.OrSubstitution):
        left, right = (truth(resolve(side, configurations, api)) for side in value.args)
        both = isinstance(value, api.AndSubstitution)
        return str(left and right if both else left or right).lower()
    if isinstance(value, api.IfElseSubstitution):
        condition = truth(resolve(value.args[0], configurations, api))
        return resolve(
            value.kwargs['if_value' if condition else 'else_value'], configurations, api
        )
    if isinstance(value, api.ParameterValue):
        text = resolve(value.args[0], configurations, api)
        kind = value.kwargs['value_type']
        return truth(text) if kind is bool else kind(text)
    raise AssertionError(f'no stand-in evaluation for {value!r}')


def configurations_of(entities, api, **arguments) -> dict[str, str]:
    """Every launch argument's value for the launch arguments ``arguments`` (name:=value)."""
    configurations = {}
    for name, kwargs in declared_arguments(entities, api).items():
        value = arguments.pop(name, None)
        if value is None:
            value = resolve(kwargs['default_value'], configurations, api)
        assert value in kwargs.get('choices', [value]), (name, value)
        configurations[name] = value
    assert not arguments, f'undeclared arguments {sorted(arguments)}'
    return configurations


def started(action, configurations, api) -> bool:
    """Whether launch starts ``action`` (its condition holds, or it has none)."""
    condition = action.kwargs.get('condition')
    if condition is None:
        return True
    holds = truth(resolve(condition.args[0], configurations, api))
    return holds if isinstance(condition, api.IfCondition) else not holds


def node_parameters(entities, api, **arguments) -> dict[str, dict]:
    """The parameter overrides of each node started for the launch arguments ``arguments``."""
    configurations = configurations_of(entities, api, **arguments)
    result = {}
    for executable, node in nodes_by_executable(entities, api).items():
        if not started(node, configurations, api):
            continue
        overrides = {}
        for item in node.kwargs['parameters']:
            if isinstance(item, dict):
                overrides.update({k: resolve(v, configurations, api) for k, v in item.items()})
        result[executable] = overrides
    return result


def test_launch_description_declares_every_argument_it_uses(entities, launch_api):
    declared = declared_arguments(entities, launch_api)
    assert set(declared) >= {'namespace', 'mode', 'params_file', 'joint_prefix'}
    assert set(declared) >= SIM_TIME_ARGUMENTS
    order = list(declared)
    for name, kwargs in declared.items():
        assert kwargs.get('description', '').strip(), f'argument {name} has no description'
        assert 'default_value' in kwargs, f'argument {name} has no default'
        for used in used_configurations(kwargs['default_value'], launch_api):
            assert order.index(used) < order.index(name), f'{name} defaults to a later {used}'

    nodes = of_kind(entities, launch_api.Node)
    assert {n.kwargs['executable'] for n in nodes} == LAUNCHED
    for node in nodes:
        assert set(used_configurations(node, launch_api)) <= set(declared)
        files = [p for p in node.kwargs['parameters'] if isinstance(p, str)]
        assert files, f'{node.kwargs["executable"]} loads no config file'
        for path in files:
            assert Path(path).is_file(), f'{path} does not exist'
            assert Path(path).parent == PACKAGE_DIR / 'config'
    assert declared['mode']['choices'] == list(MODES)
    assert declared['mode']['default_value'] == 'sine'


def test_each_node_loads_its_config_file_and_the_arguments_default_to_its_table(
    entities, launch_api
):
    # Launched without arguments, every node runs at its table's defaults: the overrides the
    # launch file adds to each node's config file change nothing.
    nodes = nodes_by_executable(entities, launch_api)
    parameters = node_parameters(entities, launch_api)
    for entry in NODES:
        files = [p for p in nodes[entry.executable].kwargs['parameters'] if isinstance(p, str)]
        assert files == [str(PACKAGE_DIR / 'config' / entry.config_file)], entry.executable
        ours = {k: v for k, v in parameters[entry.executable].items() if k != 'use_sim_time'}
        assert ours, entry.executable
        assert entry.table.check(ours) == {k: entry.table.defaults()[k] for k in ours}


def test_sim_time_arguments_have_the_documented_defaults_and_choices(entities, launch_api):
    declared = declared_arguments(entities, launch_api)
    assert declared['clock']['choices'] == ['wall', 'sim']
    assert declared['clock']['default_value'] == 'wall'
    assert float(declared['real_time_factor']['default_value']) == 1.0
    for name in ('lockstep', 'use_sim_time'):
        assert sorted(declared[name]['choices']) == ['false', 'true'], name
    assert declared['lockstep']['default_value'] == 'false'
    for clock, expected in (('wall', 'false'), ('sim', 'true')):
        default = resolve(declared['use_sim_time']['default_value'], {'clock': clock}, launch_api)
        assert default == expected, f'use_sim_time defaults to {default} with clock {clock}'


def test_by_default_every_node_runs_on_the_wall_clock(entities, launch_api):
    parameters = node_parameters(entities, launch_api)
    for executable, overrides in parameters.items():
        assert overrides['use_sim_time'] is False, executable
    assert parameters['plant']['clock'] == 'wall'
    assert parameters['plant']['lockstep'] is False
    assert parameters['plant']['real_time_factor'] == 1.0
    assert parameters['pressure_command']['lockstep'] is False


def runner_overrides(arguments: list[str], emulator_link: str = '') -> dict[str, dict]:
    """The ``-p`` values ``python -m exodigit_nodes.glove <arguments>`` gives each node process,
    read as YAML (as ROS reads them)."""
    options = hand_runner.build_parser(GLOVE).parse_args(arguments)
    config = hand_runner.run_config(GLOVE, options)
    processes = hand_runner.node_processes(config, emulator_link)
    result = {}
    for executable, command in processes.items():
        given = [command[i + 1] for i, word in enumerate(command) if word == '-p']
        result[executable] = {
            name: yaml.safe_load(value) for name, value in (p.split(':=', 1) for p in given)
        }
    return result


def test_clock_sim_reaches_the_nodes_the_runner_gives_it_to(entities, launch_api):
    """The same simulated-time values as ``python -m exodigit_nodes.glove --clock sim
    --real-time-factor 0 --lockstep`` gives its node processes, but the pause its summary starts
    with; what the launch does not set, the node's config file gives at its table's default."""
    launched = node_parameters(
        entities, launch_api, clock='sim', lockstep='true', real_time_factor='0.0'
    )
    given = runner_overrides(['--clock', 'sim', '--real-time-factor', '0', '--lockstep'])
    assert set(given) == NODE_EXECUTABLES
    time_names = (SIM_TIME_ARGUMENTS | set(TIME_OPTIONS)) - RUNNER_ONLY
    tables = {entry.executable: entry.table for entry in NODES}
    for executable in NODE_EXECUTABLES:
        runner = {k: v for k, v in given[executable].items() if k in time_names}
        runner.setdefault('use_sim_time', False)  # the plant owns /clock
        assert runner['use_sim_time'] is (executable != 'plant')
        for name, value in runner.items():
            if name in launched[executable]:
                assert launched[executable][name] == value, (executable, name)
            else:
                assert tables[executable][name].default == value, (executable, name)
        for name in SIM_TIME_ARGUMENTS - {'use_sim_time'} - set(runner):
            assert name not in launched[executable], (executable, name)


def test_use_sim_time_can_be_set_apart_from_clock(entities, launch_api):
    # clock wall, use_sim_time true: every node follows somebody else's /clock (a bag, a sim).
    parameters = node_parameters(entities, launch_api, use_sim_time='true')
    assert {name: p['use_sim_time'] for name, p in parameters.items()} == dict.fromkeys(
        NODE_EXECUTABLES, True
    )
    parameters = node_parameters(entities, launch_api, clock='sim', use_sim_time='false')
    assert parameters['plant']['clock'] == 'sim'
    assert not any(p['use_sim_time'] for p in parameters.values())


def exit_handlers(entities, api) -> dict[int, Recorded]:
    """OnProcessExit handlers registered by the description, by id of their target action."""
    handlers = {}
    for register in of_kind(entities, api.RegisterEventHandler):
        (handler,) = register.args or (register.kwargs['event_handler'],)
        if isinstance(handler, api.OnProcessExit):
            target = handler.kwargs['target_action']
            assert id(target) not in handlers, 'two exit handlers for one node'
            handlers[id(target)] = handler
    return handlers


def test_every_node_has_an_exit_handler_registered_before_it_starts(entities, launch_api):
    handlers = exit_handlers(entities, launch_api)
    nodes = of_kind(entities, launch_api.Node) + of_kind(entities, launch_api.ExecuteProcess)
    assert set(handlers) == {id(node) for node in nodes}
    registered = [entities.index(e) for e in of_kind(entities, launch_api.RegisterEventHandler)]
    # A raising handler ends launch's handling of that event, so the node's own exit handlers
    # (registered when it starts, in front of earlier ones) must come first.
    assert max(registered) < min(entities.index(node) for node in nodes)
    for handler in handlers.values():
        assert callable(handler.kwargs['on_exit'])


class FakeEvent:
    """The parts of launch.events.process.ProcessExited the handler reads."""

    def __init__(self, returncode: int, process_name: str = 'plant-1'):
        self.returncode = returncode
        self.process_name = process_name


@pytest.mark.parametrize(
    ('returncode', 'words'),
    [(-9, 'SIGKILL'), (-15, 'SIGTERM'), (2, 'code 2'), (1, 'code 1')],
)
def test_a_failed_node_fails_the_launch(entities, launch_api, returncode, words):
    # launch turns an exception raised in an event handler into a shutdown and return code 1.
    for handler in exit_handlers(entities, launch_api).values():
        for is_shutdown in (False, True):  # also when it dies while the launch stops
            context = types.SimpleNamespace(is_shutdown=is_shutdown)
            with pytest.raises(Exception) as raised:
                handler.kwargs['on_exit'](FakeEvent(returncode, 'estimator-2'), context)
            assert 'estimator-2' in str(raised.value)
            assert words in str(raised.value)


def test_a_clean_exit_ends_the_launch_with_code_0(entities, launch_api):
    for handler in exit_handlers(entities, launch_api).values():
        on_exit = handler.kwargs['on_exit']
        action = on_exit(FakeEvent(0), types.SimpleNamespace(is_shutdown=False))
        actions = action if isinstance(action, list | tuple) else [action]
        assert any(isinstance(a, launch_api.Shutdown) for a in actions)
        # Ctrl-C: launch is already stopping every node; nothing more to do.
        assert on_exit(FakeEvent(0), types.SimpleNamespace(is_shutdown=True)) is None


def test_actuation_valves_reaches_the_plant_and_pressure_command_as_the_runner_gives_it(
    entities, launch_api
):
    """``actuation:=valves`` is ``--actuation valves``: the plant takes valve_command and
    pressure_command publishes it (output valves); by default neither changes."""
    launched = node_parameters(entities, launch_api, actuation='valves')
    given = runner_overrides(['--actuation', 'valves'])
    assert launched['plant']['actuation'] == given['plant']['actuation'] == 'valves'
    assert launched['pressure_command']['output'] == given['pressure_command']['output']
    assert given['pressure_command']['output'] == 'valves'
    default = node_parameters(entities, launch_api)
    assert default['plant']['actuation'] == 'regulator'
    assert default['pressure_command']['output'] == 'pressure'
    assert 'actuation' not in runner_overrides([])['plant']


@pytest.mark.parametrize('hardware', ['emulated', '/dev/ttyACM0'])
def test_hardware_puts_the_bridge_in_the_plants_place_as_the_runner_does(
    entities, launch_api, hardware
):
    """``hardware:=`` is ``--hardware``: the bridge on the board's port (or the emulator's
    link), no plant, the estimator on the bridge, pressure_command with output valves, and
    mcu_emulator for an emulated board only."""
    link = '/tmp/board_of_this_test'
    launched = node_parameters(entities, launch_api, hardware=hardware, board_link=link)
    given = runner_overrides(['--hardware', hardware], emulator_link=link)
    assert set(launched) == set(given) == LAUNCHED - {'plant'}
    port = link if hardware == 'emulated' else hardware
    assert launched['hardware']['port'] == given['hardware']['port'] == port
    for executable, name, value in (
        ('estimator', 'glove_node', 'hardware'),
        ('pressure_command', 'output', 'valves'),
    ):
        assert launched[executable][name] == given[executable][name] == value
    configurations = configurations_of(entities, launch_api, hardware=hardware, board_link=link)
    (emulator,) = of_kind(entities, launch_api.ExecuteProcess)
    assert started(emulator, configurations, launch_api) is (hardware == 'emulated')
    command = [resolve(word, configurations, launch_api) for word in emulator.kwargs['cmd']]
    assert command[-3:] == ['--link', link, '--params-file=']  # the built-in model
    assert set(node_parameters(entities, launch_api)) == NODE_EXECUTABLES  # by default no board
