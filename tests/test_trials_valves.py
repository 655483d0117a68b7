"""Trials behind valves (issue 26, item 3): a mode's pressures through the ValveLoop.

A hold session on valve-driven gloves: each patient's peak pressure and range of motion are
checked against independent statics solves of that patient's glove (``GloveModel.solve`` at the
hold pressures, bracketing the loop's deadband and overshoot), not against the trial's own
stepper; the command line's ``--actuation`` and the spec's refusals.
"""

from dataclasses import replace

import numpy as np
import pytest
from exodigit_model.tools.cli import main
from exodigit_model.trials import ControllerSpec, TrialSpec, record_patient, run_trial

from exodigit_model import GloveModel

HOLD = np.array([20e3, 25e3, 15e3])
"""The hold mode's pressures, Pa: reached in 0.25 s at the limiter's 100 kPa/s."""
BRACKET = 1e3
"""Pa around the hold pressures within which the loop holds each chamber at the end: its
deadband (300 Pa) and the overshoot of one step's opening."""


def hold_spec(**changes):
    fields = {
        'population': 'stroke_moderate',
        'patients': 3,
        'protocol_parameters': {'duration': 2.0},
        'controller': ControllerSpec('mode', 'hold', {'hold_pressure': HOLD.tolist()}),
        'actuation': 'valves',
    }
    return TrialSpec(**(fields | changes))


def test_a_valve_hold_trial_reaches_the_pressures_and_angles_the_statics_give():
    spec = hold_spec()
    result = run_trial(spec)
    assert result.spec.summary()['actuation'] == 'valves'
    metrics = result.metrics.values
    np.testing.assert_array_less(np.abs(metrics['peak_pressure_pa'] - HOLD), BRACKET)
    assert not metrics['solver_warning_steps'].any()
    params = spec.glove_params()
    for patient, finger in enumerate(result.patients.fingers):
        model = GloveModel(replace(params, finger=finger))
        rest = model.solve(np.zeros(3)).q
        low = model.solve(HOLD - BRACKET).q - rest
        high = model.solve(HOLD + BRACKET).q - rest
        rom = metrics['rom_rad'][patient]
        assert np.all((low < rom) & (rom < high)), (patient, low, rom, high)
    record = record_patient(spec, 1)
    assert record.openings.shape == (record.t.size, 6)
    assert np.all((record.openings >= 0.0) & (record.openings <= 1.0))
    # the loop never opens a chamber's inlet and outlet together (air through both is wasted)
    assert not np.any((record.openings[:, :3] > 0) & (record.openings[:, 3:] > 0))
    np.testing.assert_allclose(record.command[-1], HOLD)  # the targets the loop tracked


def test_a_softer_loop_is_slower_and_the_regulator_trial_refuses_its_parameters():
    soft = hold_spec(
        patients=1,
        protocol_parameters={'duration': 0.3},
        controller=ControllerSpec(
            'mode',
            'hold',
            {'hold_pressure': HOLD.tolist(), 'valve_kp': 1.0 / 4e6, 'valve_ki': 0.0},
        ),
    )
    default = replace(soft, controller=hold_spec().controller)
    # at 0.3 s the default loop has nearly reached the ramp's 25 kPa; a P loop of 1 % of its
    # gain opens PIP's inlet by 0.6 % at most: 0.1 kPa a step (16-37 kPa a step fully open)
    assert run_trial(default).metrics.values['peak_pressure_pa'][0, 1] > 20e3
    assert run_trial(soft).metrics.values['peak_pressure_pa'][0, 1] < 10e3
    with pytest.raises(ValueError, match="'valve_ki': a valve loop's"):
        replace(soft, actuation='regulator')
    with pytest.raises(ValueError, match='actuation'):
        hold_spec(actuation='solenoids')
    with pytest.raises(ValueError, match='in process only'):
        hold_spec(controller=ControllerSpec('ros', 'ros2 run my_pkg my_node'))


def test_the_command_line_runs_a_valve_trial(capsys):
    status = main(
        ['trial', '--patients', '2', '--duration', '0.3', '--no-progress', '--actuation', 'valves']
    )
    out, err = capsys.readouterr()
    assert (status, err) == (0, '')
    assert out.splitlines()[-1] == 'passed: 2 patients, 0 of 0 rules passed'
