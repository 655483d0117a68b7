"""The plant alone, driven from the probe: watchdog, reset, malformed commands, saturation,
parameters, markers and Ctrl-C. One plant process (no lag, no noise) serves the module: what a
test sets is put back after it, and the test of Ctrl-C stops a plant of its own."""

import math
import os
import signal
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from ros_harness import STOP_TIMEOUT, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from exodigit_model import GloveModel, load_params

NS = f'/nodes_plant_{os.getpid()}'  # unique per session
RATE_HZ = 100.0
COMMAND_TIMEOUT = 0.3  # s
MAX_SUPPLY = 100e3  # Pa
#: Angle tolerance against an independent solve, rad.
ANGLE_TOLERANCE = 1e-9
#: Allowance for the command's trip from the probe into the plant's callback, s.
DELIVERY = 0.05
#: The plant's /diagnostics period here, s (the default is 1 s).
REPORT_PERIOD = 0.1


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


def start_plant(launcher, probe, namespace):
    """A plant in ``namespace``, once it publishes: (process, command publisher, inboxes)."""
    inboxes = {
        'joint_states': probe.subscribe(f'{namespace}/joint_states', JointState, with_info=True),
        'chamber_pressure': probe.subscribe(
            f'{namespace}/chamber_pressure', Float64MultiArray, with_info=True
        ),
        'contact_forces': probe.subscribe(f'{namespace}/contact_forces', Float64MultiArray),
        'diagnostics': probe.subscribe('/diagnostics', DiagnosticArray),
    }
    node = launcher.start(
        'plant',
        {
            'pressure_time_constant': 0.0,
            'command_timeout': COMMAND_TIMEOUT,
            'max_supply_pressure': MAX_SUPPLY,
            'rate_hz': RATE_HZ,
            'joint_prefix': 'left_index_',
            'diagnostic_period': REPORT_PERIOD,
        },
        namespace=namespace,
    )
    command = probe.publisher(f'{namespace}/pressure_command', Float64MultiArray)
    assert inboxes['joint_states'].wait_count(1, timeout=30.0), node.stderr()
    return node, command, inboxes


@pytest.fixture(scope='module')
def plant(launcher, probe):
    return start_plant(launcher, probe, NS)


@pytest.fixture
def supply_restored(plant, probe):
    with probe.parameters_restored(f'{NS}/plant', ['max_supply_pressure']):
        yield


def send(publisher, values):
    publisher.publish(Float64MultiArray(data=[float(v) for v in values]))


def pressure_reaches(inboxes, values, since):
    """The first chamber_pressure after ``since`` that is exactly ``values`` (None on timeout).

    Exactly: a message still carrying the command of the test before does not count.
    """
    return inboxes['chamber_pressure'].wait_for(lambda m: list(m.data) == values, 5.0, since)


def plant_status(inboxes, since=-1.0):
    """The plant's DiagnosticStatus messages (newest last) that arrived after ``since``."""
    return [
        status
        for array in inboxes['diagnostics'].messages(since)
        for status in array.status
        if status.name == f'{NS}/plant'
    ]


def value(status, key):
    return next(kv.value for kv in status.values if kv.key == key)


def all_outputs_finite(inboxes):
    for message in inboxes['joint_states'].messages():
        assert all(
            math.isfinite(v) for v in (*message.position, *message.velocity, *message.effort)
        )
    for topic in ('chamber_pressure', 'contact_forces'):
        assert all(math.isfinite(v) for m in inboxes[topic].messages() for v in m.data)


def test_joint_names_carry_the_prefix(plant):
    _, _, inboxes = plant
    assert list(inboxes['joint_states'].latest().name) == [
        'left_index_mcp',
        'left_index_pip',
        'left_index_dip',
    ]


def test_a_command_moves_the_glove_to_the_model_solution(plant, model):
    _, command, inboxes = plant
    mark = time.monotonic()
    send(command, [30e3, 20e3, 10e3])
    assert pressure_reaches(inboxes, [30e3, 20e3, 10e3], mark), inboxes[
        'chamber_pressure'
    ].latest()
    expected = model.solve([30e3, 20e3, 10e3]).q
    state = inboxes['joint_states'].wait_for(
        lambda m: np.abs(np.array(m.position) - expected).max() < ANGLE_TOLERANCE, 5.0, mark
    )
    assert state is not None


def test_watchdog_vents_within_the_timeout_plus_two_cycles(plant):
    _, command, inboxes = plant
    mark = time.monotonic()
    sent_at = time.time()
    send(command, [40e3, 40e3, 40e3])
    pressures = inboxes['chamber_pressure']
    held = pressure_reaches(inboxes, [40e3] * 3, mark)
    assert held is not None

    def first_vented():  # source time of the first vented step after the command, s
        records = [(m, info) for _, m, info in pressures.records()]
        start = next(i for i, (m, _) in enumerate(records) if m is held)
        return next(
            (
                i['source_timestamp'] * 1e-9
                for m, i in records[start:]
                if list(m.data) == [0.0] * 3
            ),
            None,
        )

    vented = wait_until(first_vented, 5.0)
    assert vented is not None
    delay = vented - sent_at
    assert COMMAND_TIMEOUT <= delay <= COMMAND_TIMEOUT + 2.0 / RATE_HZ + DELIVERY, delay
    status = wait_until(
        lambda: [s for s in plant_status(inboxes, mark) if value(s, 'watchdog') == 'venting'], 3.0
    )
    assert status and status[-1].level == DiagnosticStatus.WARN
    assert 'vented' in status[-1].message


