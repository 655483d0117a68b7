"""The plant in simulated time: /clock, lockstep, pause/step, run_until, resets, and the kit.

Over DDS (the wiring, through the testing kit and controller node processes): every expectation
is exact (lockstep), none is a timing assert: states are compared bit for bit with
``GloveSimulation`` stepped in this process with the same commands, time with the grid
t_k = round(k·10⁹/rate_hz) ns.

Starting a glove costs seconds, a reset milliseconds: the tests that need no special plant
options share one glove (``glove``, with the estimator), reset before each test, and expect
everything relative to the simulated time they find (it never rewinds). A test that needs other
options or a fresh noise stream gets a glove of its own (``glove_sim``).

In process (`reliability_inprocess.InProcessNode`, the plant's services and timers called
directly): pause and step, run_until, a new session (``reset_simulation``), the lockstep
timeout and its recovery, and the waits of a service step. That lockstep needs simulated time is
refused at start: tests/test_nodes_startup.py.
"""

import itertools
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from exodigit_model.physics.params import patient_file
from exodigit_model.stepping.settings import step_time_ns
from exodigit_nodes.nodes import sim_time
from exodigit_nodes.nodes.plant import Plant
from exodigit_nodes.nodes.pressure_command import PressureCommand
from exodigit_nodes.testing import GloveSim, GloveSimError
from exodigit_nodes.testing.client import DEFAULT_TIMEOUT
from exodigit_nodes.testing.driving import matched_both_ways
from lockstep_controller import command_at
from rclpy.parameter import Parameter
from reliability_inprocess import InProcessNode
from ros_harness import RosProbe, stop_process, wait_until
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Header
from std_srvs.srv import SetBool, Trigger

from exodigit_model import GloveModel, GloveSimulation, SimulationSettings, load_params

CONTROLLER = Path(__file__).with_name('lockstep_controller.py')
#: Step rate of the shared glove (the plant's default), Hz.
RATE = 100.0
#: Steps the test of /clock takes.
STEPS = 50
#: How close the force mode brings the contact forces to their 0.1 N targets by the end of a
#: 1 s run in lockstep, N (settled within it by step 60).
SETTLED_FORCE = 1e-4


def kit_replay(settings: SimulationSettings) -> GloveSimulation:
    """An in-process stepper in the state a fresh GloveSim leaves its plant in (one reset)."""
    simulation = GloveSimulation(settings=settings)
    simulation.reset()
    simulation.step(np.zeros(3))
    return simulation


def assert_same(state, reference):
    """A published state equals the in-process one bit for bit."""
    assert state.t == reference.t
    np.testing.assert_array_equal(state.q, reference.q_measured)
    np.testing.assert_array_equal(state.qdot, reference.qdot)
    np.testing.assert_array_equal(state.effort, reference.finger_torque)
    np.testing.assert_array_equal(state.pressure, reference.pressure_measured)
    np.testing.assert_array_equal(state.forces, reference.forces)
    np.testing.assert_array_equal(state.lengths, reference.lengths)


def sine(k, peak=40e3, period=150):
    return np.array([1.0, 0.7, 0.4]) * peak * 0.5 * (1.0 - math.cos(2 * math.pi * k / period))


@pytest.fixture(scope='module')
def shared_glove(tmp_path_factory):
    """One glove, with the estimator, for every test that needs no other plant options."""
    with GloveSim(estimator=True, log_dir=tmp_path_factory.mktemp('shared_glove')) as glove:
        yield glove


@pytest.fixture
def glove(shared_glove):
    """The shared glove at rest, the kit's default timeout, no controller of a test before left."""
    shared_glove.timeout = DEFAULT_TIMEOUT
    # A stopped controller leaves the graph a moment later; until then step() refuses to step.
    assert wait_until(lambda: not shared_glove._node.other_controllers(), DEFAULT_TIMEOUT)
    shared_glove.reset()
    return shared_glove


