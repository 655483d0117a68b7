"""``exodigit trial`` (issue 17, item 2): exit codes, one-line errors, the report's files.

The command runs in this process (``cli.main``) on small populations and short sessions;
tests/trial_controllers.py holds the user controllers named by module:attribute.
"""

import csv
import json
import sys

import numpy as np
import pytest
from exodigit_model.tools.cli import main
from exodigit_model.trials import PATIENT_FIELDS, column_names

QUICK = ['--patients', '4', '--duration', '0.3', '--no-progress']
FORCE_RULE = 'peak_force_n <= 0.5 for 100%'


def run(capsys, *arguments):
    status = main(['trial', *QUICK, *arguments])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize(
    ('factory', 'status', 'verdict'),
    [('trial_controllers:full_supply', 1, 'failed'), ('trial_controllers:gentle', 0, 'passed')],
)
def test_a_force_rule_fails_full_supply_and_passes_a_gentle_controller(
    capsys, factory, status, verdict
):
    code, out, err = run(
        capsys, '--population', 'healthy', '--controller', factory, '--require', FORCE_RULE
    )
    assert (code, err) == (status, '')
    assert f'{verdict}: peak_force_n <= 0.5 held for' in out
    assert out.splitlines()[-1] == f'{verdict}: 4 patients, {1 - status} of 1 rules passed'


def test_a_built_in_mode_with_parameters_passes_its_rules(capsys):
    code, out, _ = run(
        capsys,
        '--mode',
        'hold',
        '--param',
        'hold_pressure=[10e3, 20e3, 30e3]',
        '--param',
        'max_pressure=25e3',
        '--set',
        'hold=0.1',
        '--protocol',
        'staircase',
        '--require',
        'peak_pressure_pa.dip <= 25e3 for 100%',
        '--require',
        'peak_pressure_pa.mcp <= 10e3 for 100%',
    )
    assert code == 0, out
    assert out.count('passed: peak_pressure_pa') == 2


@pytest.mark.parametrize(
    ('arguments', 'message'),
    [
        (['--patients', '0'], 'patients = 0: must be a whole number >= 1'),
        (['--population', 'nobody'], 'cannot read population file'),
        (['--set', 'period'], "--set 'period': expected KEY=VALUE"),
        (['--set', 'tempo=3'], "unknown parameter 'tempo'"),
        (['--duration', '0.005'], 'whole number of steps'),
        (['--mode', 'sine', '--param', 'sine_period=-1'], 'sine_period = -1.0: must be > 0'),
        (['--controller', 'no_such_module:make'], 'cannot import no_such_module'),
        (['--controller', 'trial_controllers:not_a_controller'], 'not a BatchController'),
        (['--require', 'peak_force <= 5 for 99%'], "unknown metric 'peak_force'"),
        (['--address', 'auto'], '--address is for --engine ray'),
        (['--force-limit', '0'], 'force_limit = 0.0: must be > 0'),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, arguments, message):
    code, out, err = run(capsys, *arguments)
    assert code == 2
    assert out == ''
    assert err.count('\n') == 1
    assert err.startswith('exodigit trial: error: ')
    assert message in err


def test_the_report_files_exist_and_parse(capsys, tmp_path):
    out_dir = tmp_path / 'report'
    code, out, _ = run(
        capsys,
        '--protocol',
        'grasp',
        '--mode',
        'position',
        '--require',
        FORCE_RULE,
        '--out',
        str(out_dir),
    )
    assert code == 1
    assert 'wrote' in out.splitlines()[-1]
    names = {path.name for path in out_dir.iterdir()}
    assert names == {
        'patients.csv',
        'summary.json',
        'distributions.png',
        'worst_patient.png',
        'rom.png',
    }
    for name in ('distributions.png', 'worst_patient.png', 'rom.png'):
        assert (out_dir / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'

    with (out_dir / 'patients.csv').open() as file:
        rows = list(csv.DictReader(file))
    parameters = [f'{key}.{joint}' for key in PATIENT_FIELDS for joint in ('mcp', 'pip', 'dip')]
    assert list(rows[0]) == ['patient', *parameters, *column_names()]
    assert [int(row['patient']) for row in rows] == [0, 1, 2, 3]

    summary = json.loads((out_dir / 'summary.json').read_text())
    assert set(summary) == {'spec', 'status', 'message', 'summary', 'rules', 'worst_patient'}
    assert summary['spec']['controller'] == {'kind': 'mode', 'name': 'position', 'parameters': {}}
    assert (summary['status'], summary['rules'][0]['rule']) == (1, FORCE_RULE)
    peak = [
        max(float(row[f'peak_force_n.{joint}']) for joint in ('mcp', 'pip', 'dip')) for row in rows
    ]
    assert summary['worst_patient'] == summary['rules'][0]['worst_patient'] == int(np.argmax(peak))
    assert summary['summary']['metrics']['peak_force_n']['worst'][0]['value'] == max(peak)


def test_a_report_never_goes_into_a_folder_with_files(capsys, tmp_path):
    (tmp_path / 'old.txt').write_text('mine')
    code, _, err = run(capsys, '--out', str(tmp_path), '--no-figures')
    assert code == 2
    assert 'is not an empty folder' in err
    assert [path.name for path in tmp_path.iterdir()] == ['old.txt']


def test_help_has_examples(capsys):
    with pytest.raises(SystemExit):
        main(['trial', '--help'])
    text = capsys.readouterr().out
    assert 'exodigit trial --population stroke_moderate' in text
    assert 'exit status: 0 every rule passed, 1 a rule failed, 2 bad input' in text


def test_the_ray_engine_without_ray_exits_2_naming_the_extra(capsys, monkeypatch):
    """The command where ``ray`` cannot be imported (the extra not installed): in this process,
    with ``sys.modules['ray'] = None`` for the test (Python then refuses ``import ray``)."""
    monkeypatch.setitem(sys.modules, 'ray', None)
    code, out, err = run(capsys, '--engine', 'ray')
    assert (code, out) == (2, '')
    assert err.strip().splitlines() == [
        'exodigit trial: error: ray is not installed; install the extra with: '
        'pip install "./exodigit_model[ray]"'
    ]
