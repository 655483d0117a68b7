"""Valves over ROS (docs/spec/ros.md, "Valves"): the plant with ``actuation:=valves`` and
``pressure_command`` with ``output:=valves``, in process (`reliability_inprocess.InProcessNode`:
callbacks and timers called by the test, no DDS traffic, no waiting on the wall clock).

The plant is checked against ``GloveSimulation(actuation='valves')`` stepped in this process with
the same openings, bit for bit: in lockstep (each delivered ``valve_command`` is the answer that
lets the next step go), with refused commands (the last valid openings stay), and with the
watchdog's vent (inlets closed, outlets open) counted in simulated time. The physics of the
valves is the model's (tests/test_model_*); here only that the node applies what it should.
"""

import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_model.control import ValveLoop, ValveLoopSettings
from exodigit_model.stepping.settings import VENT
from exodigit_nodes.nodes.plant import Plant
from exodigit_nodes.nodes.pressure_command import PressureCommand
from reliability_inprocess import InProcessNode, non_finite
from ros_harness import wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Header

from exodigit_model import GloveSimulation, SimulationSettings

SETTINGS = SimulationSettings(pressure_time_constant=0.0)
"""The in-process plants' settings (no lag: the valves are the dynamics; rate 100 Hz)."""
PLANT = {
    'actuation': 'valves',
    'clock': 'sim',
    'real_time_factor': '0.0',
    'marker_rate_hz': '0.0',
    'pressure_time_constant': '0.0',
}
FILL = np.array([0.6, 0.4, 0.2, 0.0, 0.0, 0.0])
"""Openings that fill every chamber (inlets open, outlets closed)."""