@pytest.fixture
def probe_for():
    probes = []

    def make(domain_id):
        probes.append(RosProbe(domain_id, name='sim_time_probe'))
        return probes[-1]

    yield make
    for probe in probes:
        probe.close()


def start_controller(glove, *extra):
    return subprocess.Popen(
        [sys.executable, str(CONTROLLER), *extra, '--ros-args', '-r', f'__ns:={glove.namespace}'],
        env=glove.env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )


# -- the plant through the testing kit ------------------------------------------------------


@pytest.mark.glove_sim(
    plant={
        'pressure_time_constant': 0.05,
        'angle_noise_std': 2e-3,
        'pressure_noise_std': 300.0,
        'seed': 11,
        'rate_hz': 250.0,
    }
)
def test_the_node_and_the_stepper_give_identical_states_for_the_same_commands(glove_sim):
    # A glove of its own: the noise streams must start with it. Not at the default rate, so
    # that the stamps are checked on another grid than the shared glove's.
    settings = SimulationSettings(
        pressure_time_constant=0.05,
        angle_noise_std=2e-3,
        pressure_noise_std=300.0,
        seed=11,
        rate_hz=250.0,
    )
    reference = kit_replay(settings)
    assert_same(glove_sim.state, reference.state)
    for k in range(100):  # 100 steps of noise, lag and a varying command are as good as 300
        command = sine(k, period=100)
        assert_same(glove_sim.step(command), reference.step(command))
    glove_sim.reset()
    reference.reset()
    reference_state = reference.step(np.zeros(3))  # the plant publishes its rest state as a step
    assert_same(glove_sim.state, reference_state)
    assert_same(glove_sim.step([5e3, 5e3, 5e3]), reference.step([5e3, 5e3, 5e3]))


def test_clock_is_monotone_and_advances_one_period_per_step(glove, probe_for):
    probe = probe_for(glove.domain_id)
    clocks = probe.subscribe('/clock', Clock)
    states = probe.subscribe(f'{glove.namespace}/joint_states', JointState)
    for _ in range(50):  # until the plant has matched the probe's readers (a bounded retry)
        first = glove.reset()
        if wait_until(lambda: clocks.count() and states.count(), 0.2):
            break
    states.clear()
    stamps = [glove.step([20e3, 20e3, 20e3]).t for _ in range(STEPS)]
    assert wait_until(lambda: states.count() >= STEPS, 10.0)
    ticks = [c.clock.sec * 10**9 + c.clock.nanosec for c in clocks.messages()]
    start = round(first.t * RATE)
    assert ticks[-STEPS - 1 :] == [round(k * 1e9 / RATE) for k in range(start, start + STEPS + 1)]
    assert all(b > a for a, b in itertools.pairwise(ticks))
    assert [round(t * 1e9) for t in stamps] == ticks[-STEPS:]


def test_reset_rests_the_glove_but_never_rewinds_time(glove):
    for _ in range(3):  # no chamber lag: bent at once
        before = glove.step([40e3, 40e3, 40e3])
    assert before.q.max() > 0.05
    rest = glove.reset()
    assert rest.t == pytest.approx(before.t + 1 / RATE, abs=1e-12)
    np.testing.assert_array_equal(rest.pressure, np.zeros(3))
    np.testing.assert_array_equal(rest.q, np.zeros(3))
    after = glove.step(np.zeros(3))
    assert after.t > rest.t


def test_a_bad_command_is_refused_before_it_is_sent(glove):
    with pytest.raises(ValueError, match='three finite'):
        glove.step([1.0, math.nan, 0.0])
    assert glove.step([1e3, 1e3, 1e3]).pressure[0] == 1e3


def test_kit_parameters_cannot_be_overridden():
    with pytest.raises(ValueError, match='lockstep'):
        GloveSim(plant={'lockstep': False})


# -- an external controller in lockstep ----------------------------------------------------


