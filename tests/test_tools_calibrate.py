"""``exodigit calibrate``: round trips from known parameters plus noise, and refused fits."""

import csv

import numpy as np
import pytest
from exodigit_model.tools import calibration
from exodigit_model.tools._deps import ToolError
from exodigit_model.tools.cli import main

from exodigit_model import JOINT_NAMES, GloveModel, dump_params, load_params, params_from_dict

#: A fitted value must lie within this many reported standard errors of the truth.
STANDARD_ERRORS = 3.0
ANGLE_NOISE_DEG = 0.3
FORCE_NOISE_N = 0.01

HEADER = [
    *(f'p_{n}_kpa' for n in JOINT_NAMES),
    *(f'q_{n}_deg' for n in JOINT_NAMES),
    *(f'f_{n}_n' for n in JOINT_NAMES),
    'condition',
]


def true_params(c=(1.35e5, 1.2e4, 2e3), k=(0.055, 0.022, 0.012)):
    data = load_params().to_dict()
    data['material'].update(c1=c[0], c2=c[1], c3=c[2])
    for joint, stiffness in zip(data['finger']['joints'], k, strict=True):
        joint['stiffness'] = stiffness
    return params_from_dict(data)


def synthetic_rows(params, samples, free_every=3, seed=1):
    """Samples solved independently by GloveModel.solve, angles and forces with noise."""
    model = GloveModel(params)
    rng = np.random.default_rng(seed)
    rows = []
    for index in range(samples):
        pressure = rng.uniform(0.0, 50e3, 3)
        free = index % free_every == 0
        solution = model.solve(pressure, free=free)
        angles = np.degrees(solution.q) + rng.normal(0, ANGLE_NOISE_DEG, 3)
        forces = solution.forces + rng.normal(0, FORCE_NOISE_N, 3)
        rows.append(
            [
                *(pressure / 1e3),
                *angles,
                *(['', '', ''] if free else forces),
                'free' if free else 'finger',
            ]
        )
    return rows


