"""``exodigit draw``: picture size and the angles written on it against the solver."""

import re

import numpy as np
import pytest
from exodigit_model.tools.cli import main
from PIL import Image

from exodigit_model import GloveModel, load_params, patient_file

#: Angles are written with one decimal (deg), forces with two (N).
ANGLE_DECIMALS_DEG = 0.05
FORCE_DECIMALS_N = 0.005


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


def written_numbers(text):
    angles = [float(v) for v in re.findall(r'(?:MCP|PIP|DIP) (-?[\d.]+)°', text)]
    forces = [float(v) for v in re.search(r'f = (.*) N', text).group(1).split(', ')]
    return np.radians(angles), np.array(forces)


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
