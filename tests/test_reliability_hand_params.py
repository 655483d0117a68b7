"""The five per-finger parameter files of the whole-hand benchmark (config/hand/*.yaml).

Each file must load with `exodigit_model.load_params`, carry a unit comment on every number, say
only what differs from the defaults, and describe a finger whose link lengths agree with the
anthropometric ratio its comment cites (ratio x hand length / 2). The model must bend every finger
to finite, converged angles across the working pressures.
"""

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from exodigit_model import GloveModel, load_params

HAND_DIR = Path(__file__).resolve().parents[1] / 'exodigit_nodes' / 'config' / 'hand'
FINGERS = ('thumb', 'index', 'middle', 'ring', 'little')
#: Hand length the files state, m.
HAND_LENGTH = 0.189
#: Files round half-lengths to 0.1 mm.
LENGTH_ROUNDING = 0.5e-4
NUMBER = re.compile(r'(?<![\w.])[-+]?\d+\.?\d*(?:[eE][-+]?\d+)?')


def hand_file(finger: str) -> Path:
    return HAND_DIR / f'{finger}.yaml'


def test_the_hand_has_one_file_per_finger():
    assert sorted(p.stem for p in HAND_DIR.glob('*.yaml')) == sorted(FINGERS)


@pytest.mark.parametrize('finger', FINGERS)
def test_every_number_carries_a_unit_comment(finger):
    for line in hand_file(finger).read_text('utf-8').splitlines():
        code, _, comment = line.partition('#')
        if NUMBER.search(code):
            assert re.search(r'\bm\b|N·m/rad|Pa', comment), f'{finger}: no unit on {line!r}'


@pytest.mark.parametrize('finger', FINGERS)
def test_file_sets_only_finger_keys_that_differ_from_the_defaults(finger):
    data = yaml.safe_load(hand_file(finger).read_text('utf-8'))
    assert set(data) == {'finger'}
    defaults = load_params().finger.joints
    for default, override in zip(defaults, data['finger']['joints'], strict=True):
        for key, value in override.items():
            assert value != getattr(default, key), f'{finger}: {key} repeats the default'


@pytest.mark.parametrize('finger', FINGERS)
def test_link_lengths_follow_the_cited_hand_length_ratios(finger):
    joints = load_params(hand_file(finger)).finger.joints
    defaults = load_params().finger.joints
    for line_no, line in enumerate(hand_file(finger).read_text('utf-8').splitlines()):
        ratio = re.search(r'\((0\.\d+) x 0\.189 / 2\)', line)
        if ratio is None:
            continue
        joint = re.search(r'# (mcp|pip|dip):', line).group(1)
        index = ('mcp', 'pip', 'dip').index(joint)
        expected = float(ratio.group(1)) * HAND_LENGTH / 2
        assert joints[index].link_half_length == pytest.approx(expected, abs=LENGTH_ROUNDING), (
            f'{finger} line {line_no + 1}'
        )
    lengths = [j.link_half_length for j in joints]
    assert lengths[0] > lengths[1] > lengths[2], f'{finger}: phalanges must shorten distally'
    assert all(j.stiffness > 0 for j in joints)
    if finger == 'index':
        # The default finger (46/27/18 mm, docs/spec/model.md §10) is this index finger to the
        # millimetre.
        for joint, default in zip(joints, defaults, strict=True):
            assert 2 * joint.link_half_length == pytest.approx(
                2 * default.link_half_length, abs=0.5e-3
            )


def test_middle_finger_is_the_longest_and_little_the_shortest_finger():
    length = {
        f: sum(j.link_half_length for j in load_params(hand_file(f)).finger.joints)
        for f in FINGERS
        if f != 'thumb'
    }
    assert max(length, key=length.get) == 'middle'
    assert min(length, key=length.get) == 'little'


@pytest.mark.parametrize('finger', FINGERS)
def test_model_bends_every_finger_monotonically_to_finite_converged_angles(finger):
    model = GloveModel(load_params(hand_file(finger)))
    pressures = np.linspace(0.0, 100e3, 11)
    angles = []
    for pressure in pressures:
        solution = model.solve(np.full(3, pressure))
        assert solution.converged and np.all(np.isfinite(solution.q))
        angles.append(solution.q)
    assert np.all(np.diff(np.asarray(angles), axis=0) > 0), f'{finger}: bending not monotone'
