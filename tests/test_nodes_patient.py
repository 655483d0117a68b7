"""The patient over ROS (docs/spec/ros.md Part II, "The patient"), in lockstep simulated time.

The plant simulates a patient file; a probe publishes ``patient_effort`` and reads the
estimator's ``estimated_finger_torque``, ``estimated_rest_angle`` and the diagnostics. Expected
values come from ``GloveModel`` solves of the same patient, independent of the nodes. One glove
serves the module: it identifies the patient first thing, then each test finds it at rest.
"""

import ast
import contextlib

import numpy as np
import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from exodigit_nodes.nodes.qos import RECORD_QOS
from exodigit_nodes.testing import GloveSim
from ros_harness import RosProbe, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

#: A linear patient (so the effective spring is the patient itself), resting flexed.
LINEAR_PATIENT = {
    'finger': {
        'joints': [
            {'stiffness': 0.08, 'rest_angle': 0.2},
            {'stiffness': 0.06, 'rest_angle': 0.25},
            {'stiffness': 0.03, 'rest_angle': 0.15},
        ]
    }
}
ANGLE_TOLERANCE = 1e-9
#: The plant's /diagnostics period in these tests, s (the default is 1 s).
REPORT_PERIOD = 0.1
#: Identification of a noise-free linear patient: stiffness (relative), rest angle (rad).
STIFFNESS_RTOL, REST_TOLERANCE = 1e-4, 1e-5
#: Longest wait for what the nodes report on the wall clock (/diagnostics, the estimator's
#: publishers), s: only a failing test waits it out, and a loaded machine is slow.
WAIT = 60.0


@pytest.fixture(scope='module')
def patient_file(tmp_path_factory):
    path = tmp_path_factory.mktemp('patient') / 'patient.yaml'
    path.write_text(yaml.safe_dump(LINEAR_PATIENT))
    return path


@contextlib.contextmanager
def patient_glove(patient_file, log_dir):
    """A glove simulating the patient file, with the estimator, and a probe in its domain."""
    plant = {'diagnostic_period': REPORT_PERIOD}
    with GloveSim(patient_file, estimator=True, plant=plant, log_dir=log_dir) as sim:
        probe = RosProbe(sim.domain_id, name='patient_probe')
        try:
            yield sim, probe
        finally:
            probe.close()


@pytest.fixture(scope='module')
def started(patient_file, tmp_path_factory):
    """One glove for the module (starting one costs seconds), identified first thing.

    The identification runs before any test can step the glove: the estimator's window (500
    pairs) then holds the identification's steps only, whatever order the tests run in.
    """
    with patient_glove(patient_file, tmp_path_factory.mktemp('logs')) as (sim, probe):
        yield sim, probe, identification_run(sim, probe)


@pytest.fixture
def glove(started):
    """The shared glove at rest: no command, no effort (``reset`` forgets both)."""
    sim, probe, _ = started
    sim.reset()
    return sim, probe


def plant_status(diagnostics, ns):
    for array in reversed(diagnostics.messages()):
        for status in array.status:
            if status.name == f'{ns}/plant':
                return status, {kv.key: kv.value for kv in status.values}
    return None


def steps_until(glove, command, condition, limit=400):
    for _ in range(limit):
        state = glove.step(command)
        if condition(state):
            return state
    return None


def test_an_effort_moves_the_glove_as_the_model_predicts_and_times_out(glove, patient_file):
    sim, probe = glove
    model = GloveModel(load_params(patient_file))
    effort = probe.publisher(f'{sim.namespace}/patient_effort', Float64MultiArray)
    p, u = [20e3, 20e3, 20e3], [0.01, 0.005, 0.002]
    helped = model.solve(p, effort=u).q
    plain = model.solve(p).q
    assert np.abs(helped - plain).min() > 1e-3  # the effort matters

    def near(target):
        return lambda state: np.abs(state.q - target).max() < ANGLE_TOLERANCE

    assert steps_until(sim, p, near(plain)) is not None
    effort.publish(Float64MultiArray(data=u))
    assert steps_until(sim, p, near(helped)) is not None
    # effort_timeout (0.5 simulated s) after the last effort message: no effort any more
    assert steps_until(sim, p, near(plain), limit=200) is not None


