"""The plant in simulated time over DDS: /clock, lockstep, pause/step, reset, and the testing kit.

Every expectation is exact (lockstep), none is a timing assert: states are compared bit for bit
with ``GloveSimulation`` stepped in this process with the same commands, time with the grid
t_k = round(k·10⁹/rate_hz) ns.

Starting a glove costs seconds, a reset milliseconds: the tests that need no special plant
options share one glove (``glove``, with the estimator), reset before each test, and expect
everything relative to the simulated time they find (it never rewinds). A test that needs other
options, a fresh noise stream, or steps the plant behind the kit's back gets a glove of its own
(``glove_sim``).
"""

import itertools
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from exodigit_model.simulation import step_time_ns
from exodigit_nodes.nodes import sim_time
from exodigit_nodes.nodes.plant import Plant
from exodigit_nodes.nodes.pressure_command import PressureCommand
from exodigit_nodes.testing import GloveSim, GloveSimError
from exodigit_nodes.testing.client import DEFAULT_TIMEOUT
from lockstep_controller import command_at
from reliability_inprocess import InProcessNode
from ros_harness import RosProbe, wait_until
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from exodigit_model import GloveSimulation, SimulationSettings

CONTROLLER = Path(__file__).with_name('lockstep_controller.py')
#: How long a negative check (nothing happens) watches, wall s.
QUIET = 0.3
#: Step rate of the shared glove (the plant's default), Hz.
RATE = 100.0


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


def sine(k, peak=40e3):
    return np.array([1.0, 0.7, 0.4]) * peak * 0.5 * (1.0 - math.cos(2 * math.pi * k / 150))


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


def stop(process):
    process.send_signal(signal.SIGINT)
    try:
        process.wait(5)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


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
    for k in range(300):
        command = sine(k)
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
    stamps = [glove.step([20e3, 20e3, 20e3]).t for _ in range(200)]
    assert wait_until(lambda: states.count() >= 200, 10.0)
    ticks = [c.clock.sec * 10**9 + c.clock.nanosec for c in clocks.messages()]
    start = round(first.t * RATE)
    assert ticks[-201:] == [round(k * 1e9 / RATE) for k in range(start, start + 201)]
    assert all(b > a for a, b in itertools.pairwise(ticks))
    assert [round(t * 1e9) for t in stamps] == ticks[-200:]


def test_reset_rests_the_glove_but_never_rewinds_time(glove):
    for k in range(50):
        before = glove.step(sine(k))
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


def test_pause_and_step_advance_exactly_one_step_each(glove_sim, probe_for):
    # A glove of its own: the kit's client would take the steps made here for its own later.
    probe = probe_for(glove_sim.domain_id)
    ns = glove_sim.namespace
    states = probe.subscribe(f'{ns}/joint_states', JointState)
    glove_sim.step([10e3, 10e3, 10e3])
    paused = probe.call(f'{ns}/set_paused', SetBool, SetBool.Request(data=True))
    assert paused.success and 'paused' in paused.message
    mark = glove_sim.state.t
    probe_pub = probe.publisher(f'{ns}/pressure_command', Float64MultiArray)
    probe_pub.publish(Float64MultiArray(data=[30e3, 30e3, 30e3]))  # an answer, but paused
    time.sleep(QUIET)
    assert not [m for m in states.messages() if _t(m) > mark], 'stepped while paused'
    for k in range(1, 4):
        response = probe.call(f'{ns}/step', Trigger, Trigger.Request())
        assert response.success, response.message
        newest = wait_until(lambda: max(_t(m) for m in states.messages()), 5.0)
        assert newest == pytest.approx(mark + 0.01 * k, abs=1e-12)
    resumed = probe.call(f'{ns}/set_paused', SetBool, SetBool.Request(data=False))
    assert resumed.success
    running = probe.call(f'{ns}/step', Trigger, Trigger.Request())
    assert not running.success and 'not paused' in running.message


def _t(joint_state):
    return (joint_state.header.stamp.sec * 10**9 + joint_state.header.stamp.nanosec) / 1e9


# -- an external controller in lockstep ----------------------------------------------------


