"""``exodigit curves`` and the CLI's help and error paths, checked against independent solves.

Every ``exodigit curves`` here writes its four real figures (about 0.3 s each); the figures'
data, labels and titles are checked line by line against single solves and the arc chord of
docs/spec/model.md eq 4 (the ``drawn`` fixture).
"""

import csv
import subprocess
import sys

import numpy as np
import pytest
from exodigit_model.tools import figures
from exodigit_model.tools.cli import EXAMPLES, main
from exodigit_model.tools.curves import simulate, sweep_markers
from png_files import png_size

from exodigit_model import JOINT_NAMES, GloveModel, load_params, patient_file

#: CSV (9 significant digits) and plotted angles, deg, against single solves.
ANGLE_TOLERANCE_DEG = 1e-6
#: CSV (9 significant digits) and plotted forces, N, against single solves.
FORCE_TOLERANCE_N = 1e-8
#: Marker positions (mm) against the closed-form arc chord of docs/spec/model.md eq 4.
MARKER_TOLERANCE_MM = 1e-5
#: CSV (9 significant digits) and plotted lengths, mm, against single solves.
LENGTH_TOLERANCE_MM = 1e-6

#: A glove whose MCP and PIP bottom faces stretch (docs/spec/model.md §12), N per unit strain.
EXTENSIBLE_GLOVE = """\
exo_digit:
  segments:
    - {layer_axial_stiffness: 20.0}
    - {layer_axial_stiffness: 0.0}
    - {}
"""

CLI = [sys.executable, '-m', 'exodigit_model.tools.cli']


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


@pytest.fixture(scope='module')
def curves(tmp_path_factory):
    folder = tmp_path_factory.mktemp('curves')
    assert main(['curves', '--out', str(folder), '--pressures', '0:45:15']) == 0
    with open(folder / 'angles.csv', newline='') as handle:
        angles = list(csv.DictReader(handle))
    with open(folder / 'markers.csv', newline='') as handle:
        markers = list(csv.DictReader(handle))
    return folder, angles, markers


def read_rows(path):
    with open(path, newline='') as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope='module')
def extensible(tmp_path_factory):
    """(folder, model) of ``exodigit curves`` for EXTENSIBLE_GLOVE."""
    folder = tmp_path_factory.mktemp('extensible')
    glove = folder / 'glove.yaml'
    glove.write_text(EXTENSIBLE_GLOVE)
    arguments = ['--params', str(glove), '--out', str(folder), '--pressures', '0:50:25']
    assert main(['curves', *arguments]) == 0
    return folder, GloveModel(load_params(glove))


def chamber_pressures(experiment, kpa):
    pressure = np.zeros(3)
    if experiment == 'all':
        pressure[:] = kpa * 1e3
    else:
        pressure[JOINT_NAMES.index(experiment)] = kpa * 1e3
    return pressure


def test_angles_csv_equals_single_solves(curves, model):
    _, rows, _ = curves
    seen = set()
    for row in rows:
        pressure = chamber_pressures(row['experiment'], float(row['pressure_kpa']))
        solution = model.solve(pressure, free=row['condition'] == 'free')
        angles = [float(row[f'q_{name}_deg']) for name in JOINT_NAMES]
        forces = [float(row[f'f_{name}_n']) for name in JOINT_NAMES]
        np.testing.assert_allclose(angles, np.degrees(solution.q), atol=ANGLE_TOLERANCE_DEG)
        np.testing.assert_allclose(forces, solution.forces, atol=FORCE_TOLERANCE_N)
        assert row['converged'] == str(int(solution.converged))
        seen.add((row['experiment'], row['condition'], float(row['pressure_kpa'])))
    expected = {
        (experiment, condition, kpa)
        for experiment in (*JOINT_NAMES, 'all')
        for condition in ('free', 'finger')
        for kpa in (0.0, 15.0, 30.0, 45.0)
    }
    assert seen == expected


def test_free_bending_moves_only_the_pressurised_module(curves):
    _, rows, _ = curves
    for row in rows:
        if row['condition'] == 'free' and row['experiment'] != 'all':
            others = [n for n in JOINT_NAMES if n != row['experiment']]
            assert all(float(row[f'q_{n}_deg']) == 0.0 for n in others)
            assert all(float(row[f'f_{n}_n']) == 0.0 for n in JOINT_NAMES)