def test_reset_puts_pressures_and_angles_back_to_zero(plant, probe):
    _, command, inboxes = plant
    mark = time.monotonic()
    send(command, [50e3, 50e3, 50e3])
    assert inboxes['joint_states'].wait_for(lambda m: m.position[0] > 0.3, 5.0, mark) is not None
    response = probe.call(f'{NS}/reset', Trigger, Trigger.Request())
    assert response.success, response.message
    after = time.monotonic()
    assert inboxes['joint_states'].wait_count(inboxes['joint_states'].count() + 5, 5.0)
    states = inboxes['joint_states'].messages(after)
    assert states and all(list(m.position) == [0.0, 0.0, 0.0] for m in states), [
        (m.header.stamp.sec, m.header.stamp.nanosec, list(m.position)) for m in states
    ]
    pressures = inboxes['chamber_pressure'].messages(after)
    assert pressures and all(list(m.data) == [0.0, 0.0, 0.0] for m in pressures)


@pytest.mark.parametrize(
    'bad',
    [[], [1e3], [1e3, 2e3], [1e3] * 4, [1e3] * 1000, [math.nan] * 3, [1e3, math.inf, 1e3]],
    ids=['empty', 'one', 'two', 'four', 'thousand', 'nan', 'inf'],
)
def test_a_malformed_command_is_dropped_and_counted(plant, bad):
    _, command, inboxes = plant
    mark = time.monotonic()
    send(command, [20e3, 20e3, 20e3])
    assert pressure_reaches(inboxes, [20e3] * 3, mark)
    reported = wait_until(lambda: plant_status(inboxes), 5.0)
    assert reported, 'no diagnostics from the plant'
    before = reported[-1]
    counted_before = sum(int(kv.value) for kv in before.values if kv.key.startswith('rejected'))
    send(command, bad)

    def counted():
        return [
            s
            for s in plant_status(inboxes, mark)
            if sum(int(kv.value) for kv in s.values if kv.key.startswith('rejected'))
            == counted_before + 1
        ]

    reports = wait_until(counted, 3.0)
    assert reports
    assert (
        reports[0].level == DiagnosticStatus.WARN
        and 'input messages dropped' in reports[0].message
    )
    # Until the watchdog vents, the plant holds the last valid command.
    held = [list(m.data) for m in inboxes['chamber_pressure'].messages(mark)]
    assert all(p in ([20e3] * 3, [0.0] * 3) for p in held[held.index([20e3] * 3) :])
    all_outputs_finite(inboxes)


def test_pressures_outside_the_supply_are_saturated_and_reported(plant):
    _, command, inboxes = plant
    mark = time.monotonic()
    send(command, [-5e3, 50e3, 5e5])
    saturated = pressure_reaches(inboxes, [0.0, 50e3, MAX_SUPPLY], mark)
    assert saturated, inboxes['chamber_pressure'].latest()
    status = wait_until(
        lambda: [
            s for s in plant_status(inboxes, mark) if int(value(s, 'saturated above supply')) > 0
        ],
        3.0,
    )
    assert status and int(value(status[-1], 'saturated below 0')) > 0


@pytest.mark.parametrize(
    ('values', 'named'),
    [
        ({'rate_hz': 10.0}, 'rate_hz'),
        ({'pressure_time_constant': -1.0}, 'pressure_time_constant'),
        ({'max_supply_pressure': math.inf}, 'max_supply_pressure'),
        ({'command_timeout': 'long'}, 'command_timeout'),
        ({'seed': 3}, 'seed'),
        ({'angle_noise_std': [0.1]}, 'angle_noise_std'),
        ({'joint_prefix': 'x_'}, 'joint_prefix'),
    ],
)
def test_a_bad_parameter_set_is_refused_naming_it_and_the_plant_runs_on(
    plant, probe, values, named
):
    node, _, inboxes = plant
    name = next(iter(values))
    before = probe.get_parameters(f'{NS}/plant', [name])
    result = probe.set_parameters(f'{NS}/plant', values)[0]
    assert not result.successful and named in result.reason
    assert probe.get_parameters(f'{NS}/plant', [name]) == before
    assert inboxes['joint_states'].wait_count(inboxes['joint_states'].count() + 3, 5.0)
    assert node.alive()


def test_a_good_parameter_set_is_applied_from_the_next_step(plant, probe, supply_restored):
    _, command, inboxes = plant
    result = probe.set_parameters(f'{NS}/plant', {'max_supply_pressure': 30e3})[0]
    assert result.successful, result.reason
    mark = time.monotonic()
    send(command, [50e3, 10e3, 50e3])
    capped = pressure_reaches(inboxes, [30e3, 10e3, 30e3], mark)
    assert capped, inboxes['chamber_pressure'].latest()


@pytest.fixture
def own_plant(launcher, probe):
    """A plant for one test alone (which may stop it); stopped after it if still running."""
    node, _, _ = start_plant(launcher, probe, f'{NS}_own')
    yield node
    node.stop()


def test_sigint_stops_the_plant_within_2_s(own_plant):
    node = own_plant
    started = time.monotonic()
    node.signal(signal.SIGINT)
    assert node.wait(STOP_TIMEOUT) == 0, node.stderr()
    assert time.monotonic() - started < STOP_TIMEOUT
    assert 'Traceback' not in node.stderr()
