"""``exodigit calibrate``: round trips from known parameters plus noise, and refused fits.

Every round trip writes its real fit figure (about 0.3 s of matplotlib) and checks the PNG:
one row of panels per measured quantity. The figure's data is checked panel by panel against
the CSV and single solves in test_the_fit_figure_shows_each_measured_value_against_the_models.
"""

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from exodigit_model.extras import ToolError
from exodigit_model.tools import calibration, figures
from exodigit_model.tools.cli import main
from PIL import Image

from exodigit_model import JOINT_NAMES, GloveModel, dump_params, load_params, params_from_dict

#: A fitted value must lie within this many reported standard errors of the truth.
STANDARD_ERRORS = 3.0
ANGLE_NOISE_DEG = 0.3
FORCE_NOISE_N = 0.01
LENGTH_NOISE_MM = 0.2
#: Residuals against independent single solves (deg or mm, solver tolerance).
RESIDUAL_TOLERANCE = 1e-6

HEADER = [
    *(f'p_{n}_kpa' for n in JOINT_NAMES),
    *(f'q_{n}_deg' for n in JOINT_NAMES),
    *(f'f_{n}_n' for n in JOINT_NAMES),
    'condition',
]
LENGTHS = [f'l_{n}_mm' for n in JOINT_NAMES]
HEADER_WITH_LENGTHS = [*HEADER[:-1], *LENGTHS, 'condition']


def true_params(c=(1.35e5, 1.2e4, 2e3), k=(0.055, 0.022, 0.012), layers=(math.inf,) * 3):
    data = load_params().to_dict()
    data['material'].update(c1=c[0], c2=c[1], c3=c[2])
    for joint, stiffness in zip(data['finger']['joints'], k, strict=True):
        joint['stiffness'] = stiffness
    for segment, layer in zip(data['exo_digit']['segments'], layers, strict=True):
        segment['layer_axial_stiffness'] = layer
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


def with_lengths(params, rows, measured=(0, 1, 2), seed=2):
    """``rows`` (from synthetic_rows) with the bottom-face lengths, mm, of GloveModel.solve."""
    model = GloveModel(params)
    rng = np.random.default_rng(seed)
    out = []
    for row in rows:
        pressure = np.array(row[:3], dtype=float) * 1e3
        solution = model.solve(pressure, free=row[-1] == 'free')
        lengths = solution.lengths * 1e3 + rng.normal(0, LENGTH_NOISE_MM, 3)
        cells = [lengths[k] if k in measured else '' for k in range(3)]
        out.append([*row[:-1], *cells, row[-1]])
    return out


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
    """Reported values within STANDARD_ERRORS of ``truth`` (display units: kPa, N·m/rad, N)."""
    data = load_params(out).to_dict()
    for name, true_value in zip(names, truth, strict=True):
        value, error = reported(stdout, name)
        if name.startswith('k_'):
            written = data['finger']['joints'][JOINT_NAMES.index(name[2:])]['stiffness']
        elif name.startswith('EL_'):
            segment = data['exo_digit']['segments'][JOINT_NAMES.index(name[3:])]
            written = segment['layer_axial_stiffness']
        else:
            written = data['material'][name] / 1e3
        assert written == pytest.approx(value, rel=1e-4, abs=1e-9)
        assert error > 0
        assert abs(value - true_value) <= STANDARD_ERRORS * error, (name, value, error)


def figure_rows(path):
    """Rows of panels of the fit figure in the PNG at ``path`` (12 in wide, 3.8 in a row)."""
    with Image.open(path) as image:
        assert image.format == 'PNG'
        width, height = image.size
    row = round(3.8 * figures.DPI)
    assert width == 12 * figures.DPI and height % row == 0, (width, height)
    return height // row


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
    assert figure_rows(tmp_path / 'fit_fit.png') == 2  # angles, forces


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


