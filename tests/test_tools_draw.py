"""``exodigit draw``: picture size and the angles written on it against the solver."""

import re

import numpy as np
import pytest
from exodigit_model.tools.cli import main
from exodigit_model.tools.drawing import draw
from PIL import Image

from exodigit_model import GloveModel, load_params, params_from_dict, patient_file

#: Angles are written with one decimal (deg), lengths with one (mm), forces with two (N).
ANGLE_DECIMALS_DEG = 0.05
LENGTH_DECIMALS_MM = 0.05
FORCE_DECIMALS_N = 0.005
#: Drawn points (m) against closed forms.
POINT_TOLERANCE_M = 1e-12

#: A glove with stretching MCP and PIP bottom faces (docs/spec/model.md §12), N per unit strain.
EXTENSIBLE_GLOVE = 'exo_digit:\n  segments:\n    - {layer_axial_stiffness: 0.0}\n'
EXTENSIBLE_GLOVE += '    - {layer_axial_stiffness: 30.0}\n    - {}\n'


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


def written_numbers(text):
    angles = [float(v) for v in re.findall(r'(?:MCP|PIP|DIP) (-?[\d.]+)°', text)]
    forces = [float(v) for v in re.search(r'f = (.*) N', text).group(1).split(', ')]
    return np.radians(angles), np.array(forces)


def written_lengths(text):
    """The lengths ℓ of a caption, m, or None if it writes none."""
    found = re.search(r'ℓ = ([\d., ]+) mm', text)
    return None if found is None else np.array(found.group(1).split(', '), float) * 1e-3


@pytest.mark.parametrize('pressure', ['50', '40,20,10', '0'])
def test_picture_shows_the_solved_angles(pressure, model, tmp_path, capsys):
    out = tmp_path / 'glove.png'
    assert main(['draw', '--pressure', pressure, '--out', str(out)]) == 0
    values = [float(v) * 1e3 for v in pressure.split(',')]
    solution = model.solve(values * 3 if len(values) == 1 else values)
    image = Image.open(out)
    assert image.size == (800, 600)
    for text in (image.text['Description'], capsys.readouterr().out):
        angles, forces = written_numbers(text)
        np.testing.assert_allclose(angles, solution.q, atol=np.radians(ANGLE_DECIMALS_DEG))
        np.testing.assert_allclose(forces, solution.forces, atol=FORCE_DECIMALS_N)
        assert written_lengths(text) is None  # constant lengths are not news


@pytest.mark.parametrize(
    ('args', 'fragment'),
    [
        (['--pressure', '1,2'], '--pressure'),
        (['--pressure=-5'], '>= 0'),
        (['--pressure', 'nan'], 'finite'),
        (['--pressure', 'ten'], 'numbers'),
        (['--pressure', '10', '--out', 'glove.jpg'], 'PNG'),
        (['--pressure', '10', '--out', '/no/such/folder/g.png'], 'does not exist'),
    ],
)
def test_bad_draw_input_is_one_line(args, fragment, capsys):
    assert main(['draw', *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith('exodigit draw: error:') and fragment in err and '\n' not in err


def test_a_state_outside_the_model_is_drawn_with_a_warning(tmp_path, capsys):
    # 500 kPa (a typo for 50): the finger folds through itself; it must not look normal.
    assert main(['draw', '--pressure', '500', '--out', str(tmp_path / 'g.png')]) == 0
    err = capsys.readouterr().err
    assert 'validated range' in err and 'range of motion' in err
    assert main(['draw', '--pressure', '30', '--out', str(tmp_path / 'g.png')]) == 0
    assert capsys.readouterr().err == ''


def test_draw_takes_a_patient_preset(tmp_path, capsys):
    assert (
        main(
            [
                'draw',
                '--pressure',
                '30',
                '--patient',
                'stroke_mild',
                '--out',
                str(tmp_path / 'g.png'),
            ]
        )
        == 0
    )
    patient = GloveModel(load_params(patient_file('stroke_mild')))
    angles, _ = written_numbers(capsys.readouterr().out)
    np.testing.assert_allclose(
        angles, patient.solve([30e3] * 3).q, atol=np.radians(ANGLE_DECIMALS_DEG)
    )


@pytest.mark.parametrize('pressure', ['50', '50,0,0', '0'])
def test_extensible_glove_caption_writes_the_solved_lengths(pressure, tmp_path, capsys):
    glove = tmp_path / 'glove.yaml'
    glove.write_text(EXTENSIBLE_GLOVE)
    out = tmp_path / 'glove.png'
    assert main(['draw', '--params', str(glove), '--pressure', pressure, '--out', str(out)]) == 0
    values = [float(v) * 1e3 for v in pressure.split(',')]
    solution = GloveModel(load_params(glove)).solve(values * 3 if len(values) == 1 else values)
    for text in (Image.open(out).text['Description'], capsys.readouterr().out):
        np.testing.assert_allclose(
            written_lengths(text), solution.lengths, atol=LENGTH_DECIMALS_MM * 1e-3
        )
        angles, forces = written_numbers(text)
        np.testing.assert_allclose(angles, solution.q, atol=np.radians(ANGLE_DECIMALS_DEG))
        np.testing.assert_allclose(forces, solution.forces, atol=FORCE_DECIMALS_N)
    if pressure != '0':
        assert solution.lengths[0] > 0.050  # E_L = 0: the MCP face stretches by > 4 mm


def test_drawn_arcs_have_the_solved_lengths(tmp_path):
    """The MCP arc drawn starts at the base block's end and ends at the closed-form chord."""
    params = params_from_dict(
        {'exo_digit': {'segments': [{'layer_axial_stiffness': 0.0}, {}, {}]}}
    )
    model = GloveModel(params)
    drawing = draw(model, np.array([50e3, 0.0, 0.0]), tmp_path / 'g.png')
    q, length = drawing.solution.q[0], drawing.solution.lengths[0]
    start = np.array([2 * params.exo_digit.base_block_half_length, 0.0])
    chord = length / q * np.array([np.sin(q), 1.0 - np.cos(q)])
    arc = drawing.pose.arcs[0]
    np.testing.assert_allclose(arc[0], start, atol=POINT_TOLERANCE_M)
    np.testing.assert_allclose(arc[-1], start + chord, atol=POINT_TOLERANCE_M)
    # the drawn arc is as long as the solved length (a polyline of 24 points: just under it)
    drawn = np.sum(np.linalg.norm(np.diff(arc, axis=0), axis=1))
    assert length * (1 - 1e-3) < drawn <= length
    assert length - params.exo_digit.segments[0].arc_length > 4e-3
    np.testing.assert_allclose(
        drawing.pose.block_origins[1], start + chord, atol=POINT_TOLERANCE_M
    )