def test_a_bad_effort_is_dropped_and_counted(glove, patient_file):
    sim, probe = glove
    diagnostics = probe.subscribe('/diagnostics', DiagnosticArray)
    effort = probe.publisher(f'{sim.namespace}/patient_effort', Float64MultiArray)

    def counted():
        report = plant_status(diagnostics, sim.namespace)
        return report and sum(
            int(v) for k, v in report[1].items() if k.startswith('rejected patient_effort')
        )

    assert wait_until(lambda: counted() is not None, WAIT)
    before = counted()
    effort.publish(Float64MultiArray(data=[1.0, float('nan'), 0.0]))
    effort.publish(Float64MultiArray(data=[50.0, 0.0, 0.0]))  # beyond any finger
    assert wait_until(lambda: counted() == before + 2, WAIT)
    model = GloveModel(load_params(patient_file))
    state = sim.step([10e3, 10e3, 10e3])  # still running, and without the dropped efforts
    np.testing.assert_allclose(state.q, model.solve([10e3] * 3).q, atol=ANGLE_TOLERANCE)


def identification_run(sim, probe) -> dict:
    """3 simulated s of a sine (two identification periods); what the estimator published."""
    ns = sim.namespace
    # Transient-local: the estimator's publishers keep their samples for a reader they match
    # late (volatile, a run here got the torques of 38 of the 300 steps: the estimator's writer
    # matched the probe's reader only then).
    torques = probe.subscribe(f'{ns}/estimated_finger_torque', JointState, qos=RECORD_QOS)
    rests = probe.subscribe(f'{ns}/estimated_rest_angle', Float64MultiArray, qos=RECORD_QOS)
    stiffness = probe.subscribe(
        f'{ns}/estimated_finger_stiffness', Float64MultiArray, qos=RECORD_QOS
    )
    diagnostics = probe.subscribe('/diagnostics', DiagnosticArray)
    assert wait_until(lambda: probe.node.count_publishers(f'{ns}/estimated_rest_angle'), WAIT)
    states = []
    for k in range(300):
        p = 25e3 * (1.0 - np.cos(2.0 * np.pi * k / 150))
        states.append(sim.step([p, 0.8 * p, 0.6 * p]))
    identified = wait_until(lambda: rests.count() >= 1 and stiffness.count() >= 1, WAIT)
    report = wait_until(
        lambda: next(
            (
                {kv.key: kv.value for kv in status.values}
                for array in reversed(diagnostics.messages())
                for status in array.status
                if status.name == f'{ns}/estimator' and 'fit RMSE (N·m)' in str(status.values)
            ),
            None,
        ),
        10.0,
    )
    return {
        'states': states,
        'torques': torques.messages(),
        'rest': rests.latest() if identified else None,
        'stiffness': stiffness.latest() if identified else None,
        'report': report,
    }


def test_the_estimator_identifies_the_patient_and_publishes_its_torque(started, patient_file):
    run = started[2]
    assert run['rest'] is not None and run['stiffness'] is not None, 'nothing identified'
    truth = LINEAR_PATIENT['finger']['joints']
    np.testing.assert_allclose(
        run['stiffness'].data, [j['stiffness'] for j in truth], rtol=STIFFNESS_RTOL
    )
    np.testing.assert_allclose(
        run['rest'].data, [j['rest_angle'] for j in truth], atol=REST_TOLERANCE
    )
    # τ̂_H of each step is the patient's torque at the state its stamp names (static patient:
    # no speed terms)
    assert len(run['torques']) >= 100
    model = GloveModel(load_params(patient_file))
    states = {round(s.t * 1e9): s for s in run['states']}
    for message in run['torques'][-50:]:
        stamp = message.header.stamp.sec * 10**9 + message.header.stamp.nanosec
        expected = model.finger_torque(states[stamp].q)
        np.testing.assert_allclose(message.effort, expected, rtol=0, atol=1e-9)
    assert run['report'] is not None
    assert max(ast.literal_eval(run['report']['fit RMSE (N·m)'])) < 1e-6


def test_diagnostics_say_when_a_contact_is_in_tension(glove):
    sim, probe = glove
    diagnostics = probe.subscribe('/diagnostics', DiagnosticArray)
    state = sim.step([0.0, 0.0, 0.0])  # the flexed finger against the vented glove
    tense = [name for name, f in zip(('mcp', 'pip', 'dip'), state.forces, strict=True) if f < 0]
    assert tense, state.forces
    report = wait_until(lambda: plant_status(diagnostics, sim.namespace), WAIT)
    assert report is not None
    status, values = report
    assert values['contacts in tension'] == ', '.join(tense)
    assert 'in tension' in status.message
