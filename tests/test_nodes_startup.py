"""A node refuses a bad configuration at start: non-zero exit, one clear line, no traceback."""

import pytest

NODES = ('plant', 'pressure_command', 'estimator')
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


@pytest.mark.parametrize('node', NODES)
@pytest.mark.parametrize('label', list(BAD_FILES))
def test_a_bad_params_file_stops_the_node_with_one_clear_line(launcher, bad_files, node, label):
    code, lines = refused(launcher, node, {'params_file': bad_files[label]})
    assert code not in (0, None)
    assert len(lines) == 1, lines
    assert lines[0].startswith(f'{node}: error: params_file: ')
    assert bad_files[label] in lines[0]


@pytest.mark.parametrize(
    ('node', 'parameters', 'named'),
    [
        ('plant', {'rate_hz': -5.0}, 'rate_hz'),
        ('plant', {'command_timeout': 'soon'}, 'command_timeout'),
        ('pressure_command', {'mode': 'wiggle'}, 'mode'),
        ('pressure_command', {'sine_low': 30e3, 'sine_high': 10e3}, 'sine_low'),
        ('estimator', {'identification_window': 1}, 'identification_window'),
    ],
)
def test_a_bad_parameter_at_start_stops_the_node_naming_it(launcher, node, parameters, named):
    code, lines = refused(launcher, node, parameters)
    assert code not in (0, None)
    assert len(lines) == 1 and named in lines[0], lines
