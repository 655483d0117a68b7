"""An extensible glove (docs/spec/model.md §12): ``segment_lengths`` through the kit.

The MCP segment has no separate strain-limiting layer (``layer_axial_stiffness: 0.0``), the PIP
and DIP keep the default ``.inf`` (inextensible). With the kit's default chamber lag 0 each
published state is the coupled solve at its command, so the lengths are compared with an
independent ``GloveModel(load_params(file)).solve(p)``. One glove (with its estimator) serves
the module, put to rest before each test. The markers drawn at the published lengths are
checked on a plant built in process (`reliability_inprocess.InProcessNode`)."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from exodigit_nodes.nodes.markers import ARC_SAMPLES
from exodigit_nodes.nodes.plant import Plant
from exodigit_nodes.testing import GloveSim
from exodigit_nodes.testing.client import DEFAULT_TIMEOUT
from lockstep_controller import command_at
from reliability_inprocess import InProcessNode
from ros_harness import stop_process, wait_until
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from exodigit_model import GloveModel, load_params

CONTROLLER = Path(__file__).with_name('lockstep_controller.py')
#: Length tolerance of the plant against an independent solve, m.
LENGTH_TOLERANCE = 1e-9
#: Angle tolerance of the plant against an independent solve, rad.
ANGLE_TOLERANCE = 1e-9
#: Relative tolerance of closed-form geometry (floating-point rounding only).
EXACT = 1e-12
COMMANDS = [
    [10e3, 10e3, 10e3],
    [30e3, 20e3, 10e3],
    [50e3, 40e3, 30e3],
    [0.0, 0.0, 0.0],
    [20e3, 0.0, 40e3],
]
"""Pressures stepped through, Pa (a return to zero and an MCP-only-ish case included)."""
EXTENSIBLE_MCP = """\
exo_digit:
  segments:
    - {layer_axial_stiffness: 0.0}   # N per unit strain: MCP with no layer, docs/spec/model.md §12
    - {}
    - {}
