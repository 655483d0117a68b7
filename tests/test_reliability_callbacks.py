"""Hypothesis drives every subscription callback of every node in-process (no DDS).

Each node class is built in this process (`reliability_inprocess.InProcessNode`); hypothesis
generates messages of every subscribed type with hostile contents (any float64 including NaN,
±Inf, ±1e308 and subnormals; any length; any joint names; stamps anywhere in int32 seconds), which
pass through an ``rclpy.serialization`` round trip into the callback; then every timer of the
node fires once. After each message: nothing published is non-finite, pressures stay inside the
documented limits, and each malformed message adds exactly one to the node's rejection count
in /diagnostics (a well-formed message may be refused too, e.g. as stale). For the plant a
valid command is also checked against an independent solve.
"""

import importlib
import inspect
import math

import numpy as np
import pytest
from exodigit_nodes.nodes.node_base import GloveNode
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from reliability_fuzz import HOSTILE_NUMBERS, WRONG_LENGTHS
from reliability_inprocess import InProcessNode, non_finite
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

#: Examples per subscription (each one message, then one cycle of every timer).
EXAMPLES = 150
#: Plant supply limit and controller pressure limit used here, Pa.
MAX_SUPPLY = 100e3
MAX_PRESSURE = 60e3
#: Angle tolerance of a published state against an independent solve, rad.
ANGLE_TOLERANCE = 1e-9

NODES = {
    'plant': {'pressure_time_constant': '0.0', 'max_supply_pressure': str(MAX_SUPPLY)},
    'pressure_command': {'max_pressure': str(MAX_PRESSURE)},
    'estimator': {},
}
#: Topic -> inclusive bounds of every published value (the documented limits).
BOUNDS = {
    'chamber_pressure': (0.0, MAX_SUPPLY),
    'pressure_command': (0.0, MAX_PRESSURE),
}
JOINTS = ('mcp', 'pip', 'dip')
JOINT_STATE_READERS = ['estimator', 'pressure_command']
"""The nodes that subscribe joint_states (the tests of that topic run on these alone)."""

hostile_floats = st.floats(width=64) | st.sampled_from(HOSTILE_NUMBERS)
vectors = st.one_of(
    st.lists(hostile_floats, min_size=3, max_size=3),
    st.lists(hostile_floats, max_size=6),
    st.sampled_from(WRONG_LENGTHS).map(lambda n: [1.0] * n),
    st.lists(st.floats(-1e6, 1e6), min_size=3, max_size=3),
)
joint_names = st.lists(
    st.sampled_from(JOINTS + tuple(f'p_{j}' for j in JOINTS) + ('', 'x', 'mcp_')),
    max_size=5,
) | st.permutations(JOINTS).map(list)
stamps = st.one_of(
    st.sampled_from(['now', 'zero', 'future', 'ancient']),
    st.tuples(st.integers(-(2**31), 2**31 - 1), st.integers(0, 2**32 - 1)),
)


def node_class(module_name: str) -> type:
    module = importlib.import_module(f'exodigit_nodes.nodes.{module_name}')
    found = [
        c
        for c in vars(module).values()
        if inspect.isclass(c) and issubclass(c, GloveNode) and c.__module__ == module.__name__
    ]
    assert len(found) == 1, f'{module_name}: expected one node class, found {found}'
    return found[0]


@pytest.fixture(scope='module', params=sorted(NODES))
def node(request, probe):
    made = InProcessNode(node_class(request.param), NODES[request.param], probe)
    made.reported = {}  # topic -> rejection count in the node's latest diagnostics
    made.fire_timers()
    made.take()
    yield made
    made.close()


def set_stamp(message: JointState, stamp, now_ns: int) -> None:
    seconds = {'now': now_ns, 'zero': 0, 'future': now_ns + 10**12, 'ancient': 10**9}
    if isinstance(stamp, str):
        nanoseconds = seconds[stamp]
        message.header.stamp.sec = nanoseconds // 10**9
        message.header.stamp.nanosec = nanoseconds % 10**9
    else:
        message.header.stamp.sec, message.header.stamp.nanosec = stamp


def joint_state_malformed(message: JointState) -> bool:
    suffixes = sorted(n[-3:] for n in message.name)
    names_ok = len(message.name) == 3 and suffixes == sorted(JOINTS)
    if names_ok:
        names_ok = all(sum(n.endswith(j) for n in message.name) == 1 for j in JOINTS)
    return not (
        names_ok
        and len(message.position) == 3
        and all(math.isfinite(v) for v in message.position)
        and len(message.velocity) in (0, 3)
        and len(message.effort) in (0, 3)
    )


