"""Virtual patient trials of a ROS node controller through the testing kit (docs/trials.md).

The "user's" node is the built-in ``pressure_command`` in ``position`` mode with
``lockstep:=true``, following the protocol's trajectory; the in-process trial's ``position``
mode is the same controller code (exodigit_model.control) sampling the same trajectory, so the
two trials must agree on every metric a ROS node can report. They are not bit for bit the same:
the trial steps its patients as one batch of fingers, the plant one glove, and the two solves
end a few ulps apart (the same commands gave angles 3e-16 rad apart from the first step, the
commands then 7e-12 Pa apart, the metrics 2e-16), hence ROUNDING. Given the same states, the
node's commands are the in-process controller's bit for bit (tests/test_nodes_trajectory.py).

The module's trial runs on one glove: patient 1 on the glove and node that ran patient 0, a new
session of the plant on which the node starts over. A glove and node started for patient 1 alone
must give the same session bit for bit (lockstep: the same commands give the same states), so
the same metrics.
"""

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from exodigit_model.tools.trial_report import write_report
from exodigit_model.trials import ControllerSpec, TrialSpec, run_trial
from exodigit_nodes.testing.trial_engine import KitEngine, PatientError, ros_controller

from exodigit_nodes import trial as trial_command

ROUNDING = 1e-9
"""Relative (and absolute, in the metric's unit) agreement of the kit's metrics with the
in-process trial's: six orders above the rounding measured, far below what one step's stale
target would change (about 1e-4 rad of tracking RMSE)."""
NOT_REPORTED = ('limiter_steps', 'solver_warning_steps', 'outside_model_steps')
"""What a ROS node and the plant's topics do not say: 0 in a kit trial."""
NODE = [sys.executable, '-m', 'exodigit_nodes.nodes.pressure_command']
NEW_SESSION = 'joint_states went back'
"""What pressure_command logs when a state's stamp goes back: it starts a new session."""


def trial(controller: ControllerSpec, patients: int = 2) -> TrialSpec:
    return TrialSpec(
        patients=patients,
        seed=4,
        protocol='grasp',
        protocol_parameters={
            'duration': 1.0,
            'close_time': 0.5,
            'hold_time': 0.2,
            'open_time': 0.3,
        },
        controller=controller,
    )


@pytest.fixture(scope='module')
def kit_trial(tmp_path_factory):
    """The two patients on one glove and node, kept from patient 0 for patient 1."""
    spec = trial(ros_controller(NODE, mode='position', lockstep=True))
    with KitEngine(parallel=1, log_dir=tmp_path_factory.mktemp('kit')) as engine:
        result = run_trial(spec, engine=engine)
    return spec, engine, result


# The in-process run's position controller warns that a stiff patient's feed-forward is
# beyond the supply: the trial compares the two engines, beyond the supply included.
@pytest.mark.filterwarnings('ignore::exodigit_model.physics.validity.OutsideModelWarning')
def test_the_node_gives_the_in_process_metrics(kit_trial):
    _, engine, result = kit_trial
    reference = run_trial(trial(ControllerSpec('mode', 'position')))
    kit, local = result.metrics.columns(), reference.metrics.columns()
    assert list(kit) == list(local)  # the same columns, in the same order
    for column in NOT_REPORTED:
        assert (kit[column] == 0).all()
    assert local['limiter_steps'].max() > 0  # the rate limit acted: the node's is not seen
    for column in set(kit) - set(NOT_REPORTED):
        np.testing.assert_allclose(
            kit[column], local[column], rtol=ROUNDING, atol=ROUNDING, err_msg=column
        )
    assert (kit['rom_rad.pip'] > 0.05).all()  # the finger moved
    assert result.status == 0 and result.message.startswith('passed: 2 patients')
    assert [run.status for run in engine.runs] == [0, 0]


