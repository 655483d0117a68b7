"""Launch a simulated hand: every finger's plant, estimator and pressure_command in one process.

    ros2 launch exodigit_nodes hand.launch.py
    ros2 launch exodigit_nodes hand.launch.py fingers:=index,middle namespace:=/left
    ros2 launch exodigit_nodes hand.launch.py clock:=sim lockstep:=true real_time_factor:=0.0

Starts the ``hand_nodes`` executable once, as the venv runner does (``estimator:=false`` leaves
the estimators out); finger f in ``<namespace>/<f>`` with joint prefix ``f_`` and its model
``config/hand/<f>.yaml`` (docs/running.md, "A whole hand"). The launch arguments are the
options of ``hand_nodes --help``, with their choices and defaults, from one table
(``exodigit_nodes.nodes.hand_config.command_options``) that the venv runner ``python -m
exodigit_nodes.hand`` reads too. When the process exits the launch ends, and fails (exit 1) if
the process failed.
"""

from exodigit_nodes.logic.lifetime import exit_status
from exodigit_nodes.nodes.hand_config import command_options
from exodigit_nodes.nodes.run_options import flag
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, RegisterEventHandler
from launch.event_handlers import OnProcessExit
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


class HandProcessError(RuntimeError):
    """The hand's process ended with a non-zero code or by a signal: the launch fails."""


def fail_the_hand(event, context):
    """On the process's exit, fail the launch (raise) if the process failed.

    ``ros2 launch`` ends with its one process either way, but exits 0 whatever the process's
    code; an exception raised while it handles an event makes it return 1.
    """
    if event.returncode != 0:
        raise HandProcessError(f'{event.process_name} {exit_status(event.returncode)}')


def generate_launch_description():
    """The hand's arguments, its process and the process's exit handler."""
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
        command += [flag(option.name), LaunchConfiguration(option.name)]
    hand = Node(
        package='exodigit_nodes',
        executable='hand_nodes',
        output='screen',
        emulate_tty=True,
        arguments=command,
    )
    handler = RegisterEventHandler(OnProcessExit(target_action=hand, on_exit=fail_the_hand))
    return LaunchDescription([*arguments, handler, hand])
