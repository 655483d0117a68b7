"""The one runner's configuration (exodigit_nodes.runner.hand_runner), built without ROS.

The glove is the hand of one finger with no finger level: what it starts, where its nodes live,
which model they load and where its record goes are read here from the :class:`Session` the
runner would run, beside a hand's; nothing is started. The runs themselves:
test_glove_run.py and test_hand_run.py.
"""

import argparse
from dataclasses import replace

import pytest
import yaml
from exodigit_nodes.glove import GLOVE
from exodigit_nodes.hand import HAND
from exodigit_nodes.logic.options import NOMINAL_PATIENT, UsageError
from exodigit_nodes.nodes.catalog import NODES
from exodigit_nodes.nodes.hand_config import (
    DEFAULT_PATIENTS,
    HandConfig,
    command_options,
    hand_config,
    hand_config_dir,
)
from exodigit_nodes.nodes.run_options import add_options
from exodigit_nodes.runner import hand_runner

from exodigit_model import patient_file

EXECUTABLES = tuple(entry.executable for entry in NODES)


def configured(command, *arguments):
    options = hand_runner.build_parser(command).parse_args(list(arguments))
    return hand_runner.run_config(command, options)


@pytest.fixture
def session_of(tmp_path):
    """The session a command would run for its arguments (records closed: nothing runs)."""
    sessions = []

    def build(command, *arguments):
        session = hand_runner.session(configured(command, *arguments), tmp_path / 'run')
        sessions.append(session)
        return session

    yield build
    for session in sessions:
        for glove in session.gloves:
            glove.record.close()


def overrides(command: list[str]) -> dict:
    """The ``-p name:=value`` of a command line, read as YAML (as ROS reads them)."""
    given = [command[i + 1] for i, word in enumerate(command) if word == '-p']
    return {name: yaml.safe_load(value) for name, value in (p.split(':=', 1) for p in given)}


def namespace_of(command: list[str]) -> str:
    return command[command.index('-r') + 1].removeprefix('__ns:=')


# -- where the gloves are ---------------------------------------------------------------------


def test_the_glove_is_one_glove_with_no_finger_level(tmp_path):
    model = tmp_path / 'my glove.yaml'
    model.write_text('{}\n')
    (glove,) = configured(GLOVE, '--params-file', str(model)).hand.gloves()
    assert glove.finger == '' and glove.namespace == '/glove' and glove.joint_prefix == ''
    assert glove.model_files == (str(model),)
    assert glove.plant_files == (str(model), str(patient_file(DEFAULT_PATIENTS['glove'])))


def test_a_hand_has_a_glove_per_finger_in_its_namespace_on_the_fingers_own_model():
    gloves = configured(HAND, '--fingers', 'ring,thumb', '--namespace', '/left').hand.gloves()
    assert [(g.finger, g.namespace, g.joint_prefix) for g in gloves] == [
        ('ring', '/left/ring', 'ring_'),
        ('thumb', '/left/thumb', 'thumb_'),
    ]
    for glove in gloves:
        assert glove.model_files == (str(hand_config_dir() / f'{glove.finger}.yaml'),)
        assert glove.plant_files == glove.model_files  # the hand's default: the nominal finger


def test_the_default_patients_are_the_documented_ones():
    assert configured(GLOVE).hand.patient == 'stroke_moderate'
    assert configured(HAND).hand.patient == NOMINAL_PATIENT


def test_each_node_gets_its_gloves_model_prefix_and_the_hands_mode():
    config = configured(HAND, '--fingers', 'index', '--patient', 'stroke_mild', '--mode', 'hold')
    hand = config.hand
    (glove,) = hand.gloves()
    assert hand.parameters('plant', glove)['params_file'] == list(glove.plant_files)
    assert hand.parameters('plant', glove)['joint_prefix'] == 'index_'
    for executable in ('estimator', 'pressure_command'):
        assert hand.parameters(executable, glove)['params_file'] == list(glove.model_files)
    assert hand.parameters('pressure_command', glove)['mode'] == 'hold'
    # a lone glove on the built-in model and nominal finger: no model file, no prefix
    (lone,) = replace(hand, fingers=(), patient=NOMINAL_PATIENT).gloves()
    for executable in EXECUTABLES:
        given = replace(hand, fingers=()).parameters(executable, lone)
        assert 'params_file' not in given and 'joint_prefix' not in given, executable


