"""A batch of gloves on a population of patients (docs/spec/model.md §13, "A population").

Every expectation comes from gloves simulated one by one: glove i of
``GloveSimulation(model, fingers=F)`` must rest, step, be reconfigured and reset exactly as
``GloveSimulation(GloveModel(replace(model.params, finger=F[i])))`` does, bit for bit; the
range-of-motion flag must be each patient's own (``GloveModel.in_range_of_motion`` of that
patient's model); the same finger N times must be today's ``count=N`` batch, noise included.
That the compiled kernels give what plain Python gives is checked with the other kernel cases
(``simulation_population`` in tests/kernel_cases.py, run by tests/test_model_kernels.py).
"""

from dataclasses import replace

import numpy as np
import pytest
from exodigit_model.trials import load_population
from kernel_cases import EVERY_TERM, NOISY, commands, efforts, models, stacked
from test_model_kernels import SHARED, assert_identical, assert_same_states, counts

from exodigit_model import GloveModel, GloveSimulation, SimulationSettings, params_from_dict

#: Without noise (a batch draws its noise for all its gloves from one stream), with lag.
QUIET = SimulationSettings(seed=3)
#: Steps of the glove-by-glove comparison; the settings change after CONFIGURE_AT steps and
#: every glove is put back to rest after RESET_AT.
STEPS, CONFIGURE_AT, RESET_AT = 60, 20, 40
#: Link half lengths of a little finger, m (exodigit_nodes/config/hand/little.yaml).
LITTLE_FINGER = (0.0193, 0.0111, 0.0088)
#: Exo-digits the patients wear (tests/kernel_cases.py): the default, one with extensible
#: segments, and a soft one whose solves fail at high pressure.
EXO_DIGITS = ('default', 'extensible', 'soft')


def patients(model: GloveModel) -> list:
    """Five fingers: the model's own, three drawn from stroke_severe, and a little finger with
    every term of eq 11.1 on (other link lengths: the anatomy is the patient's too)."""
    drawn = load_population('stroke_severe').sample(3, seed=5).fingers
    joints = [dict(EVERY_TERM, link_half_length=length) for length in LITTLE_FINGER]
    little = params_from_dict({'finger': {'joints': joints}}).finger
    return [model.params.finger, *drawn, little]


def alone(model: GloveModel, finger, settings: SimulationSettings) -> GloveSimulation:
    """The glove of ``finger`` simulated by itself."""
    return GloveSimulation(GloveModel(replace(model.params, finger=finger)), settings)


def row(state, r: int):
    """Glove ``r`` of a batch's state as a single glove's (the shared fields, and None, as they
    are)."""
    rows = {
        f: getattr(state, f)[r]
        for f in state._fields
        if f not in SHARED and getattr(state, f) is not None
    }
    return state._replace(**rows)


def assert_rows_are_singles(state, expected: list, what: str) -> None:
    """Each row of ``state`` equals the matching single glove's ``expected`` state."""
    for r, single_state in enumerate(expected):
        assert_same_states(single_state, row(state, r), f'{what}, glove {r}', skip=('saturated',))
    assert state.saturated == any(single_state.saturated for single_state in expected)


@pytest.mark.parametrize('name', EXO_DIGITS)
def test_each_glove_of_a_population_is_its_patient_simulated_alone(name):
    model = models()[name]
    fingers = patients(model)
    count = len(fingers)
    batch = GloveSimulation(model, QUIET, fingers=fingers)
    singles = [alone(model, finger, QUIET) for finger in fingers]
    assert batch.count == count and batch.fingers == tuple(fingers)
    assert_rows_are_singles(batch.state, [s.state for s in singles], 'rest')
    scales = np.linspace(1.1, 0.05, count)[:, None]  # the nominal finger pushed hardest
    below = above = 0
    for k, (command, effort) in enumerate(zip(commands(STEPS), efforts(STEPS), strict=True)):
        if k == CONFIGURE_AT:
            for simulation in (batch, *singles):
                simulation.configure(pressure_time_constant=0.0, max_supply_pressure=120e3)
        if k == RESET_AT:
            rested = batch.reset()
            assert_rows_are_singles(rested, [s.reset() for s in singles], 'reset')
        rows, pushes = scales * command, scales * effort
        state = batch.step(rows, pushes)
        expected = [single.step(rows[r], pushes[r]) for r, single in enumerate(singles)]
        assert_rows_are_singles(state, expected, f'step {k + 1}')
        below += bool(np.any(rows < 0.0))
        above += bool(np.any(rows > batch.settings.max_supply_pressure))
    saturation = batch.chambers.saturation
    assert (saturation.below_zero, saturation.above_supply) == (below, above) != (0, 0)
    assert batch.solver_failures == sum(single.solver_failures for single in singles)
    assert (batch.solver_failures > 0) == (name == 'soft')  # the failure path is reached


