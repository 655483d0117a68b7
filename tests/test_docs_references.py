"""Every reference to a document resolves inside the repository (the specification in docs/spec/).

The model and the ROS interface are specified in docs/spec/model.md and docs/spec/ros.md, and
code, config and docs cite them: ``docs/spec/model.md §10``, ``§10-11``, ``§7, §11``,
``section 10``, ``eq 11.1``, ``(11.4)``, ``docs/spec/ros.md, "QoS"``, ``... Part II``. The
references are found by pattern in every text file git tracks (this one excepted: it spells out
broken ones to test the patterns). For each, the file must exist, each § or section number must be
a numbered heading of it, each equation of the model specification must be the paper's (1-36) or
one of its own numbered ones, and each quoted name must begin a heading (or a bold run-in label)
of the file. The specification's own cross-references ("section 9", "model §6") and the relative
links of every Markdown file are checked too. The contract files these documents replace lived
outside the repository: no tracked file may name them any more.
"""

import re
import subprocess
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODEL_SPEC = 'docs/spec/model.md'
ROS_SPEC = 'docs/spec/ros.md'
PAPER_EQUATIONS = range(1, 37)
"""The paper's equations, eqs 1-36."""
GONE = (
    'MODEL' + '.md',
    'INTERFACES' + '.md',
    'ROS_NOTES' + '.md',
    'STYLE' + '.md',
    '../' + 'shared',
    '/work/' + 'shared',
)
"""Names of documents outside the repository (the working notes docs/spec replaces; spelt so
that this file does not contain them)."""

DOCUMENT = re.compile(r'(?<![\w/.:-])((?:[\w.-]+/)*[\w-]+\.md)\b')
"""A Markdown file named by its path (a URL is not: its path follows ``:`` or ``/``)."""
LEAD = re.compile(r'`?\)?[ \t]*,?[ \t]*(?:\n[ \t]*(?:#|//|\*)?[ \t]*)?')
"""What may stand between a file and its first item: a closing backtick, a comma, a line break
with a comment leader (a wrapped comment or docstring)."""
SEPARATOR = re.compile(r'(?:[ \t]*,[ \t]*|[ \t]+and[ \t]+|[ \t]+)(?:\n[ \t]*(?:#|//)?[ \t]*)?')
NUMBER = r'\d+(?!\.\d)'
EQUATION = r'\d+(?:\.\d+)?'
DASH = r'\s*[-–]\s*'
ITEM = re.compile(
    rf'§\s*(?P<s1>{NUMBER})(?:{DASH}§?(?P<s2>{NUMBER}))?'
    rf'|sections?\s+(?P<t1>{NUMBER})(?:{DASH}(?P<t2>{NUMBER}))?'
    rf'|eqs?\.?\s+(?P<e1>{EQUATION})(?:{DASH}(?P<e2>{EQUATION}))?'
    rf'|\((?P<p1>\d+\.\d+)\)(?:{DASH}\((?P<p2>\d+\.\d+)\))?'
    r'|(?P<part>Part\s+I{1,3})\b'
    r'|"(?P<quote>[^"\n]{1,80})"'
)
"""One item of a reference: a section (range), an equation (range), a part or a quoted name."""
SPEC_SECTIONS = re.compile(r'\bsections?\s+(\d+(?:\s*(?:[-–,]|and)\s*\d+)*)(?!\.\d)')
"""The model specification's references to its own sections ("section 9", "sections 2–7")."""
MODEL_FROM_ROS = re.compile(r'\bmodel\s+§(\d+(?:[-–]\d+)?)')
"""The ROS specification's references to the model's ("model §6", "model §10–11")."""
LINK = re.compile(r'\]\(([^)\s]+)\)')
"""A Markdown link's target."""


