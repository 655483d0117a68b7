"""The kinds of option of the glove and hand commands, and their checks (no rclpy).

:func:`.hand_config.command_options` is the one table of the options, made of :class:`RunOption`
entries. The time options are the plant's parameters of the same names, with their defaults,
descriptions and checks. Values stay text on the command line (``--lockstep`` alone means true);
every refusal is a :class:`..logic.options.UsageError` naming the option.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from ..logic.options import UsageError
from ..logic.pacing import TimeSettings
from .catalog import ESTIMATOR_NODE, PLANT_NODE, PRESSURE_COMMAND_NODE, SIMULATED_SAMPLE_AGE

BOOLEANS = ('true', 'false')
TIME_OPTIONS = ('real_time_factor', 'lockstep', 'lockstep_timeout', 'start_paused')
"""Plant parameters (:class:`..logic.pacing.TimeSettings` fields) a command may have as options."""
SIM_ONLY = ('lockstep', 'start_paused', 'real_time_factor')
"""Time options refused on the wall clock, in the order the refusal lists them."""


@dataclass(frozen=True)
class RunOption:
    """One option of a command: ``--<name>`` on a command line, ``<name>:=`` in a launch.

    Attributes
    ----------
    name : str
        Launch argument name (underscores); the command-line option has dashes.
    default : str
        Default, as text.
    help : str
    choices : tuple of str
        Allowed values (empty: any).
    switch : bool
        A true/false option: ``--<name>`` alone means true.
    metavar : str
        Placeholder of the value in ``--help`` (default the name in capitals).
    """

    name: str
    default: str
    help: str
    choices: tuple[str, ...] = ()
    switch: bool = False
    metavar: str = ''


def flag(name: str) -> str:
    """The command-line option of parameter or option ``name``: ``--real-time-factor``."""
    return '--' + name.replace('_', '-')


def text(value) -> str:
    """A value as option text: ``true``, ``1.0``, ``sine``."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def parameter_option(name: str, *, note: str = '', default: str | None = None) -> RunOption:
    """The option of a plant parameter (``mode``: pressure_command's); ``note`` ends its help.

    ``default`` (text) replaces the parameter's: '' for "none given", resolved by the command.
    """
    spec = PRESSURE_COMMAND_NODE.table[name] if name == 'mode' else PLANT_NODE.table[name]
    switch = isinstance(spec.default, bool)
    return RunOption(
        name=name,
        default=text(spec.default) if default is None else default,
        help=spec.description + note,
        choices=BOOLEANS if switch else tuple(spec.choices),
        switch=switch,
    )


def add_options(parser: argparse.ArgumentParser, options: Iterable[RunOption]) -> None:
    """Put ``options`` on ``parser`` (values stay text; read them with the checks below)."""
    for option in options:
        extra = {'nargs': '?', 'const': 'true'} if option.switch else {}
        parser.add_argument(
            flag(option.name),
            default=option.default,
            choices=option.choices or None,
            help=f'{option.help} (default {option.default})' if option.default else option.help,
            metavar=None if option.choices else option.metavar or option.name.upper(),
            **extra,
        )


def time_settings(values: Mapping[str, str]) -> TimeSettings:
    """The :class:`TimeSettings` of time options ``values`` (name to text), checked.

    Each gets the plant's check of its parameter (UsageError naming the option); those not in
    ``values`` keep the plant's defaults.
    """
    checked = {}
    for name, value in values.items():
        spec = PLANT_NODE.table[name]
        try:
            kind = type(spec.default)
            checked[name] = spec.check(value == 'true' if kind is bool else kind(value))
        except ValueError as error:
            raise UsageError(f'{flag(name)} {value}: {" ".join(str(error).split())}') from None
    return TimeSettings(**checked)


def check_sim_only(clock: str, time: TimeSettings, names: Iterable[str]) -> None:
    """Refuse a simulated-time setting on the wall clock (UsageError, one line).

    The message lists every such option of ``names`` (the command's), e.g. ``--lockstep and
    --real-time-factor need --clock sim``.
    """
    defaults = TimeSettings()
    if clock != 'sim' and any(getattr(time, n) != getattr(defaults, n) for n in SIM_ONLY):
        *others, last = [flag(n) for n in SIM_ONLY if n in names]
        listed = f'{", ".join(others)} and {last}' if others else last
        raise UsageError(f'{listed} need{"" if others else "s"} --clock sim')


def time_parameters(executable: str, clock: str, time: TimeSettings) -> dict[str, object]:
    """The simulated-time parameters of one glove node: the same for a glove and every finger.

    The plant gets ``clock`` and, with ``clock`` sim, ``time``; every other node follows its
    /clock (``use_sim_time``), ``pressure_command`` in lockstep with it, and the estimator
    takes states as old as :data:`.catalog.SIMULATED_SAMPLE_AGE` (it may be behind).
    """
    sim = clock == 'sim'
    if executable == PLANT_NODE.executable:
        values: dict[str, object] = {'clock': clock}
        if sim:
            values.update({name: getattr(time, name) for name in TIME_OPTIONS})
        return values
    values = {'use_sim_time': sim}
    if executable == PRESSURE_COMMAND_NODE.executable:
        values['lockstep'] = sim and time.lockstep
    if executable == ESTIMATOR_NODE.executable and sim:
        values['max_sample_age'] = SIMULATED_SAMPLE_AGE
    return values
