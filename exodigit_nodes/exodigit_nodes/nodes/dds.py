"""The Fast DDS profile every exodigit process uses (docs/spec/ros.md, "QoS").

``fastdds.xml`` beside this module shortens the participants' announcements from 3 s to 250 ms
(how soon two processes that start at once find each other) and the writers' heartbeat from 3 s
to 50 ms (how soon a reader gets a sample it missed), and lets a service server wait 1 s, not
100 ms, for a new client's reader. rmw_fastrtps reads it when a process creates its first
participant, so every process names it before ``rclpy.init``, unless the user named a profile of
their own. A user's own node gets it with::

    export FASTRTPS_DEFAULT_PROFILES_FILE=$(python3 -m exodigit_nodes.nodes.dds)
"""

import os
from collections.abc import Mapping
from pathlib import Path

#: The profile shipped inside the package.
PROFILE = Path(__file__).with_name('fastdds.xml')
#: The variable rmw_fastrtps reads (Fast DDS 2.x, as in ROS 2 Jazzy).
PROFILE_VARIABLE = 'FASTRTPS_DEFAULT_PROFILES_FILE'


def with_profile(environ: Mapping[str, str]) -> dict[str, str]:
    """A copy of ``environ`` naming the exodigit profile, unless it already names one."""
    env = dict(environ)
    if not env.get(PROFILE_VARIABLE):
        env[PROFILE_VARIABLE] = str(PROFILE)
    return env


def use_profile() -> None:
    """Name the exodigit profile in this process's environment (call before ``rclpy.init``)."""
    os.environ[PROFILE_VARIABLE] = with_profile(os.environ)[PROFILE_VARIABLE]


if __name__ == '__main__':
    print(PROFILE)
