"""The reference controllers against every patient preset (issue 9), in lockstep simulated time.

The controller assumes the nominal finger (its feed-forward is the nominal model) while the
simulated glove holds the preset patient; each state is answered with one command, exactly as
``pressure_command`` does in lockstep (its ``CommandLoop``), against the stepper the plant runs
(``GloveSimulation``, with the plant's default chamber lag). Targets are states the patient can
be held at (a static solve of the patient's model at moderate pressures), so every preset has one.
Over DDS, the same loop with the node and the plant is checked in test_nodes_sim_time.py.
"""

import math

import numpy as np
import pytest
from exodigit_model.control import (
    CommandLoop,
    Feedback,
    ForceController,
    PositionController,
    SafetyLimiter,
)
from exodigit_nodes.logic.command_settings import safety_limits
from exodigit_nodes.nodes.catalog import PRESSURE_COMMAND_NODE

from exodigit_model import (
    PATIENT_PRESETS,
    GloveModel,
    GloveSimulation,
    SimulationSettings,
    load_params,
    patient_file,
)

NOMINAL = GloveModel(load_params())
DEFAULTS = PRESSURE_COMMAND_NODE.table.defaults()
LIMITS = safety_limits(DEFAULTS)
SECONDS = 5.0
#: Steady-state errors accepted (issue 9): angle, rad; contact force, N.
ANGLE_ERROR = math.radians(1.0)
FORCE_ERROR = 0.02
#: Pressures of the held states the targets come from, Pa (MCP, PIP, DIP).
HOLD = np.array([35e3, 30e3, 25e3])


def patient_model(name):
    return GloveModel(load_params(patient_file(name)))


def run(loop, patient, *, estimate_forces):
    """Step the patient's glove answering each state; the trajectory of states and commands."""
    simulation = GloveSimulation(patient, SimulationSettings())
    state = simulation.state
    states, commands = [], []
    for _ in range(round(SECONDS * simulation.settings.rate_hz)):
        forces = NOMINAL.estimate_forces(state.q_measured, state.pressure_measured)
        feedback = Feedback(state.q_measured, forces if estimate_forces else None)
        command = loop.command(state.t, simulation.period, feedback)
        state = simulation.step(command.pressure)
        states.append(state)
        commands.append(command.pressure)
    return states, np.array(commands)


def assert_within_the_safety_limits(states, commands):
    assert (commands >= 0.0).all() and (commands <= LIMITS.max_pressure).all()
    rate = np.abs(np.diff(commands, axis=0)).max() / 0.01
    assert rate <= LIMITS.max_pressure_rate * (1 + 1e-9)
    angles = np.array([s.q for s in states])
    assert (angles >= LIMITS.joint_lower).all() and (angles <= LIMITS.joint_upper).all()
    forces = np.array([s.forces for s in states])
    assert np.abs(forces).max() <= LIMITS.max_contact_force
    assert all(s.converged and s.in_range_of_motion for s in states)


@pytest.mark.parametrize('preset', PATIENT_PRESETS)
def test_position_mode_reaches_its_targets_on_every_patient(preset):
    patient = patient_model(preset)
    targets = patient.solve(HOLD).q
    controller = PositionController(
        NOMINAL, targets, DEFAULTS['position_kp'], DEFAULTS['position_ki']
    )
    states, commands = run(
        CommandLoop(controller, SafetyLimiter(LIMITS)), patient, estimate_forces=False
    )
    assert np.abs(states[-1].q - targets).max() <= ANGLE_ERROR, np.degrees(states[-1].q - targets)
    assert_within_the_safety_limits(states, commands)


@pytest.mark.parametrize('preset', PATIENT_PRESETS)
def test_force_mode_reaches_its_targets_on_every_patient(preset):
    patient = patient_model(preset)
    targets = patient.solve(HOLD).forces
    controller = ForceController(NOMINAL, targets, DEFAULTS['force_kp'], DEFAULTS['force_ki'])
    states, commands = run(
        CommandLoop(controller, SafetyLimiter(LIMITS)), patient, estimate_forces=True
    )
    assert np.abs(states[-1].forces - targets).max() <= FORCE_ERROR, states[-1].forces - targets
    assert_within_the_safety_limits(states, commands)