def replay_external(rest, run_lengths, then=()):
    """(Time, state, command) of runs with the lockstep controller, stepped in process.

    The runs start from the glove's rest state ``rest`` (a reset); the in-process stepper
    starts at step 1, so its step n is the glove's step n + shift, which is what the
    controller sees (its commands are a function of that time). Then the commands ``then``,
    each after the controller's answer to the state before, are stepped: their states last.
    """
    simulation = kit_replay(SimulationSettings(pressure_time_constant=0.0))
    shift = round(rest.t * RATE) - simulation.state.step
    state = simulation.step(np.zeros(3))  # the first run's fresh state (latest command: 0)
    records = []
    for length in run_lengths:
        run = []
        while len(run) < length:
            t = step_time_ns(state.step + shift, RATE) / 1e9
            run.append((t, state, command_at(t)))
            state = simulation.step(command_at(t))
        records.append(run)
    return [*records, [simulation.step(command) for command in then]]


@pytest.mark.parametrize('delay', [0.0, 0.02], ids=['fast', 'slow'])
def test_runs_with_a_controller_node_are_exact_however_slow_it_is(glove, delay):
    # Two runs: the second goes on exactly where the first stopped. Beside the controller the
    # test cannot step the glove itself.
    rest = glove.state
    controller = start_controller(glove, '--delay', str(delay))
    try:
        records = [glove.run(0.2), glove.run(0.1)]
        with pytest.raises(GloveSimError, match='run'):
            glove.step([1e3, 1e3, 1e3])
    finally:
        stop_process(controller)
    expected = replay_external(rest, [20, 10])[:2]
    for record, runs in zip(records, expected, strict=True):
        assert len(record.t) == len(runs)
        for i, (t, state, command) in enumerate(runs):
            assert record.t[i] == t
            np.testing.assert_array_equal(record.q[i], state.q_measured)
            np.testing.assert_array_equal(record.pressure[i], state.pressure_measured)
            np.testing.assert_array_equal(record.forces[i], state.forces)
            np.testing.assert_array_equal(record.lengths[i], state.lengths)
            np.testing.assert_array_equal(record.command[i], command)


def test_a_step_after_a_run_is_the_step_after_the_controller_s_last_answer(glove):
    # The plant took the controller's answer to the run's last state; stepping the glove
    # afterwards steps with that answer first, then with the test's command.
    rest = glove.state
    controller = start_controller(glove)
    try:
        last = glove.run(0.05).t[-1]
    finally:
        stop_process(controller)
    assert wait_until(lambda: not glove._node.other_controllers(), DEFAULT_TIMEOUT)
    command = np.array([5e3, 10e3, 15e3])
    state = glove.step(command)
    *_, (expected,) = replay_external(rest, [5], then=[command])
    assert state.t == step_time_ns(round(last * RATE) + 2, RATE) / 1e9
    np.testing.assert_array_equal(state.q, expected.q_measured)
    np.testing.assert_array_equal(state.pressure, expected.pressure_measured)
    np.testing.assert_array_equal(state.forces, expected.forces)


def test_a_controller_that_cannot_answer_the_plant_s_handshake_is_never_counted(glove):
    # Matched both ways as the plant sees it, but the plant cannot know that the controller's
    # reader has matched its writer (docs/spec/ros.md, guarantee 5): no state is sent for it.
    controller = start_controller(glove, '--no-parameters')
    glove.timeout = 2.0
    try:
        with pytest.raises(GloveSimError, match='waited 2 s for the plant to match'):
            glove.run(0.05)
    finally:
        glove.timeout = DEFAULT_TIMEOUT
        stop_process(controller)


def test_the_kit_knows_a_controller_the_plant_matched_by_its_publishers_not_its_name():
    said = {'/g/lockstep_controller': {'0a', '0b'}}  # the plant's lockstep_controllers
    assert matched_both_ways({'/g/lockstep_controller': {'0b'}}, said)
    assert matched_both_ways({}, said)
    assert not matched_both_ways({'/g/lockstep_controller': {'0c'}}, said)  # a namesake's
    assert not matched_both_ways({'/g/other': {'0a'}}, said)


