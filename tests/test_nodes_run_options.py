"""One table of runner options and one set of checks for the glove and the hand (no ROS)."""

import pytest
from exodigit_nodes.logic.options import UsageError
from exodigit_nodes.logic.pacing import TimeSettings
from exodigit_nodes.nodes.catalog import PLANT_NODE
from exodigit_nodes.nodes.hand_config import hand_config
from exodigit_nodes.nodes.run_options import (
    TIME_OPTIONS,
    check_sim_only,
    time_parameters,
    time_settings,
)
from exodigit_nodes.runner.hand_runner import run_config

from exodigit_nodes import glove, hand


def parsed(command, *arguments):
    return command.build_parser().parse_args(list(arguments))


def configured(command, *arguments):
    """The run ``python -m exodigit_nodes.<command> <arguments>`` would start."""
    runner = glove.GLOVE if command is glove else hand.HAND
    return run_config(runner, parsed(command, *arguments))


@pytest.mark.parametrize('command', [glove, hand])
def test_both_commands_take_the_plants_time_options_with_its_defaults(command):
    options = parsed(command)
    assert options.clock == PLANT_NODE.table['clock'].default
    assert float(options.real_time_factor) == PLANT_NODE.table['real_time_factor'].default
    assert options.lockstep == 'false'
    assert parsed(command, '--lockstep').lockstep == 'true'  # a switch alone means true
    assert parsed(command, '--lockstep', 'false').lockstep == 'false'


@pytest.mark.parametrize('command', [glove, hand])
def test_both_commands_read_their_switches_into_booleans(command):
    config = configured(command, '--clock', 'sim', '--lockstep', 'false', '--record', 'false')
    assert config.hand.time.lockstep is False and config.record is False
    config = configured(
        command, '--clock', 'sim', '--lockstep', '--record', '--real-time-factor', '0'
    )
    assert config.hand.time.lockstep is True and config.record is True
    assert config.hand.time.real_time_factor == 0.0


@pytest.mark.parametrize(
    ('names', 'message'),
    [
        (('real_time_factor', 'lockstep'), '--lockstep and --real-time-factor need --clock sim'),
        (TIME_OPTIONS, '--lockstep, --start-paused and --real-time-factor need --clock sim'),
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
    check_sim_only('wall', TimeSettings(lockstep_timeout=3.0), names)  # harmless


@pytest.mark.parametrize(
    ('values', 'message'),
    [
        ({'real_time_factor': '-2'}, '--real-time-factor -2: real_time_factor = -2.0: must lie'),
        ({'real_time_factor': 'fast'}, '--real-time-factor fast: '),
        ({'lockstep_timeout': '-1'}, '--lockstep-timeout -1: '),
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
        configured(command, '--namespace', 'x')


def test_a_glove_and_a_finger_get_the_same_simulated_time_parameters():
    time = ('--clock', 'sim', '--lockstep', '--real-time-factor', '0')
    lone = hand_config(parsed(glove, *time))
    finger = hand_config(parsed(hand, *time, '--fingers', 'ring'))
    for executable in ('plant', 'estimator', 'pressure_command'):
        shared = time_parameters(
            executable, 'sim', TimeSettings(real_time_factor=0.0, lockstep=True)
        )
        for config in (lone, finger):
            (one,) = config.gloves()
            given = config.parameters(executable, one)
            assert {name: given[name] for name in shared} == shared, executable
    # nothing of the simulated time on the wall clock
    time = TimeSettings(real_time_factor=0.0, lockstep=True)
    assert time_parameters('plant', 'wall', time) == {'clock': 'wall'}
    assert time_parameters('pressure_command', 'wall', time) == {
        'use_sim_time': False,
        'lockstep': False,
    }
    # the estimator may be behind a lockstep plant: in simulated time that is not staleness
    assert time_parameters('estimator', 'wall', time) == {'use_sim_time': False}
    assert time_parameters('estimator', 'sim', time) == {
        'use_sim_time': True,
        'max_sample_age': 10.0,
    }
