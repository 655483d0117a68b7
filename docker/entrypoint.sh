#!/usr/bin/env bash
# Source the ROS install and the exodigit overlay, then run the given command (ros2 launch ...).
set -e
source "/opt/ros/${ROS_DISTRO}/setup.bash"
source "${WORKSPACE}/install/setup.bash"
exec "$@"