def test_the_targets_sent_are_the_protocols_and_in_the_records(kit_trial):
    spec, engine, result = kit_trial
    protocol = spec.session()
    targets = protocol.targets(protocol.times())
    assert sorted(engine.records) == [0, 1]
    for patient, record in engine.records.items():
        assert record.patient == patient
        np.testing.assert_array_equal(record.target, targets)
        np.testing.assert_array_equal(record.t, protocol.times())
        assert record.q.shape == record.command.shape == (protocol.steps, 3)
    # the target's range is what the metrics saw: exactly the targets sent
    sent = targets.max(axis=0) - targets.min(axis=0)
    np.testing.assert_array_equal(result.metrics.values['target_rom_rad'], np.tile(sent, (2, 1)))


def test_a_glove_kept_for_the_next_patient_gives_what_a_fresh_glove_gives(kit_trial):
    spec, engine, _ = kit_trial
    logs = Path(engine.log_dir)
    # patient 1 ran on patient 0's glove: its node saw time go back once, none started for 1
    assert (logs / 'patient_0' / 'controller.err').read_text().count(NEW_SESSION) == 1
    assert not (logs / 'patient_1' / 'controller.err').exists()
    alone = KitEngine().session(spec, 1)  # on a glove and node of its own
    kept = engine.records[1]
    # every series the metrics come from, and the node's commands
    for series in ('q', 'target', 'pressure', 'forces', 'command'):
        np.testing.assert_array_equal(getattr(kept, series), getattr(alone, series), series)
    before = engine.records[0].command[-1]
    assert not np.array_equal(before, kept.command[0])  # the node had something to forget


def test_the_report_is_the_in_process_one(kit_trial, tmp_path):
    _, engine, result = kit_trial
    worst = result.worst_patient()
    written = write_report(result, tmp_path / 'report', record=engine.records[worst])
    assert sorted(path.name for path in written) == sorted(
        ['patients.csv', 'summary.json', 'distributions.png', 'worst_patient.png', 'rom.png']
    )
    summary = json.loads((tmp_path / 'report' / 'summary.json').read_text())
    assert summary['spec']['controller']['kind'] == 'ros'
    assert summary['spec']['controller']['parameters'] == {'lockstep': True, 'mode': 'position'}
    assert summary['worst_patient'] == worst


def test_a_controller_that_exits_at_once_fails_its_run_not_hangs():
    spec = trial(ros_controller([sys.executable, '-c', 'raise SystemExit(3)']), patients=1)
    engine = KitEngine(parallel=1, timeout=20.0, follows_targets=False)
    with pytest.raises(PatientError) as failure:
        run_trial(spec, engine=engine)
    (run,) = engine.runs
    assert failure.value.run is run
    assert run.status == 1 and not run.success and run.record is None
    assert run.message.startswith('patient 0: your controller exited with code 3 while waiting')


def test_the_engines_refuse_each_others_controllers():
    ros = trial(ros_controller(NODE), patients=1)
    with pytest.raises(ValueError, match='is a ROS node: it runs through the testing kit'):
        run_trial(ros)
    with pytest.raises(ValueError, match="KitEngine runs a ROS node controller \\(kind 'ros'\\)"):
        run_trial(trial(ControllerSpec('mode', 'position'), 1), engine=KitEngine())
    for parallel in (0, 1.5, True):
        with pytest.raises(ValueError, match='parallel'):
            KitEngine(parallel)
    with pytest.raises(ValueError, match='ROS controller command: empty'):
        ros_controller([])


def test_the_command_takes_the_trial_options_and_refuses_in_process_ones(capsys):
    with pytest.raises(SystemExit):
        trial_command.main(['--help'])
    text = capsys.readouterr().out
    for option in ('--ros-controller CMD', '--parallel N', '--population', '--require RULE'):
        assert option in text
    assert '--engine {kit,ray}' in text  # its own engines, not the in-process ones
    assert '--mode' not in text and '--shard-size' not in text
    assert trial_command.main(['--ros-controller', 'x', '--parallel', '0']) == 2
    assert 'parallel = 0' in capsys.readouterr().err
    with pytest.raises(SystemExit):
        trial_command.main(['--ros-controller', 'x', '--mode', 'sine'])