def test_patients_rest_each_on_their_own_finger_and_leave_their_own_range():
    model = models()['default']
    narrow = params_from_dict({'finger': {'joints': [{'rom_max': 0.2}, {}, {}]}}).finger
    stroke = models()['stroke'].params.finger
    fingers = [model.params.finger, narrow, stroke]
    batch = GloveSimulation(model, QUIET, fingers=fingers)
    references = [GloveModel(replace(model.params, finger=finger)) for finger in fingers]
    for r, reference in enumerate(references):
        at_rest = reference.solve(np.zeros(3))
        assert_identical(at_rest.q, batch.state.q[r], f'rest q of glove {r}')
        assert_identical(at_rest.forces, batch.state.forces[r], f'rest forces of glove {r}')
    assert np.all(batch.state.q[2] > 0.1)  # the stroke finger rests flexed, the others straight
    assert not np.any(batch.state.q[:2]) and batch.state.in_range_of_motion.all()
    batch.run(np.full((30, 3, 3), 40e3))
    state = batch.state  # MCP well beyond 0.2 rad
    assert np.all(state.q[:, 0] > 0.2)
    own = [reference.in_range_of_motion(state.q[r]) for r, reference in enumerate(references)]
    assert_identical(np.array(own), state.in_range_of_motion, 'in_range_of_motion')
    assert own == [True, False, True]


def test_the_same_finger_n_times_is_the_batch_of_count_n_noise_included():
    model, count = models()['stroke'], 4
    population = GloveSimulation(model, NOISY, fingers=[model.params.finger] * count)
    batch = GloveSimulation(model, NOISY, count=count)
    assert population.fingers is not None and batch.fingers is None
    assert_same_states(batch.state, population.state, 'rest')
    scales = np.linspace(0.2, 1.1, count)[:, None]
    for command, effort in zip(commands(40), efforts(40), strict=True):
        expected = batch.step(scales * command, scales * effort)
        assert_same_states(expected, population.step(scales * command, scales * effort), 'step')
    assert counts(population) == counts(batch)
    assert_same_states(batch.reset(), population.reset(), 'reset')


def test_a_population_runs_as_it_steps_noise_included():
    model = models()['extensible']
    fingers = patients(model)
    scales = np.linspace(0.3, 1.0, len(fingers))[:, None]
    rows = scales * commands(50)[:, None, :]
    pushes = scales * efforts(50)[:, None, :]
    ran = GloveSimulation(model, NOISY, fingers=fingers)
    stepped = GloveSimulation(model, NOISY, fingers=fingers)
    record = ran.run(rows, pushes)
    history = stacked([stepped.step(c, e) for c, e in zip(rows, pushes, strict=True)])
    assert_same_states(history, record, 'run')
    assert_same_states(stepped.state, ran.state, 'state')
    assert counts(ran) == counts(stepped)


def test_a_population_of_one_is_a_direct_simulation_of_that_patient_noise_included():
    model = models()['default']
    finger = load_population('stroke_moderate').sample(1, seed=9).fingers[0]
    population = GloveSimulation(model, NOISY, fingers=[finger])
    single = alone(model, finger, NOISY)
    record = population.run(commands(80)[:, None, :], efforts(80)[:, None, :])
    expected = single.run(commands(80), efforts(80))
    assert record.q.shape == (80, 1, 3)
    for field in expected._fields:
        value = getattr(record, field)
        actual = value if field in SHARED or value is None else value[:, 0]
        assert_identical(getattr(expected, field), actual, f'run.{field}')
    assert counts(population) == counts(single)


FINGER = models()['default'].params.finger
JOINT = FINGER.joints[0]


@pytest.mark.parametrize(
    ('fingers', 'count', 'match'),
    [
        ([], None, r'fingers = \[\]: must be a non-empty sequence'),
        (FINGER, None, 'fingers = Finger.*: must be a non-empty sequence'),  # not a sequence
        ('abc', None, r"fingers\[0\] = 'a': must be a Finger"),
        (['nominal'], None, r"fingers\[0\] = 'nominal'"),
        ([None, None], None, r'fingers\[0\] = None'),
        ([FINGER, {'stiffness': 0.1}], None, r'fingers\[1\] = \{'),
        ([FINGER, JOINT], None, r'fingers\[1\] = FingerJoint'),
        ([FINGER, FINGER], 3, 'count = 3: does not match the 2 fingers'),
        ([FINGER], 0, 'count = 0: must be a positive integer'),
    ],
    ids=repr,
)
def test_bad_fingers_are_refused_naming_what_is_wrong(fingers, count, match):
    with pytest.raises(ValueError, match=match):
        GloveSimulation(models()['default'], fingers=fingers, count=count)