def test_the_fit_figure_shows_each_measured_value_against_the_models(tmp_path):
    """Panel by panel: the CSV's values against single solves of the glove before and after.

    Any two gloves do (the figure draws what it is given): the default finger as before, the
    truth with an extensible MCP as after; MCP lengths only, forces on the finger rows only.
    """
    before = true_params(k=(0.04, 0.03, 0.015))
    after = true_params(layers=(30.0, math.inf, math.inf))
    rows = with_lengths(after, synthetic_rows(after, 6), measured=(0,))
    samples = calibration.read_samples(write_csv(tmp_path / 'b.csv', rows, HEADER_WITH_LENGTHS))
    path = tmp_path / 'fit.png'
    figure = calibration.write_fit_figure(
        samples,
        calibration.predict(GloveModel(before), samples),
        calibration.predict(GloveModel(after), samples),
        path,
    )
    # what it must show, in display units: measured (the CSV; '' not measured), each model's
    # single solve of every row
    measured = np.array([[np.nan if cell == '' else cell for cell in row[3:12]] for row in rows])
    models = {}
    for name, params in (('before', before), ('fitted', after)):
        model = GloveModel(params)
        solutions = [model.solve(np.array(row[:3]) * 1e3, free=row[-1] == 'free') for row in rows]
        models[name] = np.array(
            [[*np.degrees(s.q), *s.forces, *(s.lengths * 1e3)] for s in solutions]
        )
    quantities = (('angle', 'deg'), ('force', 'N'), ('length', 'mm'))
    axes = np.reshape(figure.axes, (3, 3))
    for row, ((quantity, unit), row_axes) in enumerate(zip(quantities, axes, strict=True)):
        for joint, ax in enumerate(row_axes):
            column = 3 * row + joint
            assert ax.get_title() == f'{JOINT_NAMES[joint].upper()} {quantity}'
            shown = ~np.isnan(measured[:, column])
            if not shown.any():  # the PIP and DIP lengths
                assert (quantity, joint) in (('length', 1), ('length', 2))
                assert not ax.lines and [text.get_text() for text in ax.texts] == ['not measured']
                continue
            assert (ax.get_xlabel(), ax.get_ylabel()) == (f'measured ({unit})', f'model ({unit})')
            diagonal, *points = ax.lines
            x = measured[shown, column]
            values = [x]
            for line, (name, model) in zip(points, models.items(), strict=True):
                assert line.get_label() == name
                np.testing.assert_allclose(line.get_xdata(), x, atol=RESIDUAL_TOLERANCE)
                y = model[shown, column]
                np.testing.assert_allclose(line.get_ydata(), y, atol=RESIDUAL_TOLERANCE)
                values.append(y)
            low, high = np.min(values), np.max(values)
            np.testing.assert_allclose(
                diagonal.get_xydata(), [[low, low], [high, high]], atol=RESIDUAL_TOLERANCE
            )
    assert np.count_nonzero(~np.isnan(measured[:, 3])) == 4  # forces on the four finger rows
    assert figure_rows(path) == 3


def test_material_round_trip(tmp_path, capsys):
    truth = true_params(k=(0.04, 0.03, 0.015))  # the default stiffness, a different material
    data = write_csv(tmp_path / 'bench.csv', synthetic_rows(truth, 24))
    out = tmp_path / 'material.yaml'
    assert main(['calibrate', str(data), '--fit', 'material', '--out', str(out)]) == 0
    assert figure_rows(tmp_path / 'material_fit.png') == 2  # angles, forces
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
    assert figure_rows(tmp_path / 'both_fit.png') == 2  # angles, forces
    stdout = capsys.readouterr().out
    names = ['c1', 'c2', 'c3', *(f'k_{n}' for n in JOINT_NAMES)]
    check_round_trip(stdout, out, [135.0, 12.0, 2.0, 0.055, 0.022, 0.012], names)


def zero_pressure_rows(count):
    return [[0, 0, 0, 0.1, -0.1, 0.0, '', '', '', 'finger'] for _ in range(count)]


