"""A node refuses a bad configuration at start: non-zero exit, one clear line, no traceback.

Every node reads its ``params_file`` through ``node_base.load_model``: each kind of bad file is
checked there, without a process, and each node once as a process (that it exits with one
line). Each node is also started once with a bad parameter.
"""

import pytest
from exodigit_nodes.nodes.node_base import ConfigurationError, load_model

BAD_FILES = {
    'missing': None,
    'bad value': 'material:\n  c1: -5.0\n',
    'broken yaml': 'material: [\n',
    'unknown key': 'finger:\n  joints:\n    - {name: mcp, stifness: 0.04}\n',
}


@pytest.fixture(scope='module')
def bad_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp('params')
    paths = {}
    for label, text in BAD_FILES.items():
        path = folder / f'{label.replace(" ", "_")}.yaml'
        if text is not None:
            path.write_text(text)
        paths[label] = str(path)
    return paths


def refused(launcher, module, parameters):
    code, _, stderr = launcher.run(module, parameters, timeout=30.0)
    lines = [line for line in stderr.splitlines() if line.strip()]
    return code, lines


@pytest.mark.parametrize('label', list(BAD_FILES))
def test_a_bad_params_file_is_one_line_naming_it(bad_files, label):
    with pytest.raises(ConfigurationError) as refusal:
        load_model((bad_files[label],))
    message = str(refusal.value)
    assert message.startswith('params_file: ') and bad_files[label] in message
    assert '\n' not in message


@pytest.mark.parametrize(
    ('node', 'label'),
    [('plant', 'missing'), ('pressure_command', 'broken yaml'), ('estimator', 'unknown key')],
)
def test_a_bad_params_file_stops_the_node_with_one_clear_line(launcher, bad_files, node, label):
    code, lines = refused(launcher, node, {'params_file': bad_files[label]})
    assert code not in (0, None)
    assert len(lines) == 1, lines
    assert lines[0].startswith(f'{node}: error: params_file: ')
    assert bad_files[label] in lines[0]


@pytest.mark.parametrize(
    ('node', 'parameters', 'named'),
    [
        ('plant', {'command_timeout': 'soon'}, 'command_timeout'),  # rclpy's type check
        ('pressure_command', {'sine_low': 30e3, 'sine_high': 10e3}, 'sine_low'),  # a rule
        ('estimator', {'identification_window': 1}, 'identification_window'),  # a bound
    ],
)
def test_a_bad_parameter_at_start_stops_the_node_naming_it(launcher, node, parameters, named):
    code, lines = refused(launcher, node, parameters)
    assert code not in (0, None)
    assert len(lines) == 1 and named in lines[0], lines