def openings(k: int) -> np.ndarray:
    """Openings of step k: fill, hold and vent in turn, each chamber its own phase."""
    phase = (k // 7 + np.arange(3)) % 3
    inlet = np.where(phase == 0, 0.3 + 0.1 * np.arange(3), 0.0)
    outlet = np.where(phase == 2, 0.5, 0.0)
    return np.concatenate([inlet, outlet])


def valves_message(values) -> Float64MultiArray:
    return Float64MultiArray(data=[float(v) for v in values])


def assert_published(published: dict, reference) -> None:
    """The step the plant published equals the in-process step, bit for bit."""
    state = published['joint_states'][-1]
    np.testing.assert_array_equal(
        published['chamber_pressure'][-1].data, reference.pressure_measured
    )
    np.testing.assert_array_equal(state.position, reference.q_measured)
    np.testing.assert_array_equal(state.velocity, reference.qdot)
    np.testing.assert_array_equal(state.effort, reference.finger_torque)
    np.testing.assert_array_equal(published['contact_forces'][-1].data, reference.forces)


def report(node: InProcessNode):
    """The plant's /diagnostics status now: (status, key -> value)."""
    node.node.report()
    status = node.take()['/diagnostics'][-1].status[0]
    return status, {kv.key: kv.value for kv in status.values}


@pytest.fixture
def built(probe):
    """Builds glove nodes in process: ``built(node_class, parameters)``; closes them after."""
    made = []

    def build(node_class, parameters: dict[str, str]) -> InProcessNode:
        made.append(InProcessNode(node_class, parameters, probe))
        return made[-1]

    yield build
    for node in made:
        node.close()


@pytest.fixture
def valve_plant(built):
    """Builds a Plant with valves in process on simulated time (more parameters by keyword)."""
    return lambda **overrides: built(Plant, {**PLANT, **overrides})


@pytest.fixture
def lockstep_plant(valve_plant):
    """A valve plant in lockstep (waiting forever), its first step taken: the vent, no command.

    A publisher of ``valve_command`` and a reader of ``joint_states`` in its namespace stand for
    the controller on the graph; its answers are delivered by hand.
    """
    node = valve_plant(lockstep='true', lockstep_timeout='0.0')
    node.node.create_publisher(Float64MultiArray, 'valve_command', 10)
    node.node.create_subscription(JointState, 'joint_states', lambda _: None, 10)
    assert wait_until(node.node.lockstep_controllers, 10.0)
    node.fire_timers()
    return node


def test_a_valve_plant_in_lockstep_steps_as_the_in_process_simulation_bit_for_bit(
    lockstep_plant,
):
    reference = GloveSimulation(settings=SETTINGS, actuation='valves')
    assert_published(lockstep_plant.take(), reference.step(VENT))  # no command yet: a vent
    for k in range(60):
        lockstep_plant.deliver('valve_command', valves_message(openings(k)))
        expected = reference.step(openings(k))
        published = lockstep_plant.take()
        assert len(published['joint_states']) == 1  # one answer, one step
        assert_published(published, expected)
        assert [list(m.data) for m in published['applied_command']] == [list(openings(k))]
    assert expected.pressure.max() > 5e3  # the openings did move the chambers
    status, values = report(lockstep_plant)
    assert status.level == DiagnosticStatus.OK, status.message
    assert values['air mass (kg)'] == str(expected.mass.tolist())
    assert values['chamber volume (m³)'] == str(expected.volume.tolist())
    assert values['valve openings (in, then out)'] == str(openings(59).tolist())


@pytest.mark.parametrize(
    'bad',
    [
        [],
        [0.5] * 3,
        [0.5] * 5,
        [0.5] * 7,
        [0.5, math.nan, 0.5, 0.0, 0.0, 0.0],
        [0.5, 0.5, math.inf, 0.0, 0.0, 0.0],
        [0.5, 0.5, 0.5, -0.01, 0.0, 0.0],
        [1.01, 0.5, 0.5, 0.0, 0.0, 0.0],
    ],
    ids=['empty', 'three', 'five', 'seven', 'nan', 'inf', 'below 0', 'above 1'],
)
def test_a_bad_valve_command_is_refused_counted_and_the_last_openings_held(lockstep_plant, bad):
    reference = GloveSimulation(settings=SETTINGS, actuation='valves')
    reference.step(VENT)
    lockstep_plant.take()
    lockstep_plant.deliver('valve_command', valves_message(FILL))
    assert_published(lockstep_plant.take(), reference.step(FILL))
    # refused, but still the answer to the step: the step applies the last valid openings
    lockstep_plant.deliver('valve_command', valves_message(bad))
    published = lockstep_plant.take()
    assert_published(published, reference.step(FILL))
    assert [list(m.data) for m in published['applied_command']] == [list(FILL)]
    assert non_finite(published) == []
    status, values = report(lockstep_plant)
    assert sum(int(v) for k, v in values.items() if k.startswith('rejected valve_command')) == 1
    assert status.level == DiagnosticStatus.WARN and 'input messages dropped' in status.message
    assert values['valve openings (in, then out)'] == str(FILL.tolist())


def test_the_watchdog_vents_with_inlets_closed_and_outlets_open(valve_plant):
    """No valve_command for command_timeout (simulated s): openings (0, 0, 0, 1, 1, 1).

    Fed at t = 0, a timeout of 0.055 s holds the openings for steps 1-5 (t ≤ 0.05 s) and vents
    from step 6 on; the plant steps freely (no lockstep), as many steps a timer cycle as it
    manages, each the same.
    """
    node = valve_plant(command_timeout='0.055')
    node.deliver('valve_command', valves_message(FILL))
    states, pressures = [], []
    while len(states) < 20:
        node.fire_timers()
        published = node.take()
        states += published.get('joint_states', [])
        pressures += published.get('chamber_pressure', [])
    reference = GloveSimulation(settings=SETTINGS, actuation='valves')
    for k, (state, pressure) in enumerate(zip(states[:20], pressures[:20], strict=True)):
        expected = reference.step(FILL if k < 5 else VENT)
        np.testing.assert_array_equal(pressure.data, expected.pressure_measured)
        np.testing.assert_array_equal(state.position, expected.q_measured)
    assert reference.state.pressure.max() < 0.5 * max(max(p.data) for p in pressures)
    status, values = report(node)
    assert status.level == DiagnosticStatus.WARN and 'vented' in status.message
    assert values['watchdog'] == 'venting'
    assert values['valve openings (in, then out)'] == str(VENT.tolist())


# -- pressure_command with output valves ------------------------------------------------------

COMMAND = {'output': 'valves', 'mode': 'hold', 'hold_pressure': '[20000.0, 20000.0, 20000.0]'}


@pytest.fixture
def valve_command_node(built):
    """Builds a pressure_command with output valves in process (more parameters by keyword)."""
    return lambda **overrides: built(PressureCommand, {**COMMAND, **overrides})


def joint_state(t: float) -> JointState:
    seconds, nanoseconds = divmod(round(t * 1e9), 10**9)
    header = Header()
    header.stamp.sec, header.stamp.nanosec = seconds, nanoseconds
    return JointState(header=header, name=['mcp', 'pip', 'dip'], position=[0.1, 0.1, 0.1])


def test_in_lockstep_each_state_is_answered_with_the_loop_on_its_own_steps_pressure(
    valve_command_node,
):
    """A state is answered once its step's chamber_pressure is in (sent before it), whatever
    came first; the answer is the valve loop's openings toward the limited hold target."""
    node = valve_command_node(lockstep='true', max_pressure_rate='1e8')
    loop = ValveLoop(ValveLoopSettings())
    measured = [np.array([5e3, 20e3, 35e3]), np.array([12e3, 20.1e3, 28e3])]
    for k, pressure in enumerate(measured, start=1):
        node.deliver('chamber_pressure', Float64MultiArray(data=pressure.tolist()))
        assert 'valve_command' not in node.take()  # no answer without the state
        node.deliver('joint_states', joint_state(k * 0.01))
        (answer,) = node.take()['valve_command']
        expected = loop.openings(np.full(3, 20e3), pressure, 0.01)
        np.testing.assert_array_equal(answer.data, expected)
    np.testing.assert_array_equal(expected[[1, 4]], [0.0, 0.0])  # PIP within the deadband: hold
    assert expected[0] > 0.0 and expected[5] > 0.0  # MCP fills, DIP vents
    assert answer.layout.dim[0].label == 'valve' and answer.layout.dim[0].size == 6


def test_without_fresh_chamber_pressure_and_on_exit_it_vents(valve_command_node):
    node = valve_command_node()
    node.deliver('joint_states', joint_state(node.node.now_seconds()))
    node.node.tick()  # timer mode: no chamber_pressure at all
    np.testing.assert_array_equal(node.take()['valve_command'][-1].data, VENT)
    node.deliver('chamber_pressure', Float64MultiArray(data=[0.0, 0.0, 0.0]))
    node.node.tick()
    sent = np.array(node.take()['valve_command'][-1].data)
    assert np.all(sent[:3] > 0.0) and np.all(sent[3:] == 0.0)  # below the target: fill
    node.node.on_shutdown()
    np.testing.assert_array_equal(node.take()['valve_command'][-1].data, VENT)
