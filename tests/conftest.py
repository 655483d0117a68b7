"""Shared fixtures. ROS tests get a private domain id and a probe node (tests/ros_harness.py)."""

import os
import signal

import pytest
import rclpy
from ros_harness import NodeLauncher, RosProbe, claim_domain

# Nothing this test session starts may multicast discovery on the network interface.
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
# A shell starts a background job (`make test &`) with SIGINT ignored, and its children inherit
# that: a node would rightly ignore the Ctrl-C the tests send it. Python's own handler here, which
# exec resets to the default in every child, makes the tests mean the same wherever they run.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope='session')
def ros_domain():
    """A ROS_DOMAIN_ID held exclusively by this test session (exported to children)."""
    lease = claim_domain()
    os.environ['ROS_DOMAIN_ID'] = str(lease.domain_id)
    yield lease.domain_id
    lease.release()


@pytest.fixture(scope='session')
def probe(ros_domain):
    """The in-test rclpy node (a RosProbe), shared by the whole session."""
    ros_probe = RosProbe(ros_domain)
    yield ros_probe
    ros_probe.close()


@pytest.fixture(scope='module')
def launcher(ros_domain, tmp_path_factory):
    """Starts node processes for one test module (in a scratch dir); stops them afterwards."""
    nodes = NodeLauncher(ros_domain, tmp_path_factory.mktemp('nodes'))
    yield nodes
    nodes.stop_all()


@pytest.fixture
def ros_context(ros_domain):
    """An rclpy context of its own in the session's domain, for nodes a test builds in process."""
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    yield context
    rclpy.try_shutdown(context=context)


@pytest.fixture
def command_nodes(probe):
    """Builds pressure_command nodes in process, in position mode at given targets; closes them.

    ``build(targets, **overrides)``: an ``InProcessNode`` (reliability_inprocess) with those
    ``joint_targets`` (rad) and the parameter overrides (``-p`` strings).
    """
    from exodigit_nodes.nodes.pressure_command import PressureCommand
    from reliability_inprocess import InProcessNode

    made = []

    def build(targets, **overrides):
        parameters = {'mode': 'position', 'joint_targets': str(list(targets)), **overrides}
        made.append(InProcessNode(PressureCommand, parameters, probe))
        return made[-1]

    yield build
    for node in made:
        node.close()
