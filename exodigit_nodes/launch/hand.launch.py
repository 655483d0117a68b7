"""Launch a simulated hand: every finger's plant, estimator and pressure_command in two processes.

    ros2 launch exodigit_nodes hand.launch.py
    ros2 launch exodigit_nodes hand.launch.py fingers:=index,middle namespace:=/left
    ros2 launch exodigit_nodes hand.launch.py clock:=sim lockstep:=true real_time_factor:=0.0

Starts the ``hand_nodes`` executable twice, as the venv runner does: ``--part gloves`` (every
plant and controller, and the hand's simulated time) and ``--part estimators`` (unless
``estimator:=false``); finger f in ``<namespace>/<f>`` with joint prefix ``f_`` and its model
``config/hand/<f>.yaml`` (README, "A whole hand"). The launch arguments are the
options of ``hand_nodes --help``, with their choices and defaults, from one table
(``exodigit_nodes.nodes.hand_config.command_options``) that the venv runner ``python -m
exodigit_nodes.hand`` reads too. When either process exits the launch ends, and fails (exit 1)
if that process failed.
"""

from exodigit_nodes.logic.lifetime import exit_status
from exodigit_nodes.nodes.hand_config import command_options
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, RegisterEventHandler, Shutdown
from launch.conditions import IfCondition
from launch.event_handlers import OnProcessExit
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


class HandProcessError(RuntimeError):
    """A process of the hand ended with a non-zero code or by a signal: the launch fails."""


def end_the_hand(event, context):
    """On a process's exit, end the launch; fail it (raise) if the process failed."""
    if event.returncode != 0:
        raise HandProcessError(f'{event.process_name} {exit_status(event.returncode)}')
    if context.is_shutdown:
        return None
    return Shutdown(reason=f'{event.process_name} exited')


def hand_process(command: list, part: str, **options):
    """The ``hand_nodes --part <part>`` process of the hand, with the hand's ``command``."""
    return Node(
        package='exodigit_nodes',
        executable='hand_nodes',
        output='screen',
        emulate_tty=True,
        arguments=[*command, '--part', part],
        **options,
    )


def generate_launch_description():
    """The hand's arguments, its two processes and their exit handlers."""
    options = command_options('hand_nodes')
    arguments = [
        DeclareLaunchArgument(
            option.name,
            default_value=option.default,
            choices=list(option.choices) or None,
            description=option.help,
        )
        for option in options
    ]
    # No node name or namespace remap here: they would rename every node of the process.
    command = []
    for option in options:
        command += [option.flag, LaunchConfiguration(option.name)]
    gloves = hand_process(command, 'gloves')
    estimators = hand_process(
        command, 'estimators', condition=IfCondition(LaunchConfiguration('estimator'))
    )
    handlers = [
        RegisterEventHandler(OnProcessExit(target_action=process, on_exit=end_the_hand))
        for process in (gloves, estimators)
    ]
    return LaunchDescription([*arguments, *handlers, gloves, estimators])
