"""Solver faults in the plant: parameter files at the edge of validity, and random valid ones.

The plant class runs in-process (`reliability_inprocess.InProcessNode`, chamber lag off) with a
model file written for each case; the test is its pressure_command publisher and fires its
timers by hand. Cases, each checked against an independent `GloveModel.solve`:

- a very soft silicone (C1 = 1 Pa) at full supply: the coupled solve fails; the plant keeps the
  last good state, says so in a WARN diagnostic with the residual, and recovers on the next
  command it can solve;
- a soft silicone bent beyond the validated stretch 1.5: the plant publishes the state and a
  WARN that it is outside the valid range;
- a very stiff finger: the glove barely moves, and the state is still the solve;
- commands far above the supply: saturated, reported, state = solve at the supply pressure.

Hypothesis then builds random valid parameter files and drives random commands through the
plant's step: nothing it publishes is ever non-finite.
"""

import numpy as np
import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_nodes.nodes.plant import Plant
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from reliability_inprocess import InProcessNode, non_finite
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

SUPPLY = 100e3
ANGLE_TOLERANCE = 1e-9
#: Commands the very soft glove can solve, and one it cannot, Pa.
SOLVABLE = 5e3
UNSOLVABLE = 100e3
RECOVERY = 2e3
EDGE_FILES = {
    'very_soft': {'material': {'c1': 1.0, 'c2': 0.0, 'c3': 0.0}},
    'soft': {'material': {'c1': 1e3, 'c2': 0.0, 'c3': 0.0}},
    'stiff_finger': {'finger': {'joints': [{'stiffness': 100.0}] * 3}},
}


def write(tmp_path, name: str, data: dict) -> str:
    path = tmp_path / f'{name}.yaml'
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.fixture
def plant_for(tmp_path, probe):
    made = []

    def build(name: str, data: dict) -> tuple[InProcessNode, GloveModel]:
        """A plant on the model file ``data`` (the previous one is closed: one at a time)."""
        while made:
            made.pop().close()
        path = write(tmp_path, name, data)
        overrides = {
            'params_file': path,
            'pressure_time_constant': '0.0',
            'max_supply_pressure': str(SUPPLY),
        }
        node = InProcessNode(Plant, overrides, probe)
        made.append(node)
        return node, GloveModel(load_params(path))

    yield build
    while made:
        made.pop().close()


def step(node: InProcessNode, pressure: float, cycles: int = 1) -> dict:
    node.deliver('pressure_command', Float64MultiArray(data=[pressure] * 3))
    for _ in range(cycles):
        node.fire_timers()
    published = node.take()
    assert non_finite(published) == []
    return published


def status(published: dict) -> tuple[DiagnosticStatus, dict]:
    report = published['/diagnostics'][-1].status[0]
    return report, {kv.key: kv.value for kv in report.values}


def test_failed_solve_keeps_last_good_state_warns_with_residual_and_recovers(plant_for):
    node, model = plant_for('very_soft', EDGE_FILES['very_soft'])
    good = model.solve(np.full(3, SOLVABLE))
    bad = model.solve(np.full(3, UNSOLVABLE), q0=good.q)
    assert good.converged and not bad.converged, 'case no longer at the edge: pick another'
    published = step(node, SOLVABLE)
    np.testing.assert_allclose(published['joint_states'][-1].position, good.q, atol=1e-9)
    published = step(node, UNSOLVABLE, cycles=3)
    for state in published['joint_states']:
        np.testing.assert_allclose(state.position, good.q, atol=ANGLE_TOLERANCE)
    np.testing.assert_array_equal(published['chamber_pressure'][-1].data, [UNSOLVABLE] * 3)
    report, values = status(published)
    assert report.level == DiagnosticStatus.WARN
    assert 'did not converge' in report.message and 'residual' in report.message
    assert int(values['solver failures']) >= 3
    published = step(node, RECOVERY)
    recovered = model.solve(np.full(3, RECOVERY)).q
    np.testing.assert_allclose(
        published['joint_states'][-1].position, recovered, atol=ANGLE_TOLERANCE
    )


def test_bending_beyond_the_valid_stretch_is_published_and_reported(plant_for):
    node, model = plant_for('soft', EDGE_FILES['soft'])
    solution = model.solve(np.full(3, SUPPLY))
    assert solution.converged and not solution.in_valid_range
    published = step(node, SUPPLY)
    np.testing.assert_allclose(published['joint_states'][-1].position, solution.q, atol=1e-9)
    report, values = status(published)
    assert report.level == DiagnosticStatus.WARN and 'stretch' in report.message
    assert values['in valid range'] == 'False'


def test_very_stiff_finger_is_solved(plant_for):
    node, model = plant_for('stiff_finger', EDGE_FILES['stiff_finger'])
    published = step(node, SUPPLY)
    expected = model.solve(np.full(3, SUPPLY)).q
    np.testing.assert_allclose(published['joint_states'][-1].position, expected, atol=1e-9)
    assert np.all(np.abs(expected) < np.radians(1.0))


def test_commands_beyond_the_supply_saturate_and_are_reported(plant_for):
    node, model = plant_for('defaults', {})
    published = step(node, 1e12)
    np.testing.assert_array_equal(published['chamber_pressure'][-1].data, [SUPPLY] * 3)
    expected = model.solve(np.full(3, SUPPLY)).q
    np.testing.assert_allclose(published['joint_states'][-1].position, expected, atol=1e-9)
    report, values = status(published)
    assert report.level == DiagnosticStatus.WARN and 'saturated' in report.message
    assert int(values['saturated above supply']) >= 1


positive = st.floats(min_value=1e-3, max_value=1e3)
glove_files = st.fixed_dictionaries(
    {
        'material': st.fixed_dictionaries(
            {
                'c1': st.floats(1.0, 1e7),
                'c2': st.floats(0.0, 1e6),
                'c3': st.floats(0.0, 1e5),
            }
        ),
        'finger': st.fixed_dictionaries(
            {
                'joints': st.lists(
                    st.fixed_dictionaries(
                        {
                            'stiffness': st.floats(0.0, 100.0),
                            'link_half_length': st.floats(0.002, 0.05),
                        }
                    ),
                    min_size=3,
                    max_size=3,
                )
            }
        ),
    }
)


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=glove_files, commands=st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=4))
def test_random_valid_gloves_never_publish_non_finite_values(plant_for, data, commands):
    node, _ = plant_for('random', data)
    for command in commands:
        published = step(node, command)
        assert published['joint_states'], 'no state published'