def test_a_run_that_times_out_lets_the_plant_step_freely_again(glove, probe_for):
    controller = start_controller(glove, '--stall-after', '10')
    try:
        start = glove.run(0.05).t[-1]  # in step with the controller
        glove.timeout = 0.5  # then it hangs after 5 more answers (no need to wait long)
        with pytest.raises(GloveSimError, match=r'waited 0\.5 s for the next state'):
            glove.run(0.2)
    finally:
        stop_process(controller)
    probe = probe_for(glove.domain_id)
    plant = f'{glove.namespace}/plant'
    assert probe.get_parameters(plant, ['run_until']) == [0.0]
    # The test steps the glove again, past the end the failed run was to have.
    glove.timeout = DEFAULT_TIMEOUT
    assert wait_until(lambda: not glove._node.other_controllers(), DEFAULT_TIMEOUT)
    state = glove.step(np.zeros(3))
    while state.t < start + 0.3:
        previous, state = state, glove.step(np.zeros(3))
        assert state.t == pytest.approx(previous.t + 1 / RATE, abs=1e-12)


def test_force_mode_in_lockstep_answers_each_state_with_the_estimate_of_that_step(glove):
    controller = subprocess.Popen(
        [
            sys.executable,
            '-m',
            'exodigit_nodes.nodes.pressure_command',
            '--ros-args',
            *('-p', 'mode:=force', '-p', 'lockstep:=true', '-p', 'use_sim_time:=true'),
            *('-r', f'__ns:={glove.namespace}'),
        ],
        env=glove.env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        # Waits for one answer per state: none missing, none extra. Settled within 1e-4 N by
        # step 60 here (it was a 3 s run).
        record = glove.run(1.0)
    finally:
        stop_process(controller)
    assert len(record.t) == len(record.command) == 100
    np.testing.assert_allclose(record.forces[-1], [0.1, 0.1, 0.1], rtol=0, atol=SETTLED_FORCE)


def test_a_lockstep_force_controller_answers_states_only_once_it_hears_an_estimator(probe):
    # Else the estimate of the first state it is sent could leave before it can hear it, and
    # the glove would wait for that answer forever.
    node = InProcessNode(
        PressureCommand, {'lockstep': 'true', 'mode': 'force', 'use_sim_time': 'true'}, probe
    )
    try:
        node.node.inputs.listen_once_estimated()
        assert 'joint_states' not in node.subscriptions()
        estimator = node.node.create_publisher(JointState, 'estimated_contact_forces', 10)
        deadline = time.monotonic() + 10.0
        while 'joint_states' not in node.subscriptions() and time.monotonic() < deadline:
            node.node.inputs.listen_once_estimated()
            time.sleep(0.01)
        assert 'joint_states' in node.subscriptions()
        assert estimator.get_subscription_count() == 1
    finally:
        node.close()


def test_a_lockstep_force_controller_answers_with_the_estimate_stamped_with_the_state(probe):
    # The estimate of an earlier state (late) is not this state's: no answer until its own.
    made = InProcessNode(
        PressureCommand, {'lockstep': 'true', 'mode': 'force', 'use_sim_time': 'true'}, probe
    )
    try:
        made.node.inputs.listen_to_states()  # as once an estimator is matched

        def stamped(step, **values):
            header = Header(stamp=Time(sec=1, nanosec=step * 10_000_000))
            return JointState(header=header, name=['mcp', 'pip', 'dip'], **values)

        made.deliver('joint_states', stamped(2, position=[0.1, 0.1, 0.1]))
        made.deliver('estimated_contact_forces', stamped(1, effort=[0.0, 0.0, 0.0]))
        assert made.take().get('pressure_command', []) == []
        made.deliver('estimated_contact_forces', stamped(2, effort=[0.0, 0.0, 0.0]))
        assert len(made.take()['pressure_command']) == 1
    finally:
        made.close()


def service_callback(node: InProcessNode, name: str):
    """The callback of the node's service ``name`` (relative name)."""
    return next(s.callback for s in node.node.services if s.service_name.endswith(f'/{name}'))


@pytest.mark.parametrize('service', ['step', 'reset', 'reset_simulation'])
def test_a_service_step_is_published_before_the_answer(probe, service):
    # No timer fires: the callback itself takes the step (docs/spec/ros.md, "Simulated time").
    node = InProcessNode(Plant, {'clock': 'sim', 'start_paused': 'true'}, probe)
    try:
        answer = service_callback(node, service)(Trigger.Request(), Trigger.Response())
        assert answer.success and f't = {1 / RATE:.9f} s' in answer.message
        assert len(node.take()['joint_states']) == 1
        node.fire_timers()  # paused: nothing more
        assert 'joint_states' not in node.take()
    finally:
        node.close()


def ignore(message) -> None:
    """A subscription callback that does nothing."""


def test_lockstep_starts_only_once_one_node_both_reads_the_states_and_answers(probe):
    # An estimator reads the states and another node publishes commands: not a controller yet
    # (a lockstep force-mode pressure_command subscribes the states only once its estimator is
    # matched). The first step waits until the command publisher's node reads the states too.
    node = InProcessNode(
        Plant, {'clock': 'sim', 'lockstep': 'true', 'real_time_factor': '0.0'}, probe
    )
    plant = node.node
    try:
        with probe.local_node('estimator') as estimator, probe.local_node('controller') as ours:
            estimator.create_subscription(JointState, plant.joint_publisher.topic_name, ignore, 10)
            ours.create_publisher(Float64MultiArray, plant.command_subscription.topic_name, 10)
            assert wait_until(
                lambda: (
                    plant.command_subscription.get_publisher_count() == 1
                    and plant.joint_publisher.get_subscription_count() == 1
                ),
                10.0,
            )
            node.fire_timers()
            assert 'joint_states' not in node.take()
            ours.create_subscription(JointState, plant.joint_publisher.topic_name, ignore, 10)
            assert wait_until(plant.lockstep_controllers, 10.0)
            node.fire_timers()
            assert len(node.take()['joint_states']) == 1
    finally:
        node.close()


def listed(node: InProcessNode) -> list[dict[str, str]]:
    """The controllers of each ``lockstep_controllers`` message the plant published since."""
    return [
        {v.key: v.value for v in m.values} for m in node.take().get('lockstep_controllers', [])
    ]


def writer_id(graph, node, topic: str) -> str:
    """The GID (hex) of the one publisher of ``node`` on ``topic`` the graph of ``graph`` lists."""
    (info,) = [
        info
        for info in graph.get_publishers_info_by_topic(topic)
        if info.node_name == node.get_name()
    ]
    return bytes(info.endpoint_gid).hex()


def test_a_paused_plant_says_which_controllers_it_has_matched_both_ways(probe, monkeypatch):
    # The typed answer the testing kit waits on before it publishes a state that a controller
    # it has just started must answer: a node that publishes commands and reads the states,
    # with the id of its command publisher, which tells it from a namesake that came before.
    monkeypatch.setattr(sim_time, 'CONTROLLERS_PERIOD', 0.0)  # look at every cycle
    node = InProcessNode(Plant, {'clock': 'sim', 'start_paused': 'true'}, probe)
    plant = node.node
    commands = plant.command_subscription.topic_name
    try:
        node.fire_timers()
        assert listed(node) == [{}]
        ids = []
        for _ in range(2):  # the same name twice
            with probe.local_node('controller') as ours:
                ours.create_publisher(Float64MultiArray, commands, 10)
                node.fire_timers()
                assert listed(node) == []  # it publishes only when the list changes
                ours.create_subscription(JointState, plant.joint_publisher.topic_name, ignore, 10)
                assert wait_until(plant.lockstep_controllers, 10.0)
                node.fire_timers()
                ids.append(writer_id(plant, ours, commands))
                assert listed(node) == [{ours.get_fully_qualified_name(): ids[-1]}]
            assert wait_until(lambda: not plant.lockstep_controllers(), 10.0)
            call(node, 'set_paused', SetBool.Request(data=True), SetBool.Response())
            assert listed(node) == [{}]
        assert ids[0] != ids[1]
    finally:
        node.close()


# -- simulated time in process: pause and step, run_until, the lockstep timeout ---------------


@pytest.fixture
def sim_plant(probe):
    """Builds a Plant in process on simulated time (real-time factor 0, no chamber lag)."""
    made = []

    def build(**overrides):
        parameters = {
            'clock': 'sim',
            'real_time_factor': '0.0',
            'marker_rate_hz': '0.0',
            'pressure_time_constant': '0.0',
        }
        made.append(InProcessNode(Plant, {**parameters, **overrides}, probe))
        return made[-1]

    yield build
    for node in made:
        node.close()


def run_loop(node: InProcessNode, cycles: int = 50) -> list:
    """The joint_states published over ``cycles`` cycles of the node's timers."""
    states = []
    for _ in range(cycles):
        node.fire_timers()
        states += node.take().get('joint_states', [])
    return states


def stamps_ns(states) -> list[int]:
    return [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in states]


def call(node: InProcessNode, name: str, request, response):
    return service_callback(node, name)(request, response)


def test_pause_and_step_advance_exactly_one_step_each(sim_plant):
    node = sim_plant()
    assert run_loop(node, 3)  # running: the loop steps
    paused = call(node, 'set_paused', SetBool.Request(data=True), SetBool.Response())
    assert paused.success and 'paused' in paused.message
    mark = round(node.node.state.t * RATE)
    node.deliver('pressure_command', Float64MultiArray(data=[30e3, 30e3, 30e3]))
    assert run_loop(node) == [], 'stepped while paused'
    for k in range(1, 4):
        response = call(node, 'step', Trigger.Request(), Trigger.Response())
        assert response.success, response.message
        published = node.take()
        assert stamps_ns(published['joint_states']) == [step_time_ns(mark + k, RATE)]
        assert list(published['chamber_pressure'][-1].data) == [30e3] * 3  # the latest command
    resumed = call(node, 'set_paused', SetBool.Request(data=False), SetBool.Response())
    assert resumed.success
    running = call(node, 'step', Trigger.Request(), Trigger.Response())
    assert not running.success and 'not paused' in running.message


def test_set_paused_logs_a_change_once_however_often_it_is_asked(sim_plant, capfd):
    # A client may ask again and again (the testing kit once asked hundreds of times a
    # second, which filled the plant's log).
    node = sim_plant()
    capfd.readouterr()
    for paused in (True, True, True, True, False, False):
        answer = call(node, 'set_paused', SetBool.Request(data=paused), SetBool.Response())
        assert answer.success and answer.message.startswith('paused' if paused else 'running')
    logged = [line for line in capfd.readouterr().err.splitlines() if ' at t = ' in line]
    assert len(logged) == 2 and 'paused at' in logged[0] and 'running at' in logged[1], logged


def test_run_until_holds_the_steps_there_and_raising_it_lets_them_go_on(sim_plant):
    # What a runner does to keep its record whole (exodigit_nodes.runner.horizon): not a pause.
    node = sim_plant(start_paused='true', run_until='0.05')
    resumed = call(node, 'set_paused', SetBool.Request(data=False), SetBool.Response())
    assert resumed.success
    states = node.take().get('joint_states', []) + run_loop(node)
    assert stamps_ns(states) == [step_time_ns(k, RATE) for k in range(1, 6)]  # held at 0.05 s
    assert node.node.set_parameters([Parameter('run_until', value=0.1)])[0].successful
    states += node.take().get('joint_states', []) + run_loop(node)
    assert stamps_ns(states) == [step_time_ns(k, RATE) for k in range(1, 11)]


def test_reset_simulation_starts_the_patient_of_the_parameters_at_time_zero(sim_plant):
    # What the testing kit does between two patients of a trial: set params_file and seed,
    # then reset_simulation. The new session is what a plant started with them gives, /clock
    # going back to its first step.
    node = sim_plant(start_paused='true', angle_noise_std='0.001')
    node.deliver('pressure_command', Float64MultiArray(data=[30e3, 30e3, 30e3]))
    for _ in range(5):
        call(node, 'step', Trigger.Request(), Trigger.Response())
    patient = str(patient_file('stroke_moderate'))
    refused = node.node.set_parameters([Parameter('params_file', value='/no/such/patient.yaml')])
    assert not refused[0].successful and 'params_file' in refused[0].reason
    changes = [Parameter('params_file', value=patient), Parameter('seed', value=7)]
    assert all(result.successful for result in node.node.set_parameters(changes))
    node.take()
    answer = call(node, 'reset_simulation', Trigger.Request(), Trigger.Response())
    assert answer.success, answer.message
    published = node.take()
    settings = SimulationSettings(pressure_time_constant=0.0, angle_noise_std=0.001, seed=7)
    expected = GloveSimulation(GloveModel(load_params([patient])), settings).step(np.zeros(3))
    (state,) = published['joint_states']
    (clock,) = published['/clock']
    assert stamps_ns([state]) == [step_time_ns(1, RATE)] == [expected.time_ns]
    assert clock.clock == state.header.stamp
    np.testing.assert_array_equal(state.position, expected.q_measured)
    np.testing.assert_array_equal(published['contact_forces'][0].data, expected.forces)


def lockstep_status(node: InProcessNode) -> str:
    node.node.report()
    status = node.take()['/diagnostics'][-1].status[0]
    return next(kv.value for kv in status.values if kv.key == 'lockstep')


def test_a_silent_controller_vents_after_the_timeout_and_a_new_answer_locks_step_again(
    sim_plant,
):
    # Any controller that stops answering (killed, hung) is silence to the plant. A publisher of
    # commands and a reader of states in the node's own namespace stand for the controller
    # on the graph; its answers are delivered by hand.
    node = sim_plant(lockstep='true', lockstep_timeout='0.05')
    node.node.create_publisher(Float64MultiArray, 'pressure_command', 10)
    node.node.create_subscription(JointState, 'joint_states', lambda _: None, 10)
    assert wait_until(node.node.lockstep_controllers, 10.0)
    pressures = []

    def answer(value):
        node.deliver('pressure_command', Float64MultiArray(data=[value] * 3))
        pressures.extend(m.data[0] for m in node.take().get('chamber_pressure', []))

    node.fire_timers()  # the first step: a controller is here
    answer(20e3)
    for _ in range(5):
        answer(20e3)  # each answer lets the next step go
    assert pressures[-5:] == [20e3] * 5
    assert lockstep_status(node) in ('locked', 'waiting for the answer')
    # Silence: after lockstep_timeout (wall) the plant vents and steps on at real time.
    count = len(pressures)

    def stepped_on():
        node.fire_timers()
        pressures.extend(m.data[0] for m in node.take().get('chamber_pressure', []))
        return len(pressures) > count + 5

    assert wait_until(stepped_on, 10.0)
    assert pressures[count:] == [0.0] * (len(pressures) - count)  # vented from the first one
    assert lockstep_status(node).startswith('unlocked')
    answer(20e3)  # a controller answers again: in lockstep again, its command applied
    assert pressures[-1] == 20e3
    assert lockstep_status(node) in ('locked', 'waiting for the answer')
