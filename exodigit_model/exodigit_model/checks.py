"""The checks every parameter file and dataclass of the package uses; a broken rule names its key.

:class:`ParameterError` is the error: a ``ValueError`` whose message names the key, the value and
the rule (``key = value: must ...``). The glove's parameters (:mod:`.params`), the populations
and the trials (:mod:`.trials`) validate with these functions and read their YAML with
:func:`read_yaml`; the ROS nodes' parameter table (``exodigit_nodes.logic.parameters``) checks
its values with them too.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import yaml


class ParameterError(ValueError):
    """A parameter value or file breaks a rule; the message names key, value and rule."""


def check_number(key: str, value: Any) -> float:
    """``value`` as a finite float (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ParameterError(f'{key} = {value!r}: must be a number')
    value = float(value)
    if not math.isfinite(value):
        raise ParameterError(f'{key} = {value!r}: must be finite')
    return value


def check_integer(key: str, value: Any) -> int:
    """``value`` as an int (not a bool, not a float)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ParameterError(f'{key} = {value!r}: must be an integer')
    return int(value)


def check_flag(key: str, value: Any) -> bool:
    """``value`` as a bool: true or false, nothing else."""
    if not isinstance(value, bool):
        raise ParameterError(f'{key} = {value!r}: must be true or false')
    return value


def check_choice(key: str, value: Any, choices: tuple[str, ...]) -> str:
    """``value``, one of ``choices``."""
    if value not in choices:
        raise ParameterError(f'{key} = {value!r}: must be one of {", ".join(choices)}')
    return value


def check_range(key: str, value: float, low: float | None, high: float | None) -> float:
    """``value`` within [``low``, ``high``] (either end None: no limit on that side)."""
    if (low is not None and value < low) or (high is not None and value > high):
        raise ParameterError(f'{key} = {value!r}: must {range_words(low, high)}')
    return value


def range_words(low: float | None, high: float | None) -> str:
    """The rule of :func:`check_range` in words: ``lie in [0, 5]``, ``be >= 0``, ``''``."""
    if low is not None and high is not None:
        return f'lie in [{low:g}, {high:g}]'
    if low is not None:
        return f'be >= {low:g}'
    if high is not None:
        return f'be <= {high:g}'
    return ''


def check_positive(key: str, value: Any, unit: str) -> float:
    """``value`` as a float > 0; ``unit`` completes the message."""
    number = check_number(key, value)
    if number <= 0.0:
        raise ParameterError(f'{key} = {number!r}: must be > 0 ({unit})')
    return number


def check_non_negative(key: str, value: Any, unit: str) -> float:
    """``value`` as a float >= 0; ``unit`` completes the message."""
    number = check_number(key, value)
    if number < 0.0:
        raise ParameterError(f'{key} = {number!r}: must be >= 0 ({unit})')
    return number


def check_name(key: str, value: Any) -> str:
    """``value`` as a non-empty string."""
    if not isinstance(value, str) or not value:
        raise ParameterError(f'{key} = {value!r}: must be a non-empty string')
    return value


def check_three(key: str, items: Any, kind: type) -> tuple:
    """``items`` as a tuple of exactly three ``kind`` (MCP, PIP, DIP)."""
    items = tuple(items)
    if len(items) != 3 or not all(isinstance(item, kind) for item in items):
        raise ParameterError(f'{key} has {len(items)} entries: must be exactly 3 (MCP, PIP, DIP)')
    return items


def set_field(obj: object, key: str, value: object) -> None:
    """Set a frozen dataclass's field from its ``__post_init__`` (a checked value)."""
    object.__setattr__(obj, key, value)


class Yaml12Loader(getattr(yaml, 'CSafeLoader', yaml.SafeLoader)):
    """SafeLoader that also reads ``1.1e5`` as a float, like YAML 1.2 (docs/spec/model.md §10).

    On libyaml's parser where PyYAML has it (ten times faster: every node start and every new
    patient of a plant reads its parameter files).
    """


Yaml12Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$'),
    list('-+0123456789.'),
)


def check_keys(path: str, data: Any, known: Mapping[str, Any]) -> None:
    """Refuse ``data`` (at key ``path``) unless a mapping with only ``known`` keys."""
    if not isinstance(data, Mapping):
        raise ParameterError(f'{path or "file"} = {data!r}: must be a mapping of keys to values')
    unknown = sorted(set(data) - set(known), key=str)  # YAML keys need not be strings
    if unknown:
        where = f'{path}.' if path else ''
        raise ParameterError(
            f'{where}{unknown[0]}: unknown key (known keys: {", ".join(sorted(known))})'
        )


def build_checked(cls: type, path: str, data: Mapping[str, Any], **nested: Any) -> Any:
    """``cls(**data, **nested)``, a ParameterError from it prefixed with the key ``path``."""
    try:
        return cls(**{**data, **nested})
    except ParameterError as error:
        raise ParameterError(f'{path}.{error}' if path else str(error)) from None


def read_yaml(text: str, source: str) -> Any:
    """YAML ``text`` read from ``source`` (1.2 floats); invalid YAML is a ParameterError."""
    try:
        return yaml.load(text, Loader=Yaml12Loader)
    except yaml.YAMLError as error:
        raise ParameterError(f'{source}: not valid YAML ({error})') from None