@cache
def tracked_texts() -> dict[str, str]:
    """Every text file git tracks (binaries, and files that are not UTF-8, left out), by path."""
    try:
        listing = subprocess.run(
            ['git', 'ls-files', '-z'], cwd=ROOT, capture_output=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError) as error:
        pytest.skip(f'not a git checkout ({error}): no list of tracked files')
    texts = {}
    for name in listing.decode('utf-8').split('\0'):
        path = ROOT / name
        if not name or not path.is_file() or path == Path(__file__).resolve():
            continue
        data = path.read_bytes()
        if b'\0' in data:
            continue
        try:
            texts[name] = data.decode('utf-8')
        except UnicodeDecodeError:
            continue
    return texts


@cache
def headings(path: str) -> tuple[frozenset[int], tuple[str, ...], str]:
    """The numbered sections, the heading titles and the text of the Markdown file ``path``."""
    text = (ROOT / path).read_text(encoding='utf-8')
    titles, numbers, fence = [], set(), False
    for line in text.splitlines():
        if line.startswith('```'):
            fence = not fence
        match = None if fence else re.match(r'#{1,6}\s+(.*?)\s*$', line)
        if match:
            titles.append(match[1])
            number = re.match(r'(\d+)\.\s', match[1])
            if number:
                numbers.add(int(number[1]))
    return frozenset(numbers), tuple(titles), text


def line_of(text: str, offset: int) -> int:
    return text.count('\n', 0, offset) + 1


def numbers_in(first: str, last: str | None) -> list[int]:
    return [int(first)] if last is None else [int(first), int(last)]


def target_of(name: str, source: str) -> str | None:
    """The repository path a document name in ``source`` refers to, or None if there is none."""
    for base in (Path(), Path(source).parent):
        candidate = (base / name).as_posix()
        if (ROOT / candidate).is_file():
            return str(Path(candidate))
    return None


def check_items(target: str, text: str, start: int) -> tuple[list[str], int]:
    """The problems of the items that follow a reference to ``target``, and how many there were."""
    numbers, titles, body = headings(target)
    problems, count = [], 0
    position = LEAD.match(text, start).end()
    while (item := ITEM.match(text, position)) is not None:
        count += 1
        groups = item.groupdict()
        if groups['s1'] or groups['t1']:
            key = 's' if groups['s1'] else 't'
            first, last = groups[f'{key}1'], groups[f'{key}2']
            problems += [
                f'§{n} (no section {n} in {target})'
                for n in numbers_in(first, last)
                if n not in numbers
            ]
        elif groups['e1'] or groups['p1']:
            key = 'e' if groups['e1'] else 'p'
            first, last = groups[f'{key}1'], groups[f'{key}2']
            for equation in filter(None, (first, last)):
                if target != MODEL_SPEC:
                    problems.append(f'eq {equation} (only {MODEL_SPEC} numbers equations)')
                elif '.' in equation:
                    if f'({equation})' not in body:
                        problems.append(f'({equation}) (not an equation of {target})')
                elif int(equation) not in PAPER_EQUATIONS:
                    problems.append(f'eq {equation} (the paper has eqs 1-36)')
        elif groups['part']:
            if not any(groups['part'] in title for title in titles):
                problems.append(f'{groups["part"]} (no such part in {target})')
        else:
            quote = groups['quote']
            if not any(title.startswith(quote) for title in titles) and f'**{quote}' not in body:
                problems.append(f'"{quote}" (no heading of {target} starts so)')
        position = item.end()
        separator = SEPARATOR.match(text, position)
        if separator is None:
            break
        position = separator.end()
    return problems, count


def reference_problems(texts: dict[str, str]) -> tuple[list[str], int]:
    """Every broken reference to a Markdown file in ``texts``, and how many items were checked."""
    problems, checked = [], 0
    for source, text in texts.items():
        for match in DOCUMENT.finditer(text):
            name = match[1]
            where = f'{source}:{line_of(text, match.start())}: {name}'
            target = target_of(name, source)
            following = ITEM.match(text, LEAD.match(text, match.end()).end())
            if target is None:
                if name.startswith('docs/') or following is not None:
                    problems.append(f'{where} (no such file in the repository)')
                continue
            found, count = check_items(target, text, match.end())
            checked += count
            problems += [f'{where} {problem}' for problem in found]
    return problems, checked


