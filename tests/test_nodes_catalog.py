"""The node table (exodigit_nodes.nodes.catalog) is the one source of the nodes, modes and
defaults: the parameters say their units; setup.py's console scripts, the venv runner and the
config YAML (which docs/parameters.md shows) agree with it (the launch file:
test_packaging_launch.py; each node module's --help prints its entry's table:
test_nodes_units.py; the interface specification names every parameter)."""

import ast
import re
from pathlib import Path

import pytest
import yaml
from exodigit_model.control import MODES
from exodigit_nodes.glove import GLOVE
from exodigit_nodes.logic.parameters import ParamSpec
from exodigit_nodes.nodes.catalog import EXECUTABLES, NODES
from exodigit_nodes.nodes.config_files import CONFIG_WIDTH, config_text
from exodigit_nodes.nodes.config_files import main as write_config_main
from exodigit_nodes.runner import hand_runner

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIR = ROOT / 'exodigit_nodes'
CONFIG = PACKAGE_DIR / 'config'
PARAMETER_PAGE = ROOT / 'docs' / 'parameters.md'
REGENERATE = 'python -m exodigit_nodes.nodes.config_files --write-config exodigit_nodes/config'
by_executable = pytest.mark.parametrize('node', NODES, ids=lambda node: node.executable)
with_config = pytest.mark.parametrize('node', EXECUTABLES, ids=lambda node: node.executable)
ROS_PARAMETERS = ('use_sim_time',)
"""Parameters rclpy declares on every node (not in the table)."""
SI_UNIT = re.compile(
    r'.*?, (samples|(?:1/\(?)?(?:Hz|Pa|rad|N|m|s)(?:[·/(]+(?:Hz|Pa|rad|N|m|s)\)?)*)(?: \(.*\))?'
)
"""A number's description: '<meaning>, <SI unit>' (a gain's may be one over a unit, 1/Pa), then
perhaps one remark in parentheses."""
DIMENSIONLESS = {
    'seed': 'the seed of a random generator',
    'real_time_factor': 'simulated seconds per wall second',
}
"""Numbers without a unit, each with why."""


@by_executable
def test_every_number_states_its_si_unit(node):
    numbers = [
        spec
        for spec in node.table.specs.values()
        if type(spec.default) in (int, float, tuple) and spec.name not in DIMENSIONLESS
    ]
    assert numbers
    missing = [
        f'{s.name}: {s.description!r}' for s in numbers if not SI_UNIT.fullmatch(s.description)
    ]
    assert missing == [], f'{node.executable}: no ", <SI unit>" in {missing}'


def test_every_dimensionless_number_is_a_parameter():
    names = {name for node in NODES for name in node.table.specs}
    assert set(DIMENSIONLESS) <= names, 'DIMENSIONLESS names a parameter no node has'


def console_scripts() -> dict[str, str]:
    """setup.py's console_scripts as {executable: 'module:function'} ({PACKAGE} filled in)."""
    tree = ast.parse((PACKAGE_DIR / 'setup.py').read_text())
    package = next(
        node.value.value
        for node in tree.body
        if isinstance(node, ast.Assign) and node.targets[0].id == 'PACKAGE'
    )
    (call,) = (n for n in ast.walk(tree) if isinstance(n, ast.Call) and n.func.id == 'setup')
    points = next(k.value for k in call.keywords if k.arg == 'entry_points')
    groups = dict(zip([ast.literal_eval(k) for k in points.keys], points.values, strict=True))
    scripts = {}
    for entry in groups['console_scripts'].elts:
        parts = entry.values if isinstance(entry, ast.JoinedStr) else [entry]
        text = ''.join(p.value if isinstance(p, ast.Constant) else package for p in parts)
        name, target = (side.strip() for side in text.split('='))
        scripts[name] = target
    return scripts


@by_executable
def test_setup_py_installs_each_node_as_a_console_script_of_its_module(node):
    assert console_scripts()[node.executable] == f'exodigit_nodes.console:{node.executable}'


def test_a_rule_given_by_position_is_refused():
    # Only name, default and description are positional: ParamSpec('x', '', 'd', True) would
    # otherwise have made x's low bound True.
    with pytest.raises(TypeError):
        ParamSpec('lockstep', False, 'one step in flight', True)
    with pytest.raises(TypeError):
        ParamSpec('rate_hz', 100.0, 'rate, Hz', 1.0, 1000.0)
    spec = ParamSpec('rate_hz', 100.0, 'rate, Hz', low=1.0, high=1000.0, read_only=True)
    assert spec.rule() == '[1 .. 1000] (read-only)'


# -- the runner (python -m exodigit_nodes.glove) -----------------------------------------------


def session_of(arguments: list[str], run_dir):
    """The glove runner's session for these command-line arguments (started: nothing)."""
    options = hand_runner.build_parser(GLOVE).parse_args(arguments)
    session = hand_runner.session(hand_runner.run_config(GLOVE, options), run_dir)
    for glove in session.gloves:
        glove.record.close()
    return session


def overrides(command: list[str]) -> dict:
    """The ``-p name:=value`` of a node's command line, each value read as YAML (as ROS does)."""
    given = [command[i + 1] for i, word in enumerate(command) if word == '-p']
    return {name: yaml.safe_load(value) for name, value in (p.split(':=', 1) for p in given)}


