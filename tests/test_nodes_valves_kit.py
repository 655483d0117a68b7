"""Valves end to end over DDS: the testing kit's plant with ``actuation='valves'`` in lockstep
with a real ``pressure_command`` process with ``output:=valves`` (docs/spec/ros.md, "Valves").

Lockstep makes the run exact, so it is checked twice in this process, bit for bit, with no
wall-clock wait: the plant's states are ``GloveSimulation(actuation='valves')`` fed the recorded
openings, and the recorded openings are the in-process controller (the mode behind the safety
limiter, then :class:`exodigit_model.control.ValveLoop`) fed the recorded states.
"""

import subprocess
import sys

import numpy as np
import pytest
from exodigit_model.control import (
    CommandLoop,
    Feedback,
    SafetyLimiter,
    SafetyLimits,
    Sine,
    ValveLoop,
    ValveLoopSettings,
)
from exodigit_model.stepping.settings import VENT
from exodigit_nodes.testing import GloveSim
from ros_harness import stop_process

from exodigit_model import GloveSimulation, SimulationSettings

SINE = {'sine_low': 0.0, 'sine_high': 40e3, 'sine_period': 1.0}
"""pressure_command's mode: one rise and fall of 40 kPa a second, so that a 1 s run fills,
holds and vents every chamber."""
STEPS = 100
"""Steps of the run (1 s at the plant's 100 Hz)."""


NANOSECONDS = 10**9
"""pressure_command counts time in the stamps' whole nanoseconds: session time and step are
differences of them, divided by 10⁹ only then."""


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    """The kit's rest state and a 1 s lockstep run with pressure_command (output:=valves)."""
    with GloveSim(actuation='valves', log_dir=tmp_path_factory.mktemp('valves_kit')) as glove:
        rest = glove.state
        parameters = {'mode': 'sine', **SINE, 'output': 'valves', 'lockstep': True}
        controller = subprocess.Popen(
            [
                sys.executable,
                '-m',
                'exodigit_nodes.nodes.pressure_command',
                '--ros-args',
                *(
                    item
                    for name, value in parameters.items()
                    for item in ('-p', f'{name}:={value}')
                ),
                *('-p', 'use_sim_time:=true', '-r', f'__ns:={glove.namespace}'),
            ],
            env=glove.env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        try:
            record = glove.run(STEPS / glove.rate_hz)
        finally:
            stop_process(controller)
    return rest, record


def test_the_valve_plant_steps_as_the_in_process_simulation_fed_the_recorded_openings(run):
    rest, record = run
    assert record.command.shape == (STEPS, 6)
    simulation = GloveSimulation(
        settings=SimulationSettings(pressure_time_constant=0.0), actuation='valves'
    )
    simulation.reset()
    # The kit's reset publishes the rest state as a step; a run starts with one more step: both
    # vent (no command yet), and the first of them is the state the kit keeps as its rest.
    np.testing.assert_array_equal(simulation.step(VENT).q_measured, rest.q)
    state = simulation.step(VENT)
    for k in range(STEPS):
        assert record.t[k] == state.time_ns / 1e9
        np.testing.assert_array_equal(record.q[k], state.q_measured)
        np.testing.assert_array_equal(record.pressure[k], state.pressure_measured)
        np.testing.assert_array_equal(record.forces[k], state.forces)
        np.testing.assert_array_equal(record.lengths[k], state.lengths)
        state = simulation.step(record.command[k])  # the answer to state k makes state k + 1
    # The run filled and vented every chamber through its valves (else the check is empty).
    assert np.all(record.pressure.max(axis=0) > 30e3)
    assert np.all(record.command[:, :3].max(axis=0) > 0.0)
    assert np.all(record.command[:, 3:].max(axis=0) > 0.0)


def test_pressure_command_answers_each_state_with_the_in_process_loop_s_openings(run):
    _, record = run
    loop = CommandLoop(Sine(*SINE.values()), SafetyLimiter(SafetyLimits()))
    valves = ValveLoop(ValveLoopSettings())
    times = [round(t * NANOSECONDS) for t in record.t]
    dt = 1.0 / 100.0  # its first answer's step: pressure_command's period (rate_hz)
    for k in range(STEPS):
        if k > 0:
            dt = (times[k] - times[k - 1]) / NANOSECONDS
        t = (times[k] - times[0]) / NANOSECONDS
        target = loop.command(t, dt, Feedback(record.q[k], None)).pressure
        openings = valves.openings(target, record.pressure[k], dt)
        np.testing.assert_array_equal(record.command[k], openings, err_msg=f'step {k}')
