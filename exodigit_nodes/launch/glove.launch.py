"""Launch the simulated glove: plant, pressure_command and estimator in one namespace.

    ros2 launch exodigit_nodes glove.launch.py
    ros2 launch exodigit_nodes glove.launch.py namespace:=/left/index mode:=staircase
    ros2 launch exodigit_nodes glove.launch.py params_file:=/path/to/my_glove.yaml
    ros2 launch exodigit_nodes glove.launch.py clock:=sim lockstep:=true real_time_factor:=0.0
    ros2 launch exodigit_nodes glove.launch.py actuation:=valves
    ros2 launch exodigit_nodes glove.launch.py hardware:=emulated
    ros2 launch exodigit_nodes glove.launch.py hardware:=/dev/ttyACM0 mode:=hold

Each node reads its defaults from its ``config/<executable>.yaml`` in the package share
directory; the launch arguments below override them. The nodes, the modes and the arguments'
defaults come from the node table, ``exodigit_nodes.nodes.catalog`` (the installed package), from
which those config files are generated. Simulated time (docs/spec/ros.md Part II) is what
``python -m exodigit_nodes.glove --clock sim --real-time-factor X --lockstep`` sets: the plant
owns /clock (``clock``, ``real_time_factor``, ``lockstep``), the other nodes run with
``use_sim_time`` and pressure_command answers each joint_states in lockstep. ``actuation:=valves``
is ``--actuation valves``: the plant's chambers driven by valves (``valve_command``) and
pressure_command's ``output`` valves (docs/spec/ros.md, "Valves"). ``hardware:=emulated`` or
``hardware:=<port>`` is ``--hardware``: the ``hardware`` bridge in the plant's place, with valves,
on ``mcu_emulator`` (its pty at ``board_link``) or on the board at that serial port; leave
``clock`` at wall (docs/hardware.md).

Like that runner, the glove is one unit: when any of its nodes (or the emulated board) exits,
launch stops the others and ends; ``ros2 launch`` then exits 1 if that node failed (non-zero
code, or killed by a signal) and 0 after a clean exit or Ctrl-C. Without a ROS install,
``python -m exodigit_nodes.glove`` starts the same nodes (docs/running.md).
"""

import os
import sys

from ament_index_python.packages import get_package_share_directory
from exodigit_nodes.logic.lifetime import exit_status
from exodigit_nodes.nodes.catalog import (
    ESTIMATOR_NODE,
    HARDWARE_NODE,
    PLANT_NODE,
    PRESSURE_COMMAND_NODE,
)
from exodigit_nodes.nodes.hand_config import EMULATED
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, RegisterEventHandler, Shutdown
from launch.conditions import IfCondition, UnlessCondition
from launch.event_handlers import OnProcessExit
from launch.substitutions import (
    AndSubstitution,
    EqualsSubstitution,
    IfElseSubstitution,
    LaunchConfiguration,
    NotEqualsSubstitution,
    OrSubstitution,
)
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

PACKAGE = 'exodigit_nodes'
BOOLEANS = ['true', 'false']
PLANT = PLANT_NODE.table
COMMAND = PRESSURE_COMMAND_NODE.table


class GloveNodeError(RuntimeError):
    """A glove node ended with a non-zero code or by a signal: the launch fails."""


class ClockIsSim(EqualsSubstitution):
    """'true' when the launch argument ``clock`` is sim, else 'false' (use_sim_time's default)."""

    def __init__(self):
        super().__init__(LaunchConfiguration('clock'), 'sim')

    def describe(self):
        """What ``ros2 launch --show-args`` prints as the default."""
        return "'true' if clock is sim, else 'false'"