@pytest.mark.parametrize(
    ('mode', 'rows', 'fragment'),
    [
        ('material', lambda: zero_pressure_rows(10), 'samples with a pressure > 0, got 0'),
        ('material', lambda: synthetic_rows(true_params(), 1), 'at least 4 measured values'),
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


def run_calibrate(tmp_path, rows, mode, header=HEADER_WITH_LENGTHS, params=None):
    data = write_csv(tmp_path / 'bench.csv', rows, header)
    out = tmp_path / f'{mode}.yaml'
    extra = [] if params is None else ['--params', str(params)]
    code = main(['calibrate', str(data), '--fit', mode, '--out', str(out), *extra])
    return code, out


def rmse_after(stdout, what):
    return float(stdout.split(f'{what} RMSE: ')[1].split(' before, ')[1].split()[0])


def test_layer_round_trip(tmp_path, capsys):
    """E_L of three segments from lengths and angles; --params has them inextensible (.inf)."""
    material = true_params(k=(0.04, 0.03, 0.015))  # the default finger, the true material
    truth = true_params(k=(0.04, 0.03, 0.015), layers=(40.0, 60.0, 25.0))
    params_file = tmp_path / 'material.yaml'
    dump_params(material, params_file)
    rows = with_lengths(truth, synthetic_rows(truth, 18))
    code, out = run_calibrate(tmp_path, rows, 'layer', params=params_file)
    stdout = capsys.readouterr().out
    assert code == 0
    names = [f'EL_{n}' for n in JOINT_NAMES]
    check_round_trip(stdout, out, [40.0, 60.0, 25.0], names)
    assert [line.split()[1] for line in stdout.splitlines() if line.split()[0] in names] == [
        'inf'
    ] * 3
    assert rmse_after(stdout, 'length') < 2 * LENGTH_NOISE_MM
    assert rmse_after(stdout, 'angle') < 2 * ANGLE_NOISE_DEG
    assert figure_rows(tmp_path / 'layer_fit.png') == 3  # angles, forces, lengths


def test_layer_and_material_round_trip(tmp_path, capsys):
    """Yeoh C1..C3 and the MCP layer together; only the MCP length is measured."""
    truth = true_params(k=(0.04, 0.03, 0.015), layers=(30.0, math.inf, math.inf))
    rows = with_lengths(truth, synthetic_rows(truth, 18), measured=(0,))
    code, out = run_calibrate(tmp_path, rows, 'layer+material')
    stdout = capsys.readouterr().out
    assert code == 0
    assert figure_rows(tmp_path / 'layer+material_fit.png') == 3  # angles, forces, lengths
    check_round_trip(stdout, out, [135.0, 12.0, 2.0, 30.0], ['c1', 'c2', 'c3', 'EL_mcp'])
    segments = load_params(out).exo_digit.segments
    assert [s.layer_axial_stiffness for s in segments[1:]] == [math.inf, math.inf]
    assert rmse_after(stdout, 'length') < 2 * LENGTH_NOISE_MM


def test_layer_and_scale_round_trip(tmp_path, capsys):
    """One factor on the Yeoh coefficients and the MCP layer, from MCP-only samples."""
    truth = true_params(
        c=(0.5 * 1.1e5, 0.5 * 2e4, 0.0), k=(0.04, 0.03, 0.015), layers=(15.0, math.inf, math.inf)
    )
    model = GloveModel(truth)
    rng = np.random.default_rng(3)
    rows = []
    for kpa in (10, 20, 30, 40, 50):
        for condition in ('free', 'finger'):
            solution = model.solve([kpa * 1e3, 0, 0], free=condition == 'free')
            angle = np.degrees(solution.q[0]) + rng.normal(0, ANGLE_NOISE_DEG)
            length = solution.lengths[0] * 1e3 + rng.normal(0, LENGTH_NOISE_MM)
            rows.append([kpa, 0, 0, angle, '', '', '', '', '', length, '', '', condition])
    code, out = run_calibrate(tmp_path, rows, 'layer+scale')
    stdout = capsys.readouterr().out
    assert code == 0
    assert figure_rows(tmp_path / 'layer+scale_fit.png') == 2  # angles, lengths (no forces)
    value, error = reported(stdout, 'scale')
    assert abs(value - 0.5) <= STANDARD_ERRORS * error
    value, error = reported(stdout, 'EL_mcp')
    assert abs(value - 15.0) <= STANDARD_ERRORS * error
    material = load_params(out).material
    assert material.c1 == pytest.approx(1.1e5 * reported(stdout, 'scale')[0], rel=1e-4)
    assert material.c2 / material.c1 == pytest.approx(2e4 / 1.1e5, rel=1e-12)
    assert rmse_after(stdout, 'length') < 2 * LENGTH_NOISE_MM
    assert rmse_after(stdout, 'angle') < 2 * ANGLE_NOISE_DEG


def test_residuals_weigh_lengths_in_mm_against_single_solves(tmp_path):
    """residuals(): angle misfits in deg, then lengths in mm / LENGTH_PER_DEGREE."""
    truth = true_params(layers=(30.0, 50.0, math.inf))
    rows = with_lengths(truth, synthetic_rows(truth, 5), measured=(0, 1))
    for row in rows:
        row[6:9] = ['', '', '']  # no forces
    samples = calibration.read_samples(write_csv(tmp_path / 'b.csv', rows, HEADER_WITH_LENGTHS))
    model = GloveModel(true_params(layers=(20.0, 80.0, math.inf)))
    expected_angles, expected_lengths = [], []
    for row in rows:
        solution = model.solve(np.array(row[:3], dtype=float) * 1e3, free=row[-1] == 'free')
        expected_angles += list(np.degrees(solution.q) - np.array(row[3:6], dtype=float))
        expected_lengths += list(solution.lengths[:2] * 1e3 - np.array(row[9:11], dtype=float))
    residual = calibration.residuals(model, samples)
    np.testing.assert_allclose(
        residual,
        [*expected_angles, *(np.array(expected_lengths) / calibration.LENGTH_PER_DEGREE)],
        atol=RESIDUAL_TOLERANCE,
    )


@pytest.mark.parametrize('mode', ['layer', 'layer+scale', 'layer+material'])
def test_layer_fit_without_lengths_is_refused(mode, tmp_path, capsys):
    rows = synthetic_rows(true_params(), 8)
    code, out = run_calibrate(tmp_path, rows, mode, header=HEADER)
    err = capsys.readouterr().err.strip()
    assert code == 2 and '\n' not in err
    assert err.endswith(
        f'--fit {mode} needs measured bottom-face lengths (mm): '
        'missing column(s) l_mcp_mm, l_pip_mm, l_dip_mm'
    )
    assert not out.exists()
    empty = [[*row[:-1], '', row[-1]] for row in rows]
    code, out = run_calibrate(tmp_path, empty, mode, header=[*HEADER[:-1], 'l_pip_mm', HEADER[-1]])
    err = capsys.readouterr().err.strip()
    assert code == 2 and '\n' not in err
    assert err.endswith('column(s) l_pip_mm have no values')


def test_unmeasured_cells_are_skipped_and_empty_rows_refused(tmp_path, capsys):
    header = [*HEADER[:-1], 'l_mcp_mm', 'condition']
    rows = [
        [50, 0, 0, '', '', '', '', '', '', 52.0, 'finger'],
        [50, 0, 0, 61, '', '', '', '', '', '', 'free'],
    ]
    samples = calibration.read_samples(write_csv(tmp_path / 'a.csv', rows, header))
    assert samples.measured().tolist() == [1, 1]
    assert np.isnan(samples.angles[0]).all() and samples.lengths[0, 0] == pytest.approx(0.052)
    rows.append([10, 0, 0, '', '', '', '', '', '', '', 'finger'])
    data = write_csv(tmp_path / 'b.csv', rows, header)
    assert main(['calibrate', str(data), '--out', str(tmp_path / 'x.yaml')]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith('line 4: nothing measured (no angle, force or length)')


def test_the_fig12_worked_example_is_what_the_docs_show(tmp_path, capsys):
    """docs/extensible.md: its command writes its YAML, and the glove meets Fig. 12."""
    docs = Path(__file__).resolve().parents[1] / 'docs'
    out = tmp_path / 'fig12.yaml'
    data = str(docs / 'fig12_mcp.csv')
    assert main(['calibrate', data, '--fit', 'layer+scale', '--out', str(out)]) == 0
    capsys.readouterr()
    assert figure_rows(tmp_path / 'fig12_fit.png') == 2  # angles, lengths
    fitted, shipped = load_params(out), load_params(docs / 'extensible' / 'fig12_calibrated.yaml')
    assert fitted.material.c1 == pytest.approx(shipped.material.c1, rel=1e-6)
    assert fitted.material.c2 == pytest.approx(shipped.material.c2, rel=1e-6)
    layers = [s.layer_axial_stiffness for s in fitted.exo_digit.segments]
    assert layers == [s.layer_axial_stiffness for s in shipped.exo_digit.segments]
    assert layers == [0.0, math.inf, math.inf]  # no layer: on its bound
    model = GloveModel(fitted)
    on_finger = model.solve([50e3, 0.0, 0.0])
    assert abs(on_finger.lengths[0] * 1e3 - 62.2) < 1.0  # Fig. 12, within 1 mm
    assert abs(np.degrees(model.solve([50e3, 0.0, 0.0], free=True).q[0]) - 61.0) < 1.0
