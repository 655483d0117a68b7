"""Every statement of the model's validated stretch range is VALID_STRETCH (issue 16, item 1).

The docs and docstrings said 1 ≤ λ ≤ 1.5 while the model checks VALID_STRETCH = (0.95, 1.5). The
statements are found by pattern in every .py and .md file of the project (this file excepted: it
spells out wrong ranges to test the patterns): a chained inequality on λ, lambda or a stretch, a
range after "validated" (1–1.5, 1..1.5, 1-1.5, 1 to 1.5), a copy of the constant, and one end
after "validated stretch". A range formatted from the constant (f'{low:g} <= lambda') states no
number and is not a statement.
"""

import os
import re
from pathlib import Path

import pytest
from exodigit_model.physics.model import VALID_STRETCH

ROOT = Path(__file__).resolve().parents[1]
SKIPPED = {'.git', '.venv', '.pytest_cache', '__pycache__', 'ros_ws', 'build', 'install', 'log'}
"""Directories that are not the project's own text (ros_ws/src links back to the packages)."""
DOCUMENTED = {
    'docs/model.md',
    'docs/patients.md',
    'docs/tools.md',
    'exodigit_model/exodigit_model/gym/env.py',
    'exodigit_model/exodigit_model/physics/model.py',
}
"""Files that state the range: the patterns must find it there (a rewording they miss would
otherwise pass unchecked)."""

NUMBER = r'(\d+(?:\.\d+)?)'
AT_MOST = r'\s*(?:≤|<=)\s*'
TO = r'\s*(?:–|-|\.\.|to)\s*'
VALIDATED = r'validated(?: fibre)?(?: stretch(?:es)?)?(?: range)?\s+'
RANGES = (
    re.compile(NUMBER + AT_MOST + r'(?:λ|lambda|stretch)' + AT_MOST + NUMBER),
    re.compile(VALIDATED + NUMBER + TO + NUMBER),
    re.compile(r'VALID_STRETCH\s*=\s*\(\s*' + NUMBER + r'\s*,\s*' + NUMBER + r'\s*\)'),
)
"""Statements of both ends of the range."""
ONE_END = re.compile(VALIDATED + NUMBER + r'(?!\d|\.\d|' + TO + r'\d|' + AT_MOST + ')')
"""A statement of one end ("beyond the validated stretch 1.5")."""


def stated(text: str) -> list[tuple[int, str, tuple[float, ...]]]:
    """(offset, words, numbers) of each statement of the range in ``text``, in order."""
    found = [
        (match.start(), match[0], (float(match[1]), float(match[2])))
        for pattern in RANGES
        for match in pattern.finditer(text)
    ]
    found += [(match.start(), match[0], (float(match[1]),)) for match in ONE_END.finditer(text)]
    return sorted(found)


def project_texts() -> dict[str, str]:
    """Every .py and .md file of the project but this one, by path relative to the root."""
    texts = {}
    for folder, subfolders, names in os.walk(ROOT):
        subfolders[:] = sorted(name for name in subfolders if name not in SKIPPED)
        for name in names:
            path = Path(folder) / name
            if path.suffix in ('.py', '.md') and path != Path(__file__).resolve():
                texts[path.relative_to(ROOT).as_posix()] = path.read_text(encoding='utf-8')
    return texts


@pytest.mark.parametrize(
    ('text', 'numbers'),
    [
        ("Whether every fibre's stretch lies in 1 ≤ λ ≤ 1.5 (the", [(1.0, 1.5)]),
        ('# docs/spec/model.md §12: 0.95 <= lambda <= 1.5 over the section', [(0.95, 1.5)]),
        ('0.95 <= stretch <= 1.5', [(0.95, 1.5)]),
        ('0.4–2.6 (far beyond the\n  validated 1–1.5), and', [(1.0, 1.5)]),
        ('the validated range 1..1.5)', [(1.0, 1.5)]),
        ('VALID_STRETCH = (1.0, 1.5)', [(1.0, 1.5)]),
        ('bent beyond the validated stretch 1.6: the plant', [(1.6,)]),
        ('validated stretch range 1 ≤ λ ≤ 1.5 (a joint', [(1.0, 1.5)]),
        ("f'outside the validated range {low:g} <= lambda <= {high:g}'", []),
        ('over top-fibre stretches 0.4–2.6 (far beyond', []),
    ],
)
def test_the_patterns_find_each_way_a_range_is_written(text, numbers):
    assert [found for _, _, found in stated(text)] == numbers


def test_every_stated_validated_stretch_range_is_valid_stretch():
    low, high = VALID_STRETCH
    wrong, places = [], set()
    for path, text in project_texts().items():
        for offset, words, numbers in stated(text):
            places.add(path)
            right = numbers == VALID_STRETCH if len(numbers) == 2 else numbers[0] in VALID_STRETCH
            if not right:
                wrong.append(f'{path}:{text.count(chr(10), 0, offset) + 1}: {words!r}')
    assert wrong == [], (
        f'the validated stretch range is {low:g} <= lambda <= {high:g} '
        f'(exodigit_model.physics.model.VALID_STRETCH), but: {wrong}'
    )
    assert places >= DOCUMENTED, f'no statement of the range found in {DOCUMENTED - places}'
