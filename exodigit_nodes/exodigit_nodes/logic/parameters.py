"""Node parameters as plain data (name, default, unit, range) and their checks.

A node's :class:`ParamSpec` rows (:mod:`.catalog`) give its parameter descriptors, its
``--help``, its ``config/*.yaml`` and the checks that name the parameter a value breaks (those
of :mod:`exodigit_model.checks`, as for the model's own parameters).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import KW_ONLY, dataclass
from typing import Any

from exodigit_model.checks import (
    ParameterError,
    check_choice,
    check_flag,
    check_integer,
    check_number,
    check_range,
    range_words,
)

ParamValue = bool | int | float | str | tuple[float, ...] | tuple[str, ...]


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter: name, default and description, then keyword-only rules.

    Attributes
    ----------
    name : str
        Parameter name as declared on the node.
    default : bool, int, float, str or tuple of float
        Default value; its type is the parameter's type (a tuple means three floats, one per
        joint MCP, PIP, DIP).
    description : str
        What it means, with its SI unit.
    low, high : float, optional
        Inclusive range of a number (of every element of a joint vector); either may be given
        alone (no limit on the other side).
    read_only : bool
        Structural: fixed once the node has started.
    choices : tuple of str
        Allowed values of a string parameter (empty: any string).
    required : bool
        A string parameter that may not be empty.
    files : bool
        A string parameter that names files: one path, or a list of paths (merged in order by
        the model loader); the checked value is a tuple of the non-empty paths.
    """

    name: str
    default: ParamValue
    description: str
    _: KW_ONLY
    low: float | None = None
    high: float | None = None
    read_only: bool = False
    choices: tuple[str, ...] = ()
    required: bool = False
    files: bool = False

    def check(self, value: Any) -> ParamValue:
        """``value`` converted to this parameter's type.

        Raises
        ------
        exodigit_model.checks.ParameterError
            A ValueError ``name = value: must ...``.
        """
        kind, name = type(self.default), self.name
        if kind is bool:
            return check_flag(name, value)
        if kind is str and self.files:
            paths = [value] if isinstance(value, str) else value
            if not isinstance(paths, list | tuple) or not all(isinstance(p, str) for p in paths):
                raise ParameterError(f'{name} = {value!r}: must be a file name or a list of them')
            return tuple(path for path in paths if path.strip())
        if kind is str:
            if not isinstance(value, str) or (self.required and not value.strip()):
                raise ParameterError(f'{name} = {value!r}: must be a non-empty string')
            return check_choice(name, value, self.choices) if self.choices else value
        if kind is tuple:
            size = len(self.default)
            listed = not isinstance(value, str | bytes) and isinstance(value, Iterable)
            if not listed or len(items := list(value)) != size:
                raise ParameterError(
                    f'{name} = {value!r}: must be a list of {size} numbers (MCP, PIP, DIP)'
                )
            return tuple(self._number(item, float) for item in items)
        return self._number(value, kind)

    def _number(self, value: Any, kind: type) -> float | int:
        number = check_integer(self.name, value) if kind is int else check_number(self.name, value)
        return check_range(self.name, number, self.low, self.high)

    def rule(self) -> str:
        """The rule a value follows, as ``--help`` shows it: ``[1 .. 5000] (read-only)``."""
        low, high = self.low, self.high
        if self.choices:
            allowed = f'{{{", ".join(self.choices)}}}'
        elif low is not None and high is not None:
            allowed = f'[{low:g} .. {high:g}]'
        else:  # one end or none: the words of the check's message, '>= 0'
            allowed = range_words(low, high).removeprefix('be ')
        given = self.required and not self.default  # no default: the user names it
        notes = (allowed, '(read-only)' * self.read_only, '(must be given)' * given)
        return ' '.join(filter(None, notes))

    def help_line(self) -> str:
        """One entry of ``--help``: name, default and rule, then the meaning on a second line."""
        default = list(self.default) if isinstance(self.default, tuple) else self.default
        head = ' '.join(filter(None, (f'{self.name} = {default!r}', self.rule())))
        return f'  {head}\n      {self.description}'


class ParamTable:
    """The parameters of one node, checked together.

    Parameters
    ----------
    specs : iterable of ParamSpec
        The node's parameters.
    """

    def __init__(self, specs: Iterable[ParamSpec]) -> None:
        self.specs = {spec.name: spec for spec in specs}

    def __getitem__(self, name: str) -> ParamSpec:
        """The parameter ``name`` (KeyError if the node has none of that name)."""
        return self.specs[name]

    def defaults(self) -> dict[str, ParamValue]:
        """Every parameter at its default, as :meth:`check` gives it."""
        return {name: spec.check(spec.default) for name, spec in self.specs.items()}

    def check(self, values: Mapping[str, Any]) -> dict[str, ParamValue]:
        """``values`` (a subset of the parameters) checked and converted.

        Raises
        ------
        ValueError
            Naming the first parameter that is unknown or breaks its rule.
        """
        checked = {}
        for name, value in values.items():
            spec = self.specs.get(name)
            if spec is None:
                raise ParameterError(f'{name} is not a parameter of this node')
            checked[name] = spec.check(value)
        return checked

    def help(self) -> str:
        """All parameters, one entry each, for ``--help``."""
        return '\n'.join(spec.help_line() for spec in self.specs.values())


def params_file_spec(whose: str, taken_at: str | None = None) -> ParamSpec:
    """The ``params_file`` parameter of a node that loads the model (``whose`` model it is).

    Read-only, unless ``taken_at`` says when the node takes a new value (the plant's: at its
    next ``reset_simulation``).
    """
    return ParamSpec(
        'params_file',
        '',
        f'Model parameter YAML for {whose} (docs/spec/model.md §10-11): one file, or a list of '
        "files merged in order (e.g. ['my_glove.yaml', 'patient.yaml']); empty = built-in "
        'defaults' + ('' if taken_at is None else f' ({taken_at})'),
        read_only=taken_at is None,
        files=True,
    )


def describe_files(paths: tuple[str, ...]) -> str:
    """How a log line names the model files of a node: ``a.yaml + b.yaml`` or the defaults."""
    return ' + '.join(paths) or 'built-in defaults'
