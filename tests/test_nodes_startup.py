"""A node refuses a bad configuration at start: non-zero exit, one clear line, no traceback.

Every node reads its ``params_file`` through ``node_base.load_model``: each kind of bad file is
checked there, without a process. Each node class is built in this process with a bad file and
with a bad parameter, and must refuse with a ``ConfigurationError`` naming it. How a refusal
leaves a process (``process.serve``: status 2, that one line on stderr, no traceback, nothing
else rclpy might print) is the same for every node: two processes check it, one per kind.
"""

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from exodigit_nodes.nodes.catalog import NODES
from exodigit_nodes.nodes.node_base import ConfigurationError, load_model
from exodigit_nodes.testing.processes import ros_environment

BAD_FILES = {
    'missing': None,
    'bad value': 'material:\n  c1: -5.0\n',
    'broken yaml': 'material: [\n',
    'unknown key': 'finger:\n  joints:\n    - {name: mcp, stifness: 0.04}\n',
}
CLASSES = {node.executable: node.node_class() for node in NODES}


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


def refusal_in_process(probe, node: str, parameters: dict[str, str]) -> str:
    """The ConfigurationError text of node class ``node`` built here with ``parameters``.

    Built in the probe's context (no second DDS participant); a node that refuses is destroyed
    at once, and one that does not fails the test.
    """

    class Refusing(CLASSES[node]):
        def __init__(self, **options):
            try:
                super().__init__(**options)
            except ConfigurationError:
                self.destroy_node()
                raise
            self.destroy_node()

    args = ['--ros-args', '-r', '__ns:=/startup_in_process']
    args += [flag for name, value in parameters.items() for flag in ('-p', f'{name}:={value}')]
    with pytest.raises(ConfigurationError) as refusal:
        Refusing(
            context=probe.context,
            cli_args=args,
            start_parameter_services=False,
            enable_rosout=False,
        )
    message = str(refusal.value)
    assert '\n' not in message
    return message


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
def test_each_node_refuses_a_bad_params_file_naming_it(probe, bad_files, node, label):
    message = refusal_in_process(probe, node, {'params_file': bad_files[label]})
    assert message.startswith('params_file: ') and bad_files[label] in message


@pytest.mark.parametrize(
    ('node', 'parameters', 'named'),
    [
        ('plant', {'command_timeout': 'soon'}, 'command_timeout'),  # rclpy's type check
        ('plant', {'lockstep': 'true'}, 'lockstep needs clock sim'),  # a rule
        ('pressure_command', {'sine_low': '30000.0', 'sine_high': '10000.0'}, 'sine_low'),
        ('pressure_command', {'staircase_step': '60000.0'}, 'must not exceed staircase_peak'),
        ('estimator', {'identification_window': '1'}, 'identification_window'),  # a bound
    ],
)
def test_each_node_refuses_a_bad_parameter_at_start_naming_it(probe, node, parameters, named):
    assert named in refusal_in_process(probe, node, parameters)


def test_a_bad_params_file_stops_the_process_with_one_clear_line(launcher, bad_files):
    code, lines = refused(launcher, 'estimator', {'params_file': bad_files['unknown key']})
    assert code == 2
    assert len(lines) == 1, lines
    assert lines[0].startswith('estimator: error: params_file: ')
    assert bad_files['unknown key'] in lines[0]


def test_a_bad_parameter_stops_the_process_with_one_clear_line(launcher):
    code, lines = refused(launcher, 'plant', {'lockstep': True})
    assert code == 2
    assert len(lines) == 1, lines
    assert lines[0].startswith('plant: error: ') and 'lockstep needs clock sim' in lines[0]


@pytest.mark.parametrize('delay', [0.15, 0.5])
def test_ctrl_c_while_the_console_script_starts_ends_it_without_a_traceback(
    ros_domain, tmp_path, delay
):
    # What ros2 launch does to the other nodes when one refuses its configuration: SIGINT while
    # the plant still imports rclpy and the model (over a second here), where Python's default
    # handler used to print a KeyboardInterrupt traceback. The console script, as installed.
    script = Path(sys.executable).with_name('plant')
    env = ros_environment(ros_domain)
    process = subprocess.Popen(
        [str(script), '--ros-args', '-r', '__ns:=/startup_interrupted'],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=tmp_path,
    )
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=30.0)
    assert 'Traceback' not in stderr + stdout, stderr
    assert process.returncode == 0, stderr


def test_ctrl_c_during_an_imports_finaliser_still_ends_the_start_up(tmp_path):
    # Python's KeyboardInterrupt raised inside a finaliser (imports collect garbage) is only
    # reported as ignored: the program went on starting with the Ctrl-C lost. A console
    # script's own handler ends the start-up there, whatever code runs.
    (tmp_path / 'finalised_probe.py').write_text(
        textwrap.dedent(
            """
            import os, signal, time

            class Finaliser:
                def __del__(self):
                    os.kill(os.getpid(), signal.SIGINT)
                    time.sleep(2.0)  # the handler runs here, inside the finaliser

            Finaliser()  # collected at once

            def main():
                print('main ran')
                return 7
            """
        )
    )
    code = (
        'import sys; from exodigit_nodes.console import program; '
        "sys.exit(program('probe', 'finalised_probe')())"
    )
    done = subprocess.run(
        [sys.executable, '-c', code],
        capture_output=True,
        text=True,
        timeout=30.0,
        cwd=tmp_path,
        env={**os.environ, 'PYTHONPATH': str(tmp_path)},
    )
    assert (done.returncode, done.stdout) == (0, ''), done.stderr
    assert done.stderr.strip() == 'probe: stopped while starting'