def arc_markers(angle, length, block):
    """Markers 3 and 4 of a module bent by ``angle`` (rad), mm: the chord of a circular arc of
    bottom-face length ``length`` (eq 4), then the block of length ``block`` along its end."""
    if angle == 0.0:
        chord = np.array([length, 0.0])
    else:
        chord = length / angle * np.array([np.sin(angle), 1 - np.cos(angle)])
    return chord, chord + block * np.array([np.cos(angle), np.sin(angle)])


def test_free_markers_follow_the_arc_chord(curves, model):
    """Markers 3, 4 of a module bent alone: chord of a circular arc (eq 4), then its block."""
    _, _, rows = curves
    segments = model.params.exo_digit.segments
    free_rows = [r for r in rows if r['condition'] == 'free']
    assert len(free_rows) == 12
    for row in free_rows:
        module = JOINT_NAMES.index(row['module'])
        q = model.solve(chamber_pressures(row['module'], float(row['pressure_kpa'])), free=True)
        length = segments[module].arc_length * 1e3
        block = 2 * segments[module].block_half_length * 1e3
        chord, tip = arc_markers(q.q[module], length, block)
        marker3 = [float(row['marker3_x_mm']), float(row['marker3_y_mm'])]
        marker4 = [float(row['marker4_x_mm']), float(row['marker4_y_mm'])]
        np.testing.assert_allclose(marker3, chord, atol=MARKER_TOLERANCE_MM)
        np.testing.assert_allclose(marker4, tip, atol=MARKER_TOLERANCE_MM)
        assert float(row['marker2_x_mm']) == 0.0 and float(row['marker2_y_mm']) == 0.0


#: The figures ``exodigit curves`` writes.
FIGURES = ('angles.png', 'forces.png', 'lengths.png', 'markers.png')


def assert_figures_written(folder, names=FIGURES):
    """Each of ``names`` in ``folder`` is a PNG of at least 800 x 300 pixels."""
    for name in names:
        width, height = png_size(folder / name)
        assert width >= 800 and height >= 300, name


def test_curves_figures_are_written(curves):
    folder, _, _ = curves
    assert_figures_written(folder)


@pytest.mark.parametrize(
    'spec', ['0:50', 'a:b:c', '10:0:5', '0:50:0', '-10:50:10', '0:inf:1', '0:1e9:0.001']
)
def test_bad_pressure_sweep_is_one_line_and_exit_2(spec, tmp_path, capsys):
    assert main(['curves', '--out', str(tmp_path), f'--pressures={spec}']) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith('exodigit curves: error: --pressures') and '\n' not in err