"""


@pytest.fixture(scope='module')
def params_file(tmp_path_factory):
    path = tmp_path_factory.mktemp('extensible') / 'extensible_mcp.yaml'
    path.write_text(EXTENSIBLE_MCP)
    return path


@pytest.fixture(scope='module')
def model(params_file):
    return GloveModel(load_params(params_file))


@pytest.fixture(scope='module')
def rest(model):
    return np.array([segment.arc_length for segment in model.params.exo_digit.segments])


@pytest.fixture(scope='module')
def shared_glove(params_file, tmp_path_factory):
    logs = tmp_path_factory.mktemp('logs')
    with GloveSim(params_file, estimator=True, log_dir=logs) as glove:
        yield glove


@pytest.fixture
def glove(shared_glove):
    """The shared glove at rest, no controller of an earlier test left on the graph."""
    # A stopped controller leaves the graph a moment later; until then step() refuses to step.
    assert wait_until(lambda: not shared_glove._node.other_controllers(), DEFAULT_TIMEOUT)
    shared_glove.reset()
    return shared_glove


def assert_lengths_of_the_solve(lengths, solution, rest):
    """Lengths as solved independently; the inextensible segments exactly at rest."""
    np.testing.assert_allclose(lengths, solution.lengths, rtol=0.0, atol=LENGTH_TOLERANCE)
    np.testing.assert_array_equal(lengths[1:], rest[1:])


def run_with_controller(glove, duration):
    """``glove.run(duration)`` answered by the lockstep controller node; its record."""
    controller = subprocess.Popen(
        [sys.executable, str(CONTROLLER), '--ros-args', '-r', f'__ns:={glove.namespace}'],
        env=glove.env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        return glove.run(duration)
    finally:
        stop_process(controller)


def test_the_plant_publishes_the_segment_lengths_of_the_solve(glove, model, rest):
    np.testing.assert_array_equal(glove.state.lengths, rest)
    for command in COMMANDS:
        state = glove.step(command)
        np.testing.assert_array_equal(state.pressure, command)  # no chamber lag, no noise
        solution = model.solve(command)
        assert solution.converged
        assert_lengths_of_the_solve(state.lengths, solution, rest)
        np.testing.assert_allclose(state.q, solution.q, rtol=0.0, atol=ANGLE_TOLERANCE)
        if command[0] > 0.0:
            assert state.lengths[0] > rest[0] + 1e-4  # the MCP stretches under pressure
    np.testing.assert_array_equal(glove.reset().lengths, rest)


def test_markers_draw_the_arcs_at_the_published_lengths(probe, params_file, rest):
    # The plant built in process, stepped by its step service; someone listens to the markers
    # (the one input condition stubbed), so its marker timer draws the state just stepped.
    node = InProcessNode(
        Plant,
        {'params_file': str(params_file), 'clock': 'sim', 'start_paused': 'true'}
        | {'pressure_time_constant': '0.0', 'marker_rate_hz': '20.0'},
        probe,
    )
    try:
        node.node.marker_publisher.get_subscription_count = lambda: 1
        node.deliver('pressure_command', Float64MultiArray(data=[40e3, 40e3, 40e3]))
        step = next(s.callback for s in node.node.services if s.service_name.endswith('/step'))
        assert step(Trigger.Request(), Trigger.Response()).success
        node.node.publish_markers()
        published = node.take()
    finally:
        node.close()
    lengths = published['segment_lengths'][-1].data
    angles = published['joint_states'][-1].position
    assert lengths[0] > rest[0] + 1e-4
    array = published['markers'][-1]
    assert array.markers[0].header.stamp == published['joint_states'][-1].header.stamp
    # The backbone: base block, then each arc (ARC_SAMPLES points) and the two ends of its block.
    points = np.array([[p.x, p.y] for p in array.markers[0].points])
    for k, (length, angle) in enumerate(zip(lengths, angles, strict=True)):
        arc = points[2 + k * (ARC_SAMPLES + 2) :][:ARC_SAMPLES]
        chord = np.linalg.norm(arc[-1] - arc[0])
        # A circular arc of length ℓ bent by q has the chord 2ℓ·sin(q/2)/q (closed form).
        assert chord == pytest.approx(2.0 * length * math.sin(angle / 2.0) / angle, rel=EXACT)


def test_the_estimator_recovers_the_contact_forces_of_an_extensible_glove(glove, model):
    # The robot-side estimate from the published q and p, solved for its own bottom strains
    # (docs/spec/model.md §12), is the plant's contact force when both run the same glove.
    for command in COMMANDS[:3]:
        state = glove.step(command)
        expected = model.solve(command)
        assert expected.converged
        np.testing.assert_allclose(state.estimated_forces, expected.forces, atol=1e-8)


def test_a_run_records_each_steps_lengths_and_after_it_each_step_has_its_own_estimate(
    glove, model, rest
):
    # One controller run for both: the run's record holds the lengths of each step; and the
    # estimator answers the run's states too, so its late answers must not be paired with the
    # steps taken after the run (the kit once handed them out as those steps' estimates).
    record = run_with_controller(glove, 0.3)
    assert record.lengths.shape == (30, 3)
    assert record.lengths[:, 0].max() > rest[0] + 1e-4  # the run pressurised the MCP
    for t, pressure, lengths, command in zip(
        record.t, record.pressure, record.lengths, record.command, strict=True
    ):
        np.testing.assert_array_equal(command, command_at(t))
        assert_lengths_of_the_solve(lengths, model.solve(pressure), rest)
    assert wait_until(lambda: not glove._node.other_controllers(), DEFAULT_TIMEOUT)
    glove.reset()
    for command in COMMANDS[:3]:
        state = glove.step(command)
        np.testing.assert_allclose(state.estimated_forces, model.solve(command).forces, atol=1e-8)