def replay_external(rest, run_lengths):
    """(Time, state, command) of runs with the lockstep controller, stepped in process.

    The runs start from the glove's rest state ``rest`` (a reset); the in-process stepper
    starts at step 1, so its step n is the glove's step n + shift, which is what the
    controller sees (its commands are a function of that time).
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
    return records


@pytest.mark.parametrize('delay', [0.0, 0.02], ids=['fast', 'slow'])
def test_runs_with_a_controller_node_are_exact_however_slow_it_is(glove, delay):
    rest = glove.state
    controller = start_controller(glove, '--delay', str(delay))
    try:
        records = [glove.run(0.5), glove.run(0.3)]
    finally:
        stop(controller)
    expected = replay_external(rest, [50, 30])
    for record, runs in zip(records, expected, strict=True):
        assert len(record.t) == len(runs)
        for i, (t, state, command) in enumerate(runs):
            assert record.t[i] == t
            np.testing.assert_array_equal(record.q[i], state.q_measured)
            np.testing.assert_array_equal(record.pressure[i], state.pressure_measured)
            np.testing.assert_array_equal(record.forces[i], state.forces)
            np.testing.assert_array_equal(record.lengths[i], state.lengths)
            np.testing.assert_array_equal(record.command[i], command)


def test_a_run_that_times_out_lets_the_plant_step_freely_again(glove, probe_for):
    controller = start_controller(glove, '--stall-after', '10')
    try:
        start = glove.run(0.05).t[-1]  # in step with the controller
        glove.timeout = 1.0  # then it hangs after 5 more answers (no need to wait long)
        with pytest.raises(GloveSimError, match='waited 1 s for the next state'):
            glove.run(0.5)
    finally:
        stop(controller)
    probe = probe_for(glove.domain_id)
    plant = f'{glove.namespace}/plant'
    assert probe.get_parameters(plant, ['run_until', 'pause_at']) == [0.0, 0.0]
    # The test steps the glove again, past the end the failed run was to have.
    glove.timeout = DEFAULT_TIMEOUT
    assert wait_until(lambda: not glove._node.other_controllers(), DEFAULT_TIMEOUT)
    state = glove.step(np.zeros(3))
    while state.t < start + 0.6:
        previous, state = state, glove.step(np.zeros(3))
        assert state.t == pytest.approx(previous.t + 1 / RATE, abs=1e-12)


def test_the_test_cannot_step_beside_an_external_controller(glove):
    controller = start_controller(glove)
    try:
        assert wait_until(glove._node.other_controllers, 10.0)
        with pytest.raises(GloveSimError, match='run'):
            glove.step([1e3, 1e3, 1e3])
    finally:
        stop(controller)


# -- lockstep timeout: a controller that dies ------------------------------------------------


def test_a_killed_controller_vents_after_the_timeout_and_a_new_one_locks_step_again(
    launcher, tmp_path
):
    probe = RosProbe(launcher.domain_id, name='lockstep_timeout_probe')
    ns = f'/lockstep_timeout_{time.monotonic_ns()}'
    processes = []
    try:
        pressures = probe.subscribe(f'{ns}/chamber_pressure', Float64MultiArray)
        diagnostics = probe.subscribe('/diagnostics', DiagnosticArray)
        plant = {
            'clock': 'sim',
            'lockstep': True,
            'lockstep_timeout': 0.3,
            'real_time_factor': 0.0,
            'pressure_time_constant': 0.0,
            'diagnostic_period': 0.1,  # the waits for a report below: a tenth of a second each
        }
        processes.append(launcher.start('plant', plant, namespace=ns))
        controller_parameters = {
            'mode': 'hold',
            'lockstep': True,
            'use_sim_time': True,
            'max_pressure_rate': 1e8,
        }
        controller = launcher.start('pressure_command', controller_parameters, namespace=ns)
        processes.append(controller)
        held = pressures.wait_for(lambda m: m.data[0] == 20e3, 30.0)
        assert held is not None, controller.stderr()
        controller.kill()  # kill -9: no zero command on the way out
        mark = time.monotonic()
        vented = pressures.wait_for(lambda m: m.data[0] == 0.0, 10.0, since=mark)
        assert vented is not None
        data = [m.data[0] for m in pressures.messages()]
        last_held = max(i for i, p in enumerate(data) if p == 20e3)
        assert data[last_held + 1] == 0.0  # the first step after the timeout is vented
        unlocked = wait_until(lambda: _lockstep_status(diagnostics, ns, 'unlocked'), 10.0)
        assert unlocked, 'diagnostics do not say the plant vented on the lockstep timeout'
        # It keeps stepping (unlocked, at real time) and locks step again with a new controller.
        count = pressures.count()
        assert wait_until(lambda: pressures.count() > count + 5, 10.0)
        processes.append(launcher.start('pressure_command', controller_parameters, namespace=ns))
        assert pressures.wait_for(lambda m: m.data[0] == 20e3, 30.0, since=time.monotonic())
        assert wait_until(lambda: _lockstep_status(diagnostics, ns, 'locked', 'waiting'), 10.0)
    finally:
        probe.close()
        # Now, not at the module's end: in lockstep at real-time factor 0 the two would step
        # as fast as they can, on the cores the other tests need.
        for process in reversed(processes):
            process.stop()


def _lockstep_status(diagnostics, ns, *words):
    for array in reversed(diagnostics.messages()):
        for status in array.status:
            if status.name == f'{ns}/plant':
                value = next((kv.value for kv in status.values if kv.key == 'lockstep'), '')
                return any(value.startswith(word) for word in words)
    return False


def test_run_until_holds_the_steps_there_and_raising_it_lets_them_go_on(launcher, probe_for):
    # What a runner does to keep its record whole (exodigit_nodes.runner.horizon): not a pause.
    ns = '/run_until'
    parameters = {'clock': 'sim', 'real_time_factor': 0.0, 'start_paused': True}
    launcher.start('plant', {**parameters, 'run_until': 0.05, 'marker_rate_hz': 0.0}, namespace=ns)
    probe = probe_for(launcher.domain_id)
    states = probe.subscribe(f'{ns}/joint_states', JointState)
    probe.call(f'{ns}/step', Trigger, Trigger.Request())  # once our reader is matched

    def stamps():
        return [
            round(m.header.stamp.sec * 1e9 + m.header.stamp.nanosec) for m in states.messages()
        ]

    assert wait_until(lambda: len(stamps()) == 1, 10.0)
    running = probe.call(f'{ns}/set_paused', SetBool, SetBool.Request(data=False))
    assert running.success
    assert wait_until(lambda: len(stamps()) >= 5, 10.0)
    time.sleep(QUIET)
    assert stamps() == [k * 10**7 for k in range(1, 6)]  # 100 Hz, held at 0.05 s
    assert [r.successful for r in probe.set_parameters(f'{ns}/plant', {'run_until': 0.1})] == [
        True
    ]
    assert wait_until(lambda: len(stamps()) >= 10, 10.0)
    time.sleep(QUIET)
    assert stamps() == [k * 10**7 for k in range(1, 11)]


def test_lockstep_needs_simulated_time(launcher):
    code, _, err = launcher.run('plant', {'lockstep': True}, timeout=30.0)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and 'lockstep needs clock sim' in lines[0]


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
        record = glove.run(3.0)  # waits for one answer per state: none missing, none extra
    finally:
        stop(controller)
    assert len(record.t) == len(record.command) == 300
    np.testing.assert_allclose(record.forces[-1], [0.1, 0.1, 0.1], atol=0.01)


def test_a_lockstep_force_controller_answers_states_only_once_it_hears_an_estimator(probe):
    # Else the estimate of the first state it is sent could leave before it can hear it, and
    # the glove would wait for that answer forever.
    node = InProcessNode(
        PressureCommand, {'lockstep': 'true', 'mode': 'force', 'use_sim_time': 'true'}, probe
    )
    try:
        node.node.listen_once_estimated()
        assert 'joint_states' not in node.subscriptions()
        estimator = node.node.create_publisher(Float64MultiArray, 'estimated_contact_forces', 10)
        deadline = time.monotonic() + 10.0
        while 'joint_states' not in node.subscriptions() and time.monotonic() < deadline:
            node.node.listen_once_estimated()
            time.sleep(0.01)
        assert 'joint_states' in node.subscriptions()
        assert estimator.get_subscription_count() == 1
    finally:
        node.close()


def service_callback(node: InProcessNode, name: str):
    """The callback of the node's service ``name`` (relative name)."""
    return next(s.callback for s in node.node.services if s.service_name.endswith(f'/{name}'))


