"""The plant's own logic, in process: watchdog, reset, malformed commands, saturation,
parameters and joint names.

Each test builds a ``Plant`` in this process (`reliability_inprocess.InProcessNode`: no DDS
traffic) on the wall clock, its default, but with ``use_sim_time`` and ``/clock`` delivered by
hand: the test says what time it is, so the watchdog is checked to the step, with no waiting.
A step is one call of the plant's wall timer callback.

Covered elsewhere, not repeated here: every malformed command counted and a valid one solved
as the model solves it (hypothesis, tests/test_reliability_callbacks.py), every bad parameter
value refused naming it (tests/test_reliability_params.py), the plant's topics and services
over DDS and its Ctrl-C (tests/test_nodes_glove.py).
"""

import math

import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_nodes.nodes.plant import Plant
from rclpy.parameter import Parameter
from reliability_inprocess import InProcessNode, non_finite
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

RATE_HZ = 100.0
COMMAND_TIMEOUT = 0.3  # s
MAX_SUPPLY = 100e3  # Pa
#: Simulated time at which each test starts, s (the clock's origin is of no consequence).
START = 100.0
PARAMETERS = {
    'pressure_time_constant': '0.0',
    'command_timeout': str(COMMAND_TIMEOUT),
    'max_supply_pressure': str(MAX_SUPPLY),
    'rate_hz': str(RATE_HZ),
    'joint_prefix': 'left_index_',
    'use_sim_time': 'true',
}


class TimedPlant:
    """An in-process plant and the time the test gives it."""

    def __init__(self, probe) -> None:
        self.node = InProcessNode(Plant, PARAMETERS, probe)
        self.t = START
        self.at(START)

    def at(self, t: float) -> None:
        """Set the plant's clock to ``t`` (s) as a /clock message would."""
        self.t = t
        seconds, nanoseconds = divmod(round(t * 1e9), 10**9)
        self.node.deliver('clock', Clock(clock=Time(sec=seconds, nanosec=nanoseconds)))

    def command(self, values) -> None:
        self.node.deliver('pressure_command', Float64MultiArray(data=[float(v) for v in values]))

    def step(self) -> dict[str, list]:
        """One period later, one step of the plant; what it published."""
        self.at(self.t + 1.0 / RATE_HZ)
        self.node.node.on_wall_timer()
        return self.node.take()

    def pressure(self) -> list[float]:
        """The chamber pressure of one more step, Pa."""
        return list(self.step()['chamber_pressure'][-1].data)

    def report(self):
        """The plant's /diagnostics status now: (status, key -> value)."""
        self.node.node.report()
        status = self.node.take()['/diagnostics'][-1].status[0]
        return status, {kv.key: kv.value for kv in status.values}


@pytest.fixture
def plant(probe):
    made = TimedPlant(probe)
    yield made
    made.node.close()


def test_joint_names_carry_the_prefix(plant):
    assert list(plant.step()['joint_states'][-1].name) == [
        'left_index_mcp',
        'left_index_pip',
        'left_index_dip',
    ]


def test_the_watchdog_vents_from_the_first_step_past_the_timeout_and_says_so(plant):
    plant.command([40e3] * 3)
    sent = plant.t
    held, vented = [], []
    while plant.t < sent + COMMAND_TIMEOUT + 0.1:
        pressure = plant.pressure()
        (held if pressure == [40e3] * 3 else vented).append((plant.t - sent, pressure))
    # Up to the timeout the command holds, after it the chambers are vented; never back.
    assert held and all(age <= COMMAND_TIMEOUT + 1e-9 for age, _ in held), held
    assert vented and all(p == [0.0] * 3 for _, p in vented), vented
    assert all(age > COMMAND_TIMEOUT - 1e-9 for age, _ in vented), vented
    assert vented[0][0] <= COMMAND_TIMEOUT + 1.0 / RATE_HZ + 1e-9
    status, values = plant.report()
    assert status.level == DiagnosticStatus.WARN and 'vented' in status.message
    assert values['watchdog'] == 'venting' and values['watchdog trips'] == '1'
    plant.command([10e3] * 3)  # a command again ends the venting
    assert plant.pressure() == [10e3] * 3
    _, values = plant.report()
    assert values['watchdog'] == 'ok'


def test_reset_puts_pressures_and_angles_back_to_zero(plant):
    # With a chamber lag, so that only a reset (not venting alone) gives zero at the next step.
    lag = Parameter('pressure_time_constant', value=0.05)
    assert plant.node.node.set_parameters([lag])[0].successful
    plant.command([50e3] * 3)
    for _ in range(20):
        published = plant.step()
    assert published['joint_states'][-1].position[0] > 0.3
    service = next(s for s in plant.node.node.services if s.service_name.endswith('/reset'))
    assert service.callback(Trigger.Request(), Trigger.Response()).success
    for _ in range(3):  # until a new command comes
        published = plant.step()
        assert list(published['joint_states'][-1].position) == [0.0] * 3
        assert list(published['chamber_pressure'][-1].data) == [0.0] * 3


@pytest.mark.parametrize(
    'bad',
    [[], [1e3], [1e3, 2e3], [1e3] * 4, [1e3] * 1000, [math.nan] * 3, [1e3, math.inf, 1e3]],
    ids=['empty', 'one', 'two', 'four', 'thousand', 'nan', 'inf'],
)
def test_a_malformed_command_is_dropped_counted_and_the_last_valid_one_held(plant, bad):
    plant.command([20e3] * 3)
    assert plant.pressure() == [20e3] * 3
    status, _ = plant.report()
    assert status.level == DiagnosticStatus.OK, status.message
    plant.command(bad)
    published = plant.step()
    assert list(published['chamber_pressure'][-1].data) == [20e3] * 3
    # the plant's record of the refused command: the one it keeps applying
    assert [list(m.data) for m in published['applied_command']] == [[20e3] * 3]
    assert non_finite(published) == []
    status, values = plant.report()
    assert sum(int(v) for k, v in values.items() if k.startswith('rejected')) == 1
    assert status.level == DiagnosticStatus.WARN and 'input messages dropped' in status.message


def test_pressures_outside_the_supply_are_saturated_and_reported(plant):
    plant.command([-5e3, 50e3, 5e5])
    assert plant.pressure() == [0.0, 50e3, MAX_SUPPLY]
    status, values = plant.report()
    assert status.level == DiagnosticStatus.WARN and 'saturated' in status.message
    assert int(values['saturated below 0']) == 1 and int(values['saturated above supply']) == 1


def test_a_good_parameter_set_is_applied_from_the_next_step(plant):
    plant.command([50e3, 10e3, 50e3])
    assert plant.pressure() == [50e3, 10e3, 50e3]
    supply = Parameter('max_supply_pressure', value=30e3)
    assert plant.node.node.set_parameters([supply])[0].successful
    assert plant.pressure() == [30e3, 10e3, 30e3]