def argument_text(value) -> str:
    """A parameter default as a launch argument's default: ``'true'``, ``'1.0'``, ``'sine'``."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def end_the_glove(event, context):
    """On any node's exit, end the whole launch; fail it if the node failed.

    ``Shutdown`` alone makes ``ros2 launch`` exit 0 whatever the node's code. An exception raised
    while launch handles an event makes it shut everything down and return 1 (LaunchService
    .run_async), so a failed node is reported by raising. A node that stops cleanly because the
    launch is already ending (Ctrl-C) changes nothing.
    """
    if event.returncode != 0:
        raise GloveNodeError(
            f'{event.process_name} {exit_status(event.returncode)}: stopping the glove'
        )
    if context.is_shutdown:
        return None
    return Shutdown(reason=f'{event.process_name} exited: stopping the glove')


def launch_arguments() -> list[DeclareLaunchArgument]:
    """The glove's launch arguments, with the node table's defaults and choices."""
    return [
        DeclareLaunchArgument(
            'namespace',
            default_value='/glove',
            description='ROS namespace of this glove; one namespace per glove or finger',
        ),
        DeclareLaunchArgument(
            'mode',
            default_value=COMMAND['mode'].default,
            choices=list(COMMAND['mode'].choices),
            description=COMMAND['mode'].description,
        ),
        DeclareLaunchArgument(
            'actuation',
            default_value=PLANT['actuation'].default,
            choices=list(PLANT['actuation'].choices),
            description=PLANT['actuation'].description
            + '; with valves pressure_command publishes valve_command (output valves)',
        ),
        DeclareLaunchArgument(
            'hardware',
            default_value='',
            description=f"run the glove on a board, the hardware bridge in the plant's place: "
            f'{EMULATED} (mcu_emulator at board_link) or the serial port of a board '
            '(/dev/ttyACM0), with valves, on the wall clock; empty = the simulated plant',
        ),
        DeclareLaunchArgument(
            'board_link',
            default_value='/tmp/exodigit_board',
            description=f"hardware {EMULATED}: where the emulated board's pseudo-terminal "
            'appears (a symbolic link; one per glove)',
        ),
        DeclareLaunchArgument(
            'params_file',
            default_value=PLANT['params_file'].default,
            description='model parameter YAML (docs/spec/model.md §10) for plant, estimator and '
            'pressure_command; empty = built-in defaults',
        ),
        DeclareLaunchArgument(
            'joint_prefix',
            default_value=PLANT['joint_prefix'].default,
            description='prefix of the joint names in joint_states (<prefix>mcp, <prefix>pip, '
            '<prefix>dip)',
        ),
        DeclareLaunchArgument(
            'clock',
            default_value=PLANT['clock'].default,
            choices=list(PLANT['clock'].choices),
            description='time source: wall (system clock) or sim (the plant owns simulated '
            'time and publishes /clock; the other nodes follow it)',
        ),
        DeclareLaunchArgument(
            'real_time_factor',
            default_value=argument_text(PLANT['real_time_factor'].default),
            description='clock sim: simulated seconds per wall second, >= 0 (0 = as fast as '
            'possible); settable at run time on the plant',
        ),
        DeclareLaunchArgument(
            'lockstep',
            default_value=argument_text(PLANT['lockstep'].default),
            choices=BOOLEANS,
            description='clock sim: one step in flight; the plant waits for pressure_command '
            'to answer each joint_states, and pressure_command answers each one',
        ),
        DeclareLaunchArgument(
            'use_sim_time',
            default_value=ClockIsSim(),
            choices=BOOLEANS,
            description='estimator and pressure_command (and with clock wall the plant) use '
            '/clock for every stamp and timer; default true when clock is sim, else false',
        ),
    ]


def glove_nodes(config_dir: str) -> list:
    """The glove's processes, configured by the launch arguments.

    The plant, or with ``hardware`` the bridge (and ``mcu_emulator`` for an emulated board),
    then the estimator and pressure_command.
    """
    namespace = LaunchConfiguration('namespace')
    hardware = LaunchConfiguration('hardware')
    simulated = EqualsSubstitution(hardware, '')
    emulated = EqualsSubstitution(hardware, EMULATED)
    board_link = LaunchConfiguration('board_link')
    clock = LaunchConfiguration('clock')
    use_sim_time = LaunchConfiguration('use_sim_time')
    params_file = ParameterValue(LaunchConfiguration('params_file'), value_type=str)
    joint_prefix = ParameterValue(LaunchConfiguration('joint_prefix'), value_type=str)
    mode = ParameterValue(LaunchConfiguration('mode'), value_type=str)
    actuation = LaunchConfiguration('actuation')
    # pressure_command publishes what the plant takes: valve_command for valves (a board's)
    output = IfElseSubstitution(
        OrSubstitution(
            EqualsSubstitution(actuation, 'valves'), NotEqualsSubstitution(hardware, '')
        ),
        if_value='valves',
        else_value='pressure',
    )
    real_time_factor = ParameterValue(LaunchConfiguration('real_time_factor'), value_type=float)
    lockstep = ParameterValue(LaunchConfiguration('lockstep'), value_type=bool)
    node_sim_time = ParameterValue(use_sim_time, value_type=bool)
    # With clock sim the plant is the time source: its stamps are its steps, and its
    # diagnostics and markers stay on the wall clock, which goes on while simulated time is
    # paused or waits for a lockstep answer (as with python -m exodigit_nodes.glove). With clock
    # wall, use_sim_time makes it follow somebody else's /clock, as it makes every node.
    plant_sim_time = ParameterValue(
        AndSubstitution(use_sim_time, NotEqualsSubstitution(clock, 'sim')), value_type=bool
    )

    def glove_node(entry, overrides, condition=None):
        return Node(
            package=PACKAGE,
            executable=entry.executable,
            name=entry.executable,
            namespace=namespace,
            output='screen',
            emulate_tty=True,
            parameters=[os.path.join(config_dir, entry.config_file), overrides],
            condition=condition,
        )

    return [
        ExecuteProcess(
            name='mcu_emulator',
            cmd=[
                *(sys.executable, '-m', 'exodigit_nodes.hardware.emulator'),
                *('--link', board_link),
                # one word, so that an empty params_file (the built-in model) is a value too
                ['--params-file=', LaunchConfiguration('params_file')],
            ],
            output='screen',
            condition=IfCondition(emulated),
        ),
        glove_node(
            HARDWARE_NODE,
            {
                'use_sim_time': node_sim_time,
                'joint_prefix': joint_prefix,
                'port': ParameterValue(
                    IfElseSubstitution(emulated, if_value=board_link, else_value=hardware),
                    value_type=str,
                ),
            },
            UnlessCondition(simulated),
        ),
        glove_node(
            PLANT_NODE,
            {
                'use_sim_time': plant_sim_time,
                'params_file': params_file,
                'joint_prefix': joint_prefix,
                'actuation': ParameterValue(actuation, value_type=str),
                'clock': ParameterValue(clock, value_type=str),
                'real_time_factor': real_time_factor,
                'lockstep': lockstep,
            },
            IfCondition(simulated),
        ),
        glove_node(
            ESTIMATOR_NODE,
            {
                'use_sim_time': node_sim_time,
                'params_file': params_file,
                'glove_node': ParameterValue(
                    IfElseSubstitution(
                        simulated,
                        if_value=PLANT_NODE.executable,
                        else_value=HARDWARE_NODE.executable,
                    ),
                    value_type=str,
                ),
            },
        ),
        glove_node(
            PRESSURE_COMMAND_NODE,
            {
                'use_sim_time': node_sim_time,
                'params_file': params_file,
                'mode': mode,
                'output': ParameterValue(output, value_type=str),
                'lockstep': lockstep,
            },
        ),
    ]


def generate_launch_description():
    """The glove's nodes, the arguments that configure them, and the exit handlers."""
    nodes = glove_nodes(os.path.join(get_package_share_directory(PACKAGE), 'config'))
    # Registered before the nodes start, so that each node's own exit handlers (which flush its
    # last output) come first: a raising handler ends the handling of that event.
    exit_handlers = [
        RegisterEventHandler(OnProcessExit(target_action=node, on_exit=end_the_glove))
        for node in nodes
    ]
    return LaunchDescription(launch_arguments() + exit_handlers + nodes)
