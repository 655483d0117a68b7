"""The Fast DDS profile every exodigit process names (exodigit_nodes/nodes/dds.py)."""

import os
import subprocess
import sys

from exodigit_nodes.nodes.dds import PROFILE, PROFILE_VARIABLE, with_profile
from exodigit_nodes.testing import ros_environment

#: A process that makes a participant, a writer and a reader, so Fast DDS reads its profiles.
PARTICIPANT = """
import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node('profile_check', start_parameter_services=False)
node.create_publisher(String, 'profile_check', 10)
node.create_subscription(String, 'profile_check', lambda message: None, 10)
node.destroy_node()
rclpy.shutdown()
"""


def participant_errors(ros_domain, profile):
    env = ros_environment(ros_domain)
    env[PROFILE_VARIABLE] = str(profile)
    result = subprocess.run(
        [sys.executable, '-c', PARTICIPANT], env=env, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    output = result.stdout + result.stderr  # Fast DDS logs its errors on stdout
    return [line for line in output.splitlines() if 'XMLPARSER' in line]


def test_fast_dds_reads_the_shipped_profile_without_an_error(ros_domain, tmp_path):
    assert participant_errors(ros_domain, PROFILE) == []
    # The same file with one element misspelt: Fast DDS does read the file the variable names.
    broken = tmp_path / 'broken.xml'
    broken.write_text(PROFILE.read_text().replace('heartbeatPeriod>', 'heartbeatPeriodX>'))
    assert any('heartbeatPeriodX' in line for line in participant_errors(ros_domain, broken))


def test_node_processes_name_the_profile_unless_the_user_named_one(monkeypatch):
    monkeypatch.delenv(PROFILE_VARIABLE, raising=False)
    assert ros_environment(1)[PROFILE_VARIABLE] == str(PROFILE)
    assert with_profile({})[PROFILE_VARIABLE] == str(PROFILE)
    monkeypatch.setenv(PROFILE_VARIABLE, '/etc/my_profile.xml')
    assert ros_environment(1)[PROFILE_VARIABLE] == '/etc/my_profile.xml'
    assert with_profile(os.environ)[PROFILE_VARIABLE] == '/etc/my_profile.xml'
