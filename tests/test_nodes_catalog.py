"""The node table (exodigit_nodes.catalog) is the one source of the nodes, modes and defaults: the
node classes, setup.py's console scripts, the venv runner, the config YAML and the README's
parameter blocks agree with it (the launch file: test_packaging_launch.py)."""

import ast
import re
from pathlib import Path

import pytest
import yaml
from exodigit_nodes.catalog import (
    CONFIG_WIDTH,
    NODES,
    PLANT_NODE,
    PRESSURE_COMMAND_NODE,
    config_text,
)
from exodigit_nodes.catalog import main as write_config_main
from exodigit_nodes.controllers import MODES
from exodigit_nodes.glove import build_parser
from exodigit_nodes.parameters import ParamSpec

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIR = ROOT / 'exodigit_nodes'
CONFIG = PACKAGE_DIR / 'config'
README = ROOT / 'README.md'
README_SECTION = '## Nodes, topics and parameters'
REGENERATE = 'python -m exodigit_nodes.catalog --write-config exodigit_nodes/config'
by_executable = pytest.mark.parametrize('node', NODES, ids=lambda node: node.executable)


def test_the_glove_is_its_three_nodes_plant_first_commands_last():
    assert [node.executable for node in NODES] == ['plant', 'estimator', 'pressure_command']


@by_executable
def test_each_entry_names_the_node_class_that_declares_its_table(node):
    node_class = node.node_class()
    assert node_class.__module__ == node.module
    assert node_class.executable == node.executable
    assert node_class.table is node.table


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
    assert console_scripts()[node.executable] == node.entry_point


def test_the_modes_are_the_controllers_and_the_runner_offers_them_at_the_nodes_default():
    mode = PRESSURE_COMMAND_NODE.table['mode']
    assert mode.choices == tuple(MODES)
    assert mode.default in MODES
    for name in MODES:
        assert name in mode.description
    defaults = build_parser().parse_args([])
    assert defaults.mode == mode.default
    assert defaults.clock == PLANT_NODE.table['clock'].default
    assert defaults.real_time_factor == PLANT_NODE.table['real_time_factor'].default
    (option,) = (a for a in build_parser()._actions if a.dest == 'mode')
    assert tuple(option.choices) == tuple(MODES)


def test_a_rule_given_by_position_is_refused():
    # Only name, default and description are positional: ParamSpec('x', '', 'd', True) would
    # otherwise have made x's low bound True.
    with pytest.raises(TypeError):
        ParamSpec('lockstep', False, 'one step in flight', True)
    with pytest.raises(TypeError):
        ParamSpec('rate_hz', 100.0, 'rate, Hz', 1.0, 1000.0)
    spec = ParamSpec('rate_hz', 100.0, 'rate, Hz', low=1.0, high=1000.0, read_only=True)
    assert spec.rule() == '[1 .. 1000] (read-only)'


# -- config YAML -------------------------------------------------------------------------------


def test_the_config_directory_holds_one_parameter_file_per_node():
    assert sorted(p.name for p in CONFIG.glob('*.yaml')) == sorted(n.config_file for n in NODES)


@by_executable
def test_each_config_file_is_generated_from_the_table(node):
    committed = (CONFIG / node.config_file).read_text()
    assert committed == config_text(node), f'{node.config_file} is stale: run {REGENERATE}'


@by_executable
def test_each_config_file_is_a_ros_parameter_file_of_every_parameter_at_its_default(node):
    document = yaml.safe_load((CONFIG / node.config_file).read_text())
    assert list(document) == ['/**']
    assert list(document['/**']) == ['ros__parameters']
    values = document['/**']['ros__parameters']
    assert list(values) == list(node.table.specs)
    assert node.table.check(values) == node.table.defaults()
    for name, value in values.items():  # the YAML type is the declared type (no 1 for 1.0)
        default = node.table[name].default
        assert type(value) is (list if isinstance(default, tuple) else type(default)), name


@by_executable
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
    for node in NODES:
        assert (tmp_path / node.config_file).read_text() == config_text(node)
    with pytest.raises(SystemExit) as refused:
        write_config_main(['--write-config', str(tmp_path / 'missing')])
    assert refused.value.code == 2


# -- README ------------------------------------------------------------------------------------


def readme_parameter_blocks() -> dict[str, str]:
    """The code blocks of the README's node section, by the paragraph before each.

    A block belongs to the node named first in that paragraph: ```plant```, ```pressure_command```
    (modes: ...).
    """
    text = README.read_text()
    start = text.index(f'\n{README_SECTION}\n')
    lines = text[start : text.index('\n## ', start + 1)].splitlines()
    blocks, paragraph, block = {}, '', None
    for previous, line in zip(['', *lines], lines, strict=False):
        if block is not None:
            if line == '```':
                name = re.match(r'`(\w+)`', paragraph)
                assert name and name[1] not in blocks, f'a block after: {paragraph}'
                blocks[name[1]], block = '\n'.join(block) + '\n', None
            else:
                block.append(line)
        elif line == '```':
            block = []
        elif not previous.strip():
            paragraph = line
    return blocks


def test_the_readme_has_a_parameter_block_for_each_node_and_no_other():
    assert sorted(readme_parameter_blocks()) == sorted(node.executable for node in NODES)


@by_executable
def test_each_readme_parameter_block_is_the_nodes_help(node):
    block = readme_parameter_blocks()[node.executable]
    assert block == node.table.help() + '\n', (
        f'README, "{README_SECTION[3:]}": paste the parameters of '
        f'python -m {node.module} --help into the {node.executable} block'
    )