@pytest.mark.parametrize('command', [GLOVE, HAND])
def test_simulated_time_starts_paused_and_is_held_at_the_duration(command, session_of):
    # held by the session's Horizon: its run_until never passes the duration (test_nodes_horizon)
    assert configured(command, '--clock', 'sim', '--duration', '7').hand.time.start_paused
    session = session_of(command, '--clock', 'sim', '--duration', '7')
    assert session.simulated and session.duration == 7.0
    assert not configured(command, '--duration', '7').hand.time.start_paused  # nothing to hold
    assert not session_of(command, '--duration', '7').simulated


# -- the processes ------------------------------------------------------------------------------


def test_the_glove_runs_each_node_as_its_own_process_and_stops_the_command_node_first(session_of):
    session = session_of(GLOVE, '--namespace', '/left/index')
    commands = dict(session.processes)
    assert list(commands) == list(EXECUTABLES)  # the plant first
    for entry in NODES:
        assert commands[entry.executable][1:3] == ['-m', entry.module]
        assert namespace_of(commands[entry.executable]) == '/left/index'
        assert session.runs[entry.executable] == (entry.executable,)
    assert session.stop_order == ('pressure_command', 'estimator', 'plant')
    assert session.pause_service == '/left/index/set_paused'


@pytest.mark.parametrize('estimator', ['true', 'false'])
def test_a_hand_runs_its_fingers_in_one_hand_nodes_process(session_of, tmp_path, estimator):
    arguments = ('--fingers', 'index,ring', '--estimator', estimator)
    ros_params = tmp_path / 'fast.yaml'
    ros_params.write_text('/**:\n  ros__parameters:\n    rate_hz: 200.0\n')
    session = session_of(HAND, *arguments, '--ros-params', str(ros_params))
    ((name, command),) = session.processes
    assert name == 'hand_nodes' and session.stop_order == ('hand_nodes',)
    assert command[1:3] == ['-m', 'exodigit_nodes.nodes.hand_nodes']
    nodes = EXECUTABLES if estimator == 'true' else ('plant', 'pressure_command')
    assert session.runs == {'hand_nodes': nodes} and session.nodes == nodes
    # hand_nodes reads its command line back as this hand (its own parser, from the one table)
    ros_args = command.index('--ros-args')
    assert command[ros_args:] == ['--ros-args', '--params-file', str(ros_params)]
    parser = argparse.ArgumentParser()
    add_options(parser, command_options('hand_nodes'))
    read = parser.parse_args(command[3:ros_args])
    assert hand_config(read) == configured(HAND, *arguments).hand
    assert session.pause_service == '/hand/set_paused'


def test_each_record_is_its_gloves_the_lone_gloves_at_the_top_of_the_run(session_of, tmp_path):
    (lone,) = session_of(GLOVE).gloves
    assert lone.record.csv_path == tmp_path / 'run' / 'signals.csv'
    assert lone.title == 'exodigit glove /glove (sine)'
    gloves = session_of(HAND, '--fingers', 'middle,thumb', '--clock', 'sim', '--lockstep').gloves
    assert [g.record.csv_path for g in gloves] == [
        tmp_path / 'run' / finger / 'signals.csv' for finger in ('middle', 'thumb')
    ]
    assert gloves[0].title == 'exodigit hand /hand/middle (sine, simulated time, lockstep)'


@pytest.mark.parametrize(
    ('command', 'arguments', 'namespace', 'gloves', 'estimators'),
    [
        (GLOVE, [], '/glove', [], ('/glove/estimator',)),
        (
            HAND,
            ['--fingers', 'index,ring'],
            '/hand',
            ['--gloves', 'index,ring'],
            ('/hand/index/estimator', '/hand/ring/estimator'),
        ),
    ],
)
def test_record_adds_one_recorder_of_every_glove_first_to_start_last_to_stop(
    session_of, tmp_path, command, arguments, namespace, gloves, estimators
):
    session = session_of(command, *arguments, '--record', '--clock', 'sim')
    (name, recorder), *nodes = session.processes
    assert name == 'recorder' and session.stop_order[-1] == 'recorder'
    assert 'recorder' not in dict(nodes)
    assert recorder[1:3] == ['-m', 'exodigit_nodes.nodes.recorder']
    assert namespace_of(recorder) == namespace
    # a lone glove's bag at the top of the run, a hand's a bag per finger in it
    options = recorder[3 : recorder.index('--ros-args')]
    nodes = ['--nodes', ','.join(session.nodes)]  # each must match its readers (~/ready)
    assert options == ['--output', str(tmp_path / 'run' / 'bag'), *gloves, *nodes]
    assert set(session.nodes) == {'plant', 'estimator', 'pressure_command'}
    assert overrides(recorder) == {'use_sim_time': True}  # stamps in simulated time
    assert session.runs['recorder'] == ()
    # the plants wait for it and for every estimator (each says so on its ~/ready)
    assert session.listeners == (f'{namespace}/recorder', *estimators)
    assert session_of(command, *arguments).listeners == estimators
    if gloves:  # a hand without estimators waits for none (a lone glove always has one)
        assert session_of(command, *arguments, '--estimator', 'false').listeners == ()