def test_the_runner_starts_the_plant_first_and_stops_the_command_node_first(tmp_path):
    # The commands need the plant; stopped first they vent the chambers while the plant still
    # runs. The recorder starts before any node and stops after them, missing nothing.
    session = session_of(['--record'], tmp_path)
    started = [name for name, _ in session.processes]
    assert sorted(started) == sorted(['recorder', *(node.executable for node in NODES)])
    assert started[0] == 'recorder' and started[1] == 'plant'
    assert session.stop_order[0] == 'pressure_command' and session.stop_order[-1] == 'recorder'
    assert sorted(session.stop_order) == sorted(started)


@pytest.mark.parametrize('mode', list(MODES))
@pytest.mark.parametrize(
    'clock',
    [[], ['--clock', 'sim', '--lockstep', '--real-time-factor', '0', '--duration', '5']],
    ids=['wall', 'sim lockstep'],
)
def test_the_runner_sets_only_declared_parameters_to_values_they_accept(mode, clock, tmp_path):
    glove = tmp_path / 'my glove.yaml'  # every node loads it (the plant with the patient)
    glove.write_text('{}\n')
    session = session_of(['--mode', mode, '--params-file', str(glove), *clock], tmp_path)
    commands = dict(session.processes)
    for node in NODES:
        command = commands[node.executable]
        assert command[1:3] == ['-m', node.module]
        ours = {k: v for k, v in overrides(command).items() if k not in ROS_PARAMETERS}
        assert ours, node.executable
        checked = node.table.check(ours)  # ValueError: an unknown name or a refused value
        assert str(glove) in checked['params_file'], node.executable
    assert overrides(commands['pressure_command'])['mode'] == mode


# -- config YAML -------------------------------------------------------------------------------


def test_the_config_directory_holds_one_parameter_file_per_node():
    assert sorted(p.name for p in CONFIG.glob('*.yaml')) == sorted(
        n.config_file for n in EXECUTABLES
    )


@with_config
def test_each_config_file_is_generated_from_the_table(node):
    committed = (CONFIG / node.config_file).read_text()
    assert committed == config_text(node), f'{node.config_file} is stale: run {REGENERATE}'


@with_config
def test_each_config_file_is_a_ros_parameter_file_of_every_parameter_at_its_default(node):
    document = yaml.safe_load((CONFIG / node.config_file).read_text())
    assert list(document) == ['/**']
    assert list(document['/**']) == ['ros__parameters']
    values = document['/**']['ros__parameters']
    assert list(values) == list(node.table.specs)
    # a parameter with no default (the hardware bridge's port) is left empty, for the user
    given = [name for name, spec in node.table.specs.items() if spec.required and not spec.default]
    assert all(values.pop(name) == '' for name in given)
    specs = node.table.specs
    assert node.table.check(values) == {
        name: specs[name].check(specs[name].default) for name in values
    }
    for name, value in values.items():  # the YAML type is the declared type (no 1 for 1.0)
        default = node.table[name].default
        assert type(value) is (list if isinstance(default, tuple) else type(default)), name


@with_config
def test_each_parameter_is_preceded_by_a_comment_with_its_description(node):
    lines = config_text(node).splitlines()
    for name, spec in node.table.specs.items():
        (row,) = (i for i, line in enumerate(lines) if line.startswith(f'    {name}: '))
        above = []
        for line in reversed(lines[:row]):
            if not line.startswith('    # '):
                break
            above.insert(0, line.removeprefix('    # ').strip())
        assert ' '.join(above) == f'{spec.description} {spec.rule()}'.strip(), name
        assert all(len(line) <= CONFIG_WIDTH for line in lines[:row])


def test_write_config_writes_every_nodes_file(tmp_path):
    assert write_config_main(['--write-config', str(tmp_path)]) == 0
    for node in EXECUTABLES:
        assert (tmp_path / node.config_file).read_text() == config_text(node)
    with pytest.raises(SystemExit) as refused:
        write_config_main(['--write-config', str(tmp_path / 'missing')])
    assert refused.value.code == 2


# -- docs/parameters.md ------------------------------------------------------------------------


def test_the_parameter_page_shows_each_nodes_generated_file_and_no_other():
    # The page shows the committed config files (checked against the table above), so that a
    # node added to the table without a section on the page fails here.
    page = PARAMETER_PAGE.read_text()
    included = re.findall(r'^```\{literalinclude\} \.\./exodigit_nodes/(\S+)$', page, re.MULTILINE)
    assert sorted(included) == sorted(f'config/{node.config_file}' for node in EXECUTABLES)


@pytest.mark.parametrize('node', NODES, ids=lambda node: node.executable)
def test_the_interface_specification_names_every_parameter_of_each_node(node):
    # docs/spec/ros.md lists each node's parameters by name (their defaults live in the table).
    spec = (ROOT / 'docs' / 'spec' / 'ros.md').read_text()
    section = spec[spec.index('## Parameters\n') : spec.index('## QoS')]
    entry = section[section.index(f'- `{node.executable}`: ') :].split('\n- `')[0]
    named = set(re.findall(r'`(\w+)`', entry))
    assert sorted(set(node.table.specs) - named) == []
