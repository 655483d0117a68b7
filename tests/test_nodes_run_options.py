"""One table of runner options and one set of checks for the glove and the hand (no ROS)."""

import pytest
from exodigit_nodes.logic.options import UsageError
from exodigit_nodes.logic.pacing import TimeSettings
from exodigit_nodes.nodes.catalog import PLANT_NODE
from exodigit_nodes.nodes.hand_config import TIME_PARAMETERS, hand_config
from exodigit_nodes.nodes.run_options import (
    check_sim_only,
    time_parameters,
    time_settings,
)

from exodigit_nodes import glove, hand


def parsed(command, *arguments):
    return command.build_parser().parse_args(list(arguments))


@pytest.mark.parametrize('command', [glove, hand])
def test_both_commands_take_the_plants_time_options_with_its_defaults(command):
    options = parsed(command)
    assert options.clock == PLANT_NODE.table['clock'].default
    assert float(options.real_time_factor) == PLANT_NODE.table['real_time_factor'].default
    assert options.lockstep == 'false'
    assert parsed(command, '--lockstep').lockstep == 'true'  # a switch alone means true
    assert parsed(command, '--lockstep', 'false').lockstep == 'false'


def test_the_glove_reads_its_switches_into_booleans():
    options = parsed(glove, '--clock', 'sim', '--lockstep', 'false', '--record', 'false')
    glove.check_arguments(options)
    assert options.lockstep is False and options.record is False
    options = parsed(glove, '--clock', 'sim', '--lockstep', '--record', '--real-time-factor', '0')
    glove.check_arguments(options)
    assert options.lockstep is True and options.record is True
    assert options.real_time_factor == 0.0


@pytest.mark.parametrize(
    ('names', 'message'),
    [
        (glove.TIME_OPTIONS, '--lockstep and --real-time-factor need --clock sim'),
        (TIME_PARAMETERS, '--lockstep, --start-paused and --real-time-factor need --clock sim'),
        (('lockstep',), '--lockstep needs --clock sim'),
    ],
)
def test_simulated_time_options_on_the_wall_clock_are_refused_naming_the_commands_own(
    names, message
):
    with pytest.raises(UsageError) as refused:
        check_sim_only('wall', TimeSettings(lockstep=True), names)
    assert str(refused.value) == message
    check_sim_only('sim', TimeSettings(lockstep=True), names)  # with sim time: fine
    check_sim_only('wall', TimeSettings(lockstep_timeout=3.0, pause_at=2.0), names)  # harmless


@pytest.mark.parametrize(
    ('values', 'message'),
    [
        ({'real_time_factor': '-2'}, '--real-time-factor -2: real_time_factor must lie in'),
        ({'real_time_factor': 'fast'}, '--real-time-factor fast: '),
        ({'pause_at': '-1'}, '--pause-at -1: '),
    ],
)
def test_time_values_get_the_plants_checks_naming_the_option(values, message):
    with pytest.raises(UsageError, match=f'^{message}'):
        time_settings(values)


def test_time_values_read_as_the_plant_reads_them():
    settings = time_settings({'real_time_factor': '0', 'lockstep': 'true'})
    assert settings == TimeSettings(real_time_factor=0.0, lockstep=True)


@pytest.mark.parametrize('command', [glove, hand])
def test_both_commands_check_the_namespace_alike(command):
    with pytest.raises(UsageError, match="--namespace 'x': must be absolute"):
        if command is glove:
            glove.check_arguments(parsed(glove, '--namespace', 'x'))
        else:
            hand_config(parsed(hand, '--namespace', 'x'))


def test_a_glove_and_a_finger_get_the_same_simulated_time_parameters():
    time = TimeSettings(real_time_factor=0.0, lockstep=True)
    finger = hand_config(
        parsed(
            hand, '--clock', 'sim', '--lockstep', '--real-time-factor', '0', '--fingers', 'ring'
        )
    )
    for executable in ('plant', 'estimator', 'pressure_command'):
        given = finger.parameters(executable, 'ring')
        shared = time_parameters(executable, 'sim', time, glove.TIME_OPTIONS)
        assert {name: given[name] for name in shared} == shared
    # the plant gets only the settings named, and nothing of them on the wall clock
    assert time_parameters('plant', 'sim', time, ('lockstep',)) == {
        'clock': 'sim',
        'lockstep': True,
    }
    assert time_parameters('plant', 'wall', time, TIME_PARAMETERS) == {'clock': 'wall'}
    assert time_parameters('pressure_command', 'wall', time, TIME_PARAMETERS) == {
        'use_sim_time': False,
        'lockstep': False,
    }
