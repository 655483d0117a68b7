"""The plant's /diagnostics report of a step (exodigit_nodes/logic/plant_report.py), ROS-free.

States come from the stepper itself; each case sets one condition and checks that the report
says it (a problem, so WARN, or a note) and only it.
"""

import numpy as np
from exodigit_model.stepping.chambers import Saturation
from exodigit_nodes.logic.plant_report import plant_report
from exodigit_nodes.logic.watchdog import Watchdog

from exodigit_model import GloveSimulation, SimulationSettings

TIMEOUT = 0.5  # s
QUIET = {
    'cycles': 10,
    'late_cycles': 0,
    'failures': 0,
    'new_failures': 0,
    'failure_residual': 0.0,
    'saturation': Saturation(),
}


def state(command=(40e3, 0.0, 0.0)):  # the MCP chamber alone: no contact in tension
    return GloveSimulation(settings=SimulationSettings(pressure_time_constant=0.0)).step(command)


def fed(now: float) -> Watchdog:
    watchdog = Watchdog(TIMEOUT)
    watchdog.feed(now)
    return watchdog


def test_a_normal_step_has_no_problem_and_shows_its_values():
    step = state()
    report = plant_report(step, fed(1.0), 1.2, **QUIET)
    assert report.problems == [] and report.notes == []
    assert report.values['watchdog'] == 'ok'
    assert report.values['command age (s)'] == '0.200'
    assert report.values['chamber pressure (Pa)'] == str([40e3, 0.0, 0.0])
    assert report.values['joint angles (rad)'] == str(step.q.tolist())
    assert report.values['cycles'] == '10'


def test_the_watchdog_before_any_command_and_once_tripped():
    waiting = plant_report(state(), Watchdog(TIMEOUT), 1.0, **QUIET)
    assert waiting.values['watchdog'] == 'waiting for a command' and waiting.problems == []
    watchdog = fed(1.0)
    assert watchdog.update(1.0 + 2 * TIMEOUT)
    tripped = plant_report(state(), watchdog, 2.0, **QUIET)
    assert tripped.values['watchdog'] == 'venting'
    assert tripped.problems == ['watchdog: no command for 1.00 s, vented']


def test_failures_since_the_last_report_are_a_problem_once():
    counts = {**QUIET, 'failures': 3, 'new_failures': 2, 'failure_residual': 0.0123}
    report = plant_report(state(), fed(1.0), 1.0, **counts)
    assert report.problems == [
        'solver did not converge 2 times (last residual 0.0123 N·m), kept the last good state'
    ]
    assert report.values['solver failures'] == '3'
    again = plant_report(state(), fed(1.0), 1.0, **{**counts, 'new_failures': 0})
    assert again.problems == []


def test_saturation_is_a_problem_and_counted():
    saturated = state((-1.0, 0.0, 1e9))
    counts = {**QUIET, 'saturation': Saturation(below_zero=1, above_supply=1)}
    report = plant_report(saturated, fed(1.0), 1.0, **counts)
    assert 'command saturated to the supply range' in report.problems
    assert (report.values['saturated below 0'], report.values['saturated above supply']) == (
        '1',
        '1',
    )


def test_a_contact_in_tension_is_a_note_not_a_problem():
    step = state()
    pulled = step._replace(forces=np.array([1.0, -0.5, -0.1]))
    report = plant_report(pulled, fed(1.0), 1.0, **QUIET)
    assert report.notes == ['contact in tension at pip, dip (the strap pulls)']
    assert report.problems == []
    assert report.values['contacts in tension'] == 'pip, dip'