@pytest.mark.parametrize(
    ('text', 'fragment'), [('material: {c1: -5}\n', 'c1'), ('material: [\n', 'YAML')]
)
def test_bad_params_file_is_one_line(text, fragment, tmp_path, capsys):
    bad = tmp_path / 'bad.yaml'
    bad.write_text(text)
    assert main(['curves', '--params', str(bad), '--out', str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert fragment in err and '\n' not in err


def test_help_shows_an_example_for_every_subcommand(capsys):
    # The installed command once (its entry point), each subcommand's help in process.
    result = subprocess.run([*CLI, '--help'], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0
    for example in EXAMPLES.values():
        assert example in result.stdout
    for command, example in EXAMPLES.items():
        with pytest.raises(SystemExit) as done:
            main([command, '--help'])
        assert done.value.code == 0 and example in capsys.readouterr().out


def test_missing_matplotlib_says_what_to_install(tmp_path):
    script = (
        'import sys; sys.modules["matplotlib"] = None; '
        'from exodigit_model.tools.cli import main; '
        f'sys.exit(main(["draw", "--pressure", "10", "--out", r"{tmp_path / "g.png"}"]))'
    )
    result = subprocess.run(
        [sys.executable, '-c', script], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        'exodigit draw: error: matplotlib is not installed; install the tools with: '
        'pip install "./exodigit_model[tools]"'
    ]


def test_curves_for_a_patient_preset_are_the_patients_solves(tmp_path, capsys):
    assert (
        main(
            [
                'curves',
                '--patient',
                'stroke_severe',
                '--out',
                str(tmp_path),
                '--pressures',
                '0:40:20',
            ]
        )
        == 0
    )
    assert_figures_written(tmp_path)
    patient = GloveModel(load_params(patient_file('stroke_severe')))
    with open(tmp_path / 'angles.csv', newline='') as handle:
        rows = [r for r in csv.DictReader(handle) if r['condition'] == 'finger']
    assert rows
    for row in rows:
        pressure = chamber_pressures(row['experiment'], float(row['pressure_kpa']))
        angles = [float(row[f'q_{name}_deg']) for name in JOINT_NAMES]
        np.testing.assert_allclose(
            angles, np.degrees(patient.solve(pressure).q), atol=ANGLE_TOLERANCE_DEG
        )
    # the severe finger rests flexed: at 0 kPa on the finger the joints are bent
    rest = next(r for r in rows if float(r['pressure_kpa']) == 0.0)
    assert float(rest['q_mcp_deg']) > 20.0


def test_inextensible_lengths_are_the_rest_lengths(curves, model):
    """The paper's constant arc length: every row of lengths.csv is the rest length."""
    folder, angles, _ = curves
    rows = read_rows(folder / 'lengths.csv')
    assert [(r['experiment'], r['condition'], r['pressure_kpa']) for r in rows] == [
        (r['experiment'], r['condition'], r['pressure_kpa']) for r in angles
    ]
    rest = [s.arc_length * 1e3 for s in model.params.exo_digit.segments]
    for row in rows:
        assert [float(row[f'l_{name}_mm']) for name in JOINT_NAMES] == rest


def test_lengths_csv_equals_single_solves(extensible):
    folder, model = extensible
    rows = read_rows(folder / 'lengths.csv')
    assert len(rows) == 4 * 2 * 3
    for row in rows:
        pressure = chamber_pressures(row['experiment'], float(row['pressure_kpa']))
        solution = model.solve(pressure, free=row['condition'] == 'free')
        lengths = [float(row[f'l_{name}_mm']) for name in JOINT_NAMES]
        np.testing.assert_allclose(lengths, solution.lengths * 1e3, atol=LENGTH_TOLERANCE_MM)
        assert row['converged'] == str(int(solution.converged))
    # the extensible segments do stretch, more on the finger than free (docs/spec/model.md §12)
    top = {
        r['condition']: float(r['l_mcp_mm'])
        for r in rows
        if r['experiment'] == 'mcp' and r['pressure_kpa'] == '50'
    }
    assert 46.0 < top['free'] < top['finger']
    assert all(float(r['l_dip_mm']) == 15.0 for r in rows)
    assert_figures_written(folder)


def test_extensible_markers_follow_the_arc_chord_at_its_length(extensible):
    """Marker 3 of a stretched module is the chord of an arc of the solved length ℓ."""
    folder, model = extensible
    rows = [r for r in read_rows(folder / 'markers.csv') if r['module'] in ('mcp', 'pip')]
    assert len(rows) == 2 * 2 * 3
    segments = model.params.exo_digit.segments
    for row in rows:
        module = JOINT_NAMES.index(row['module'])
        pressure = chamber_pressures(row['module'], float(row['pressure_kpa']))
        solution = model.solve(pressure, free=row['condition'] == 'free')
        block = 2 * segments[module].block_half_length * 1e3
        chord, tip = arc_markers(solution.q[module], solution.lengths[module] * 1e3, block)
        marker3 = [float(row['marker3_x_mm']), float(row['marker3_y_mm'])]
        marker4 = [float(row['marker4_x_mm']), float(row['marker4_y_mm'])]
        np.testing.assert_allclose(marker3, chord, atol=MARKER_TOLERANCE_MM)
        np.testing.assert_allclose(marker4, tip, atol=MARKER_TOLERANCE_MM)


# -- the figures' data ---------------------------------------------------------------------

#: The paper's Fig. 12 (docs/extensible.md): the MCP module on the finger, (kPa, mm).
FIG12 = [(0.0, 46.0), (50.0, 62.2)]
CONDITIONS = ('free', 'finger')
LABELS = [name.upper() for name in JOINT_NAMES]


@pytest.fixture(scope='module')
def drawn(extensible, tmp_path_factory):
    """The four figures of ``exodigit curves`` for the extensible glove at 0, 25 and 50 kPa, as
    the command draws them; (figures by name, model, kPa)."""
    _, model = extensible
    folder = tmp_path_factory.mktemp('figures')
    kpa = np.array([0.0, 25.0, 50.0])
    sweeps = simulate(model, kpa * 1e3)
    markers = {
        (sweep.experiment, sweep.condition): sweep_markers(model, sweep)
        for sweep in sweeps
        if sweep.experiment != 'all'
    }
    rest = model.constants.arc_lengths
    drawn = {
        'angles': figures.angle_figure(sweeps, folder / 'angles.png'),
        'forces': figures.force_figure(sweeps, folder / 'forces.png'),
        'lengths': figures.length_figure(sweeps, rest, folder / 'lengths.png'),
        'markers': figures.marker_figure(markers, kpa * 1e3, folder / 'markers.png'),
    }
    assert_figures_written(folder)
    return drawn, model, kpa


def solves(model, experiment, condition, kpa):
    """Single solves of ``experiment`` (a module alone, or 'all') at each pressure, kPa."""
    free = condition == 'free'
    return [model.solve(chamber_pressures(experiment, p), free=free) for p in kpa]


def assert_lines(ax, expected, tolerance):
    """``ax``'s lines are ``expected`` [(x, y), ...], in order, within ``tolerance``."""
    assert len(ax.lines) == len(expected)
    for line, (x, y) in zip(ax.lines, expected, strict=True):
        np.testing.assert_allclose(line.get_xdata(), x, atol=tolerance)
        np.testing.assert_allclose(line.get_ydata(), y, atol=tolerance)


def test_the_angle_figure_is_each_modules_angle_free_on_the_finger_and_all(drawn):
    figures_by_name, model, kpa = drawn
    for joint, ax in enumerate(figures_by_name['angles'].axes):
        name = JOINT_NAMES[joint]
        runs = [(name, 'free'), (name, 'finger'), ('all', 'finger')]
        expected = [
            (kpa, [np.degrees(s.q[joint]) for s in solves(model, *run, kpa)]) for run in runs
        ]
        assert_lines(ax, expected, ANGLE_TOLERANCE_DEG)
        assert ax.get_title() == f'{LABELS[joint]} module'
        assert (ax.get_xlabel(), ax.get_ylabel()) == ('pressure (kPa)', f'q {LABELS[joint]} (deg)')


def test_the_force_figure_is_each_contacts_force_alone_and_all(drawn):
    figures_by_name, model, kpa = drawn
    for joint, ax in enumerate(figures_by_name['forces'].axes):
        runs = [(JOINT_NAMES[joint], 'finger'), ('all', 'finger')]
        expected = [(kpa, [s.forces[joint] for s in solves(model, *r, kpa)]) for r in runs]
        assert_lines(ax, expected, FORCE_TOLERANCE_N)
        assert ax.get_title() == f'{LABELS[joint]} contact'
        assert (ax.get_xlabel(), ax.get_ylabel()) == ('pressure (kPa)', f'f {LABELS[joint]} (N)')
        assert np.ptp(ax.lines[0].get_ydata()) > 0.1  # the contact is pressed


def test_the_length_figure_is_each_segments_length_its_rest_and_fig12(drawn):
    figures_by_name, model, kpa = drawn
    segments = model.params.exo_digit.segments
    for joint, ax in enumerate(figures_by_name['lengths'].axes):
        name = JOINT_NAMES[joint]
        runs = [(name, 'free'), (name, 'finger'), ('all', 'finger')]
        expected = [(kpa, [s.lengths[joint] * 1e3 for s in solves(model, *r, kpa)]) for r in runs]
        rest = segments[joint].arc_length * 1e3
        expected.append(([0.0, 1.0], [rest, rest]))  # a horizontal line across the axes
        if joint == 0:
            expected.append(tuple(zip(*FIG12, strict=True)))
        assert_lines(ax, expected, LENGTH_TOLERANCE_MM)
        assert ax.get_title() == f'{LABELS[joint]} segment (rest {rest:g} mm)'
        assert (ax.get_xlabel(), ax.get_ylabel()) == ('pressure (kPa)', f'l {LABELS[joint]} (mm)')


def test_the_marker_figure_is_the_arc_chord_and_block_of_each_module(drawn):
    figures_by_name, model, kpa = drawn
    segments, base = model.params.exo_digit.segments, model.params.exo_digit
    for module, ax in enumerate(figures_by_name['markers'].axes):
        # the block before the module's soft segment: the base block, or the previous module's
        half = (
            base.base_block_half_length if module == 0 else segments[module - 1].block_half_length
        )
        block = 2 * segments[module].block_half_length * 1e3
        expected = []
        for condition in CONDITIONS:
            paths = [
                arc_markers(s.q[module], s.lengths[module] * 1e3, block)
                for s in solves(model, JOINT_NAMES[module], condition, kpa)
            ]
            chords, tips = (np.array(points) for points in zip(*paths, strict=True))
            expected += [chords.T, tips.T, ([-2 * half * 1e3, 0.0], [0.0, 0.0])]
        assert_lines(ax, expected, MARKER_TOLERANCE_MM)
        assert ax.get_title() == f'{LABELS[module]} module, 50 kPa max'
        assert (ax.get_xlabel(), ax.get_ylabel()) == ('x (mm)', 'y (mm)')