def write_csv(path, rows, header=HEADER):
    with open(path, 'w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(rows)
    return path


def reported(stdout, name):
    """(value, standard error) of ``name`` from the report line ``name a -> b ± c unit``."""
    line = next(line for line in stdout.splitlines() if line.split()[0:1] == [name])
    after = line.split('->')[1].split()
    return float(after[0]), float(after[2])


def check_round_trip(stdout, out, truth, names):
    """Reported values within STANDARD_ERRORS of ``truth`` (display units: kPa, N·m/rad)."""
    data = load_params(out).to_dict()
    for name, true_value in zip(names, truth, strict=True):
        value, error = reported(stdout, name)
        if name.startswith('k_'):
            written = data['finger']['joints'][JOINT_NAMES.index(name[2:])]['stiffness']
        else:
            written = data['material'][name] / 1e3
        assert written == pytest.approx(value, rel=1e-4, abs=1e-9)
        assert error > 0
        assert abs(value - true_value) <= STANDARD_ERRORS * error, (name, value, error)


def test_stiffness_round_trip(tmp_path, capsys):
    truth = true_params()
    params_file = tmp_path / 'material.yaml'
    start = true_params(k=(0.04, 0.03, 0.015))  # the right material, the default stiffness
    dump_params(start, params_file)
    data = write_csv(tmp_path / 'bench.csv', synthetic_rows(truth, 30))
    out = tmp_path / 'fit.yaml'
    code = main(
        [
            'calibrate',
            str(data),
            '--params',
            str(params_file),
            '--fit',
            'stiffness',
            '--out',
            str(out),
        ]
    )
    stdout = capsys.readouterr().out
    assert code == 0
    check_round_trip(stdout, out, [0.055, 0.022, 0.012], [f'k_{n}' for n in JOINT_NAMES])
    assert (tmp_path / 'fit_fit.png').is_file()


def test_stiffness_fit_is_the_models_linear_identification(tmp_path):
    """One implementation: the CLI's numbers are GloveModel.fit_stiffness on the finger rows."""
    truth = true_params()
    path = write_csv(tmp_path / 'bench.csv', synthetic_rows(truth, 12))
    samples = calibration.read_samples(path)
    result = calibration.fit(truth, samples, 'stiffness')
    finger = ~samples.free
    direct = GloveModel(truth).fit_stiffness(samples.angles[finger], samples.pressure[finger])
    np.testing.assert_array_equal(result.value, direct.stiffness)
    np.testing.assert_array_equal(result.standard_error, direct.standard_error)


def test_material_round_trip(tmp_path, capsys):
    truth = true_params(k=(0.04, 0.03, 0.015))  # the default stiffness, a different material
    data = write_csv(tmp_path / 'bench.csv', synthetic_rows(truth, 24))
    out = tmp_path / 'material.yaml'
    assert main(['calibrate', str(data), '--fit', 'material', '--out', str(out)]) == 0
    stdout = capsys.readouterr().out
    check_round_trip(stdout, out, [135.0, 12.0, 2.0], ['c1', 'c2', 'c3'])
    before = float(stdout.split('angle RMSE: ')[1].split()[0])
    after = float(stdout.split('deg before, ')[1].split()[0])
    assert after < before and after < 2 * ANGLE_NOISE_DEG


def test_both_round_trip(tmp_path, capsys):
    truth = true_params()
    data = write_csv(tmp_path / 'bench.csv', synthetic_rows(truth, 24))
    out = tmp_path / 'both.yaml'
    assert main(['calibrate', str(data), '--fit', 'both', '--out', str(out)]) == 0
    stdout = capsys.readouterr().out
    names = ['c1', 'c2', 'c3', *(f'k_{n}' for n in JOINT_NAMES)]
    check_round_trip(stdout, out, [135.0, 12.0, 2.0, 0.055, 0.022, 0.012], names)


def zero_pressure_rows(count):
    return [[0, 0, 0, 0.1, -0.1, 0.0, '', '', '', 'finger'] for _ in range(count)]


@pytest.mark.parametrize(
    ('mode', 'rows', 'fragment'),
    [
        ('material', lambda: zero_pressure_rows(10), 'samples with a pressure > 0, got 0'),
        ('material', lambda: synthetic_rows(true_params(), 3), 'at least 4 samples'),
        ('stiffness', lambda: synthetic_rows(true_params(), 6, free_every=1), '2 finger samples'),
        ('both', lambda: synthetic_rows(true_params(), 6, free_every=1), '2 finger samples'),
        (
            'stiffness',
            lambda: [[10, 0, 0, 5, 0, 0, '', '', '', 'finger']] * 5,
            'mcp joint barely moved',
        ),
    ],
)
def test_ill_posed_fits_are_refused(mode, rows, fragment, tmp_path, capsys):
    data = write_csv(tmp_path / 'bench.csv', rows())
    code = main(['calibrate', str(data), '--fit', mode, '--out', str(tmp_path / 'x.yaml')])
    err = capsys.readouterr().err.strip()
    assert code == 2 and fragment in err and '\n' not in err
    assert not (tmp_path / 'x.yaml').exists()


def test_singular_jacobian_names_the_inseparable_parameters():
    parameters = calibration.material_parameters()
    column = np.linspace(1.0, 2.0, 12)
    jacobian = np.column_stack([column, 2 * column, np.cos(column)])
    with pytest.raises(ToolError, match=r'cannot separate c1, c2'):
        calibration._standard_errors(jacobian, np.ones(12), parameters)
    with pytest.raises(ToolError, match=r'do not depend on c3'):
        calibration._standard_errors(
            np.column_stack([column, np.sin(column), 0 * column]), np.ones(12), parameters
        )


@pytest.mark.parametrize(
    ('header', 'row', 'fragment'),
    [
        (HEADER[:5], [0, 0, 0, 0, 0], 'missing column(s) q_dip_deg'),
        ([*HEADER, 'time'], [0] * 9 + ['finger', 1], 'unknown column(s) time'),
        (HEADER, [0, 0, 'x', 0, 0, 0, '', '', '', 'finger'], 'line 2, column p_dip_kpa'),
        (HEADER, [0, 0, 0, 0, 0, 0, '', '', '', 'palm'], "'palm', expected free or finger"),
        (HEADER, [0, -3, 0, 0, 0, 0, '', '', '', 'finger'], '>= 0 kPa'),
    ],
)
def test_bad_csv_is_one_line(header, row, fragment, tmp_path, capsys):
    data = write_csv(tmp_path / 'bench.csv', [row], header)
    assert main(['calibrate', str(data), '--out', str(tmp_path / 'x.yaml')]) == 2
    err = capsys.readouterr().err.strip()
    assert fragment in err and '\n' not in err