# -- refusals -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('command', 'arguments', 'message'),
    [
        (HAND, ['--fingers', ','], "--fingers ',': give at least one finger"),
        (GLOVE, ['--params-file', 'missing.yaml'], '--params-file: '),
        (GLOVE, ['--patient', 'nobody.yaml'], '--patient: '),
        (HAND, ['--patient', 'nobody.yaml'], '--patient: '),
    ],
)
def test_refusals_name_the_option(tmp_path, monkeypatch, command, arguments, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(UsageError, match=f'^{message}'):
        configured(command, *arguments)


def test_a_model_file_is_the_lone_gloves():
    with pytest.raises(UsageError, match='--params-file'):
        HandConfig(fingers=('index',), params_file='my_glove.yaml')


# -- on a board ---------------------------------------------------------------------------------


def test_an_emulated_board_runs_first_and_stops_last_with_the_bridge_in_the_plants_place(
    session_of, tmp_path
):
    session = session_of(GLOVE, '--hardware', 'emulated')
    commands = dict(session.processes)
    assert list(commands) == ['mcu_emulator', 'hardware', 'estimator', 'pressure_command']
    assert session.stop_order == ('pressure_command', 'estimator', 'hardware', 'mcu_emulator')
    assert session.runs['mcu_emulator'] == () and session.runs['hardware'] == ('hardware',)
    assert session.nodes == ('hardware', 'estimator', 'pressure_command')
    link = str(tmp_path / 'run' / 'board')
    emulator = commands['mcu_emulator']
    assert emulator[1:5] == ['-m', 'exodigit_nodes.hardware.emulator', '--link', link]
    # the emulated board simulates the patient (the glove's default), as the plant would
    assert emulator[5:] == ['--params-file', str(patient_file(DEFAULT_PATIENTS['glove']))]
    assert overrides(commands['hardware']) == {'use_sim_time': False, 'port': link}
    assert overrides(commands['estimator'])['glove_node'] == 'hardware'
    assert overrides(commands['pressure_command'])['output'] == 'valves'
    assert session.streams == ('chamber_pressure', 'joint_states')  # no contact forces
    (glove,) = session.gloves
    assert glove.title == 'exodigit glove /glove (sine, board emulated)'
    assert set(glove.references['estimated_finger_stiffness']) == {'nominal', 'patient'}


def test_a_board_on_a_port_has_no_emulator_and_no_simulated_patient(session_of):
    session = session_of(GLOVE, '--hardware', '/dev/ttyACM0', '--mode', 'hold')
    commands = dict(session.processes)
    assert list(commands) == ['hardware', 'estimator', 'pressure_command']
    assert overrides(commands['hardware'])['port'] == '/dev/ttyACM0'
    (glove,) = session.gloves
    assert set(glove.references['estimated_finger_stiffness']) == {'nominal'}
    assert set(session_of(GLOVE).gloves[0].references['estimated_finger_stiffness']) == {
        'nominal',
        'patient',
    }


@pytest.mark.parametrize('arguments', [['--clock', 'sim'], ['--clock', 'sim', '--lockstep']])
def test_a_board_on_simulated_time_is_refused(arguments):
    with pytest.raises(UsageError, match=r'^--hardware emulated: .*wall clock'):
        configured(GLOVE, '--hardware', 'emulated', *arguments)


def test_a_board_has_valves_and_refuses_a_regulator():
    assert configured(GLOVE).hand.actuation == 'regulator'
    assert configured(GLOVE, '--hardware', 'emulated').hand.actuation == 'valves'
    with pytest.raises(UsageError, match=r'^--hardware emulated: .*--actuation regulator$'):
        configured(GLOVE, '--hardware', 'emulated', '--actuation', 'regulator')


def test_only_the_lone_glove_has_a_board():
    assert 'hardware' in {option.name for option in command_options('glove')}
    for command in ('hand', 'hand_nodes'):
        assert 'hardware' not in {option.name for option in command_options(command)}
    with pytest.raises(UsageError, match='--hardware'):
        HandConfig(fingers=('index',), actuation='valves', hardware='emulated')
