"""Declared node parameters as plain data: name, default, unit, range, and their validation.

Each node lists its parameters once as :class:`ParamSpec` rows (in :mod:`.catalog`). The same
rows give the ROS ``ParameterDescriptor`` (see :mod:`.node_base`), the ``--help`` text, the
``config/*.yaml`` parameter files, and the checks that refuse a bad value with a reason naming the
parameter. No rclpy here, so the rules are unit-testable.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import KW_ONLY, dataclass
from typing import Any

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
        """``value`` converted to this parameter's type, or a ValueError naming the parameter."""
        kind = type(self.default)
        if kind is bool:
            if not isinstance(value, bool):
                raise ValueError(f'{self.name} must be true or false, got {value!r}')
            return value
        if kind is str and self.files:
            paths = [value] if isinstance(value, str) else value
            if not isinstance(paths, list | tuple) or not all(isinstance(p, str) for p in paths):
                raise ValueError(
                    f'{self.name} must be a file name or a list of file names, got {value!r}'
                )
            return tuple(path for path in paths if path.strip())
        if kind is str:
            if not isinstance(value, str):
                raise ValueError(f'{self.name} must be a string, got {value!r}')
            if self.required and not value.strip():
                raise ValueError(f'{self.name} must not be empty')
            if self.choices and value not in self.choices:
                raise ValueError(
                    f'{self.name} must be one of {", ".join(self.choices)}, got {value!r}'
                )
            return value
        if kind is tuple:
            if isinstance(value, str | bytes) or not isinstance(value, Iterable):
                raise ValueError(f'{self.name} must be a list of 3 numbers, got {value!r}')
            items = list(value)
            if len(items) != len(self.default):
                raise ValueError(
                    f'{self.name} must be a list of {len(self.default)} numbers (MCP, PIP, DIP), '
                    f'got {len(items)}'
                )
            return tuple(self._number(item, float) for item in items)
        return self._number(value, kind)

    def _number(self, value: Any, kind: type) -> float | int:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f'{self.name} must be a number, got {value!r}')
        if kind is int and not isinstance(value, int):
            raise ValueError(f'{self.name} must be an integer, got {value!r}')
        if not math.isfinite(value):
            raise ValueError(f'{self.name} must be finite, got {value!r}')
        if (self.low is not None and value < self.low) or (
            self.high is not None and value > self.high
        ):
            bounds = self._bounds('lie in [{}, {}]', 'be {}')
            raise ValueError(f'{self.name} must {bounds}, got {value!r}')
        return kind(value)

    def _bounds(self, both: str, one: str = '{}') -> str:
        """The range in words (empty without one).

        ``both`` filled with low and high when the range has both ends, else ``one`` filled
        with ``>= low`` or ``<= high``.
        """
        if self.low is not None and self.high is not None:
            return both.format(f'{self.low:g}', f'{self.high:g}')
        if self.low is not None:
            return one.format(f'>= {self.low:g}')
        if self.high is not None:
            return one.format(f'<= {self.high:g}')
        return ''

    def rule(self) -> str:
        """The rule a value follows, as ``--help`` shows it: ``[1 .. 5000] (read-only)``."""
        allowed = self._bounds('[{} .. {}]')
        if self.choices:
            allowed = f'{{{", ".join(self.choices)}}}'
        return ' '.join(filter(None, (allowed, '(read-only)' if self.read_only else '')))

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
                raise ValueError(f'{name} is not a parameter of this node')
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
