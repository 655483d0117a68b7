"""Launch the simulated glove: plant, pressure_command and estimator in one namespace.

    ros2 launch exodigit_nodes glove.launch.py
    ros2 launch exodigit_nodes glove.launch.py namespace:=/left/index mode:=staircase
    ros2 launch exodigit_nodes glove.launch.py params_file:=/path/to/my_glove.yaml

Each node reads its defaults from its ``config/*.yaml`` in the package share directory; the
launch arguments below override them. Without a ROS install, ``python -m exodigit_nodes.glove``
starts the same three nodes (README, "Running the glove").
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

PACKAGE = 'exodigit_nodes'
MODES = ['sine', 'staircase', 'hold', 'position', 'force']


def generate_launch_description():
    """The glove's three nodes and the arguments that configure them."""
    config_dir = os.path.join(get_package_share_directory(PACKAGE), 'config')
    namespace = LaunchConfiguration('namespace')
    use_sim_time = ParameterValue(LaunchConfiguration('use_sim_time'), value_type=bool)
    params_file = ParameterValue(LaunchConfiguration('params_file'), value_type=str)
    joint_prefix = ParameterValue(LaunchConfiguration('joint_prefix'), value_type=str)
    mode = ParameterValue(LaunchConfiguration('mode'), value_type=str)

    arguments = [
        DeclareLaunchArgument(
            'namespace',
            default_value='/glove',
            description='ROS namespace of this glove; one namespace per glove or finger',
        ),
        DeclareLaunchArgument(
            'mode',
            default_value='sine',
            choices=MODES,
            description='pressure_command mode: sine (continuous passive motion), staircase '
            '(10 kPa steps), hold, position (joint targets), force (contact-force targets)',
        ),
        DeclareLaunchArgument(
            'params_file',
            default_value='',
            description='model parameter YAML (MODEL.md section 10) for plant, estimator and '
            'pressure_command; empty = built-in defaults',
        ),
        DeclareLaunchArgument(
            'joint_prefix',
            default_value='',
            description='prefix of the joint names in joint_states (<prefix>mcp, <prefix>pip, '
            '<prefix>dip)',
        ),
        DeclareLaunchArgument(
            'use_sim_time',
            default_value='false',
            choices=['true', 'false'],
            description='use /clock (simulated time) for every stamp and timer',
        ),
    ]

    def glove_node(executable, config_file, overrides):
        return Node(
            package=PACKAGE,
            executable=executable,
            name=executable,
            namespace=namespace,
            output='screen',
            emulate_tty=True,
            parameters=[
                os.path.join(config_dir, config_file),
                {'use_sim_time': use_sim_time, **overrides},
            ],
        )

    nodes = [
        glove_node(
            'plant', 'plant.yaml', {'params_file': params_file, 'joint_prefix': joint_prefix}
        ),
        glove_node('estimator', 'estimator.yaml', {'params_file': params_file}),
        glove_node(
            'pressure_command', 'pressure_command.yaml', {'params_file': params_file, 'mode': mode}
        ),
    ]
    return LaunchDescription(arguments + nodes)