@pytest.mark.parametrize('service', ['step', 'reset'])
def test_a_service_step_waits_for_new_readers_in_the_loop_not_in_the_callback(probe, service):
    # The step is taken once the outputs have matched every subscriber the graph knows (here:
    # not yet, then yes). The callback answers at once instead of sleeping until then, so a
    # hand's other fingers go on stepping meanwhile.
    node = InProcessNode(Plant, {'clock': 'sim', 'start_paused': 'true'}, probe)
    try:
        matched = False
        node.node.readers_matched = lambda: matched
        answer = service_callback(node, service)(Trigger.Request(), Trigger.Response())
        assert answer.success
        assert 'once every new subscriber of the outputs is matched' in answer.message
        node.fire_timers()
        assert 'joint_states' not in node.take()
        matched = True
        node.fire_timers()
        assert len(node.take()['joint_states']) == 1
        node.fire_timers()  # paused: nothing more
        assert 'joint_states' not in node.take()
    finally:
        node.close()


def test_a_service_step_goes_on_when_the_readers_never_match(probe, monkeypatch):
    monkeypatch.setattr(sim_time, 'READER_WAIT', 0.0)
    node = InProcessNode(Plant, {'clock': 'sim', 'start_paused': 'true'}, probe)
    try:
        node.node.readers_matched = lambda: False
        for _ in range(2):
            service_callback(node, 'step')(Trigger.Request(), Trigger.Response())
        node.fire_timers()
        assert [m.header.stamp.nanosec for m in node.take()['joint_states']] == [
            step_time_ns(k, RATE) for k in (1, 2)
        ]
    finally:
        node.close()
