"""The Fast DDS profile every exodigit process uses (docs/spec/ros.md, "QoS").

A reliable reader that misses a sample (a process starved of CPU for a moment, a full
shared-memory port) gets it again only after the writer's next heartbeat, by default 3 s later,
and only if the writer still keeps the sample by then (:data:`.qos.WRITER_DEPTH`). A service
server drops an answer when the new client's reply reader has not matched within 100 ms. The
profile ``fastdds.xml`` beside this module shortens the heartbeat to 50 ms and lets a server
wait 1 s.

rmw_fastrtps reads the file named by ``FASTRTPS_DEFAULT_PROFILES_FILE`` when a process creates
its first participant, so every node's ``main``, the runners, the testing kit and the tests set
it before ``rclpy.init``, unless the user already named a profile of their own. A user's own
node gets it with::

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
    if not os.environ.get(PROFILE_VARIABLE):
        os.environ[PROFILE_VARIABLE] = str(PROFILE)


if __name__ == '__main__':
    print(PROFILE)