def spec_problems(texts: dict[str, str]) -> list[str]:
    """Broken cross-references inside the specification."""
    model_numbers = headings(MODEL_SPEC)[0]
    problems = []
    for source, pattern in ((MODEL_SPEC, SPEC_SECTIONS), (ROS_SPEC, MODEL_FROM_ROS)):
        text = texts.get(source, '')
        for match in pattern.finditer(text):
            for number in map(int, re.findall(r'\d+', match[1])):
                if number not in model_numbers:
                    where = f'{source}:{line_of(text, match.start())}'
                    problems.append(f'{where}: {match[0]!r} (no section {number} in {MODEL_SPEC})')
    return problems


def link_problems(texts: dict[str, str]) -> list[str]:
    """Relative links of the Markdown files whose target is not in the repository."""
    problems = []
    for source, text in texts.items():
        if not source.endswith('.md'):
            continue
        for match in LINK.finditer(text):
            link = match[1].split('#')[0]
            if not link or re.match(r'[a-z][a-z0-9+.-]*:', link):
                continue
            if not (ROOT / Path(source).parent / link).exists():
                where = f'{source}:{line_of(text, match.start())}'
                problems.append(f'{where}: link to {match[1]} (no such file or folder)')
    return problems


@pytest.mark.parametrize(
    ('text', 'problems'),
    [
        ('see docs/spec/model.md §10-11 and §13.', []),
        ('(docs/spec/model.md §7, §11, §12)', []),
        ('(docs/spec/model.md (11.1)-(11.3), eq 36)', []),
        ('docs/spec/ros.md, "QoS"', []),
        ('(docs/spec/ros.md Part II, "The patient")', []),
        ('# (docs/spec/model.md\n#   §10-11): one file', []),
        ('docs/spec/model.md §10: "about 61°"', []),
        ('docs/spec/model.md §15', ['§15']),
        ('docs/spec/model.md §12-15', ['§15']),
        ('docs/spec/model.md §7, section 16', ['§16']),
        ('docs/spec/model.md eqs 11.1-11.9', ['(11.9)']),
        ('docs/spec/model.md eq 37', ['eq 37']),
        ('docs/spec/ros.md, "Latency"', ['"Latency"']),
        ('docs/spec/ros.md Part III', ['Part III']),
        ('docs/model.md §10', ['§10']),
        ('docs/spec/physics.md §2', ['no such file']),
    ],
)
def test_the_patterns_find_each_way_a_reference_is_written(text, problems):
    found, _ = reference_problems({'example.py': text})
    assert len(found) == len(problems), found
    for message, expected in zip(found, problems, strict=True):
        assert expected in message


def test_the_specification_is_in_the_repository():
    for path in (MODEL_SPEC, ROS_SPEC):
        assert (ROOT / path).is_file(), f'{path} is missing'
    assert headings(MODEL_SPEC)[0] == frozenset(range(1, 15)), 'sections 1-14 of the model'
    titles = headings(ROS_SPEC)[1]
    for heading in ('Nodes and topics', 'Parameters', 'QoS', 'Safety behaviour', 'Executables'):
        assert any(title.startswith(heading) for title in titles), heading


def test_every_reference_resolves_inside_the_repository():
    texts = tracked_texts()
    problems, checked = reference_problems(texts)
    assert problems == [], '\n'.join(problems)
    assert checked > 100, f'only {checked} references found: do the patterns still match?'


def test_the_specification_cross_references_resolve():
    problems = spec_problems(tracked_texts())
    assert problems == [], '\n'.join(problems)


def test_every_relative_markdown_link_resolves():
    problems = link_problems(tracked_texts())
    assert problems == [], '\n'.join(problems)


def test_no_file_names_the_documents_outside_the_repository():
    found = [
        f'{path}:{line_of(text, text.index(name))}: {name}'
        for path, text in tracked_texts().items()
        for name in GONE
        if name in text
    ]
    assert found == [], 'name the documents in docs/spec instead: ' + '; '.join(found)