def rejections(published: dict[str, list], topic: str) -> int | None:
    """The node's count of dropped ``topic`` messages in its latest diagnostics, if any."""
    reports = published.get('/diagnostics', [])
    if not reports:
        return None
    values = reports[-1].status[0].values
    return sum(int(kv.value) for kv in values if kv.key.startswith(f'rejected {topic}:'))


def check_outputs(published: dict[str, list]) -> None:
    assert non_finite(published) == []
    for topic, (low, high) in BOUNDS.items():
        for message in published.get(topic, []):
            assert all(low <= v <= high for v in message.data), f'{topic}: {list(message.data)}'


def drive(node: InProcessNode, topic: str, message) -> dict[str, list]:
    node.deliver(topic, message)
    node.fire_timers()
    published = node.take()
    check_outputs(published)
    return published


def counted_rejections(node: InProcessNode, topic: str, message) -> int:
    """How many rejections of ``topic`` the diagnostics add for ``message``."""
    reported = node.reported
    published = drive(node, topic, message)
    now = rejections(published, topic)
    assert now is not None, 'no /diagnostics after a cycle of every timer'
    added = now - reported.get(topic, 0)
    reported[topic] = now
    return added


def test_the_joint_state_readers_are_the_nodes_that_subscribe_it(node):
    subscribes = 'joint_states' in node.subscriptions()
    assert subscribes == (node.node.get_name() in JOINT_STATE_READERS)


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=vectors)
def test_vector_topics_never_yield_non_finite_output_and_count_every_rejection(node, data):
    for topic, (kind, _) in node.subscriptions().items():
        if kind is not Float64MultiArray:
            continue
        added = counted_rejections(node, topic, Float64MultiArray(data=data))
        if len(data) != 3 or not all(math.isfinite(v) for v in data):
            assert added == 1
        else:  # well formed; a node may still refuse it as out of its plausible range
            assert added in (0, 1)


@pytest.mark.parametrize('node', JOINT_STATE_READERS, indirect=True)
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    names=joint_names,
    position=st.lists(hostile_floats, max_size=5) | st.lists(st.floats(-3, 3), min_size=3),
    velocity=st.lists(hostile_floats, max_size=4),
    effort=st.lists(hostile_floats, max_size=4),
    stamp=stamps,
)
def test_joint_states_never_yield_non_finite_output_and_count_rejections(
    node, names, position, velocity, effort, stamp
):
    message = JointState(name=names, position=position, velocity=velocity, effort=effort)
    set_stamp(message, stamp, node.node.get_clock().now().nanoseconds)
    counted = counted_rejections(node, 'joint_states', message)
    # Malformed content is always refused; a well-formed message may still be refused as stale.
    assert counted == 1 if joint_state_malformed(message) else counted in (0, 1)


@pytest.fixture(scope='module')
def default_model():
    return GloveModel(load_params())


@pytest.fixture
def plant_commanded_only(probe):
    """A plant of its own that only ever gets pressure commands.

    Not the module's plant: the fuzzing above may have left it a valid patient effort, which
    moves the glove until its effort timeout (wall clock) and so off the solve of the pressure.
    """
    made = InProcessNode(node_class('plant'), NODES['plant'], probe)
    yield made
    made.close()


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(command=st.lists(st.floats(-2e5, 2e5), min_size=3, max_size=3))
def test_plant_state_after_a_valid_command_is_the_solve_of_the_saturated_pressure(
    plant_commanded_only, default_model, command
):
    published = drive(plant_commanded_only, 'pressure_command', Float64MultiArray(data=command))
    expected_pressure = np.clip(command, 0.0, MAX_SUPPLY)
    np.testing.assert_array_equal(published['chamber_pressure'][-1].data, expected_pressure)
    solution = default_model.solve(expected_pressure)
    assert solution.converged
    np.testing.assert_allclose(
        published['joint_states'][-1].position, solution.q, rtol=0, atol=ANGLE_TOLERANCE
    )


@pytest.mark.parametrize('node', JOINT_STATE_READERS, indirect=True)
@pytest.mark.parametrize('seconds', [-1, -(2**31)])
def test_joint_states_stamped_before_1970_are_dropped_not_fatal(node, seconds):
    """A stamp with negative seconds is a valid builtin_interfaces/Time on the wire."""
    message = JointState(name=list(JOINTS), position=[0.1, 0.1, 0.1])
    message.header.stamp.sec = seconds
    assert counted_rejections(node, 'joint_states', message) == 1
