"""What a hand is: its fingers, where they live, and the options that configure it (no rclpy).

One table of options, :func:`hand_options`, serves ``hand_nodes`` (the process that runs every
finger's nodes), the hand runner ``python -m exodigit_nodes.hand`` and ``launch/hand.launch.py``;
the time options are the plant's parameters of the same names (:mod:`.catalog`), with their
defaults, descriptions and checks, and ``mode`` is ``pressure_command``'s.

Finger f lives in ``<namespace>/<f>`` with joint names ``f_mcp, f_pip, f_dip`` and the model
file ``config/hand/<f>.yaml`` (its link lengths and stiffness; docs/spec/model.md §10).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path

from ..logic.options import NOMINAL_PATIENT, UsageError, check_namespace, with_patient
from ..logic.pacing import TimeSettings
from .catalog import ESTIMATOR_NODE, PLANT_NODE, PRESSURE_COMMAND_NODE

FINGERS = ('thumb', 'index', 'middle', 'ring', 'little')
"""The fingers of a hand, thumb first."""
TIME_PARAMETERS = ('clock', 'real_time_factor', 'lockstep', 'lockstep_timeout', 'start_paused')
"""Plant parameters that are options of the hand (one simulated time for every finger)."""
BOOLEANS = ('true', 'false')
PARTS = {
    'all': (PLANT_NODE, ESTIMATOR_NODE, PRESSURE_COMMAND_NODE),
    'gloves': (PLANT_NODE, PRESSURE_COMMAND_NODE),
    'estimators': (ESTIMATOR_NODE,),
}
"""Which nodes of every finger one ``hand_nodes`` process runs (``--part``), in start order.

The runner and the launch file start a hand as two processes, ``gloves`` (plants and
controllers, and the hand's simulated time) and ``estimators``: an estimator takes message info
(the source timestamps it pairs by), which rclpy 7.1's EventsExecutor cannot give, and five of
them on a SingleThreadedExecutor take a core of their own at 100 Hz (README, "A whole hand").
"""


class HandError(ValueError):
    """A hand configuration refused before any node starts; the text is one line."""


def hand_config_dir() -> Path:
    """``config/hand`` of the package: in the source tree, or in its ament share directory."""
    source = Path(__file__).resolve().parents[2] / 'config' / 'hand'
    if source.is_dir():
        return source
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory('exodigit_nodes')) / 'config' / 'hand'


@dataclass(frozen=True)
class HandOption:
    """One option of the hand: ``--<name>`` on a command line, ``<name>:=`` in a launch.

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
    """

    name: str
    default: str
    help: str
    choices: tuple[str, ...] = ()
    switch: bool = False

    @property
    def flag(self) -> str:
        """The command-line option, ``--real-time-factor``."""
        return '--' + self.name.replace('_', '-')


def _text(value) -> str:
    return str(value).lower() if isinstance(value, bool) else str(value)


def _from_parameter(name: str, *, note: str = '') -> HandOption:
    spec = PLANT_NODE.table[name] if name != 'mode' else PRESSURE_COMMAND_NODE.table[name]
    switch = isinstance(spec.default, bool)
    return HandOption(
        name=name,
        default=_text(spec.default),
        help=spec.description + note,
        choices=BOOLEANS if switch else tuple(spec.choices),
        switch=switch,
    )


def hand_options() -> tuple[HandOption, ...]:
    """Every option of the hand, in ``--help`` order."""
    return (
        HandOption(
            'fingers',
            ','.join(FINGERS),
            f'comma-separated fingers, each of {",".join(FINGERS)} at most once',
        ),
        HandOption('namespace', '/hand', 'namespace of the hand; finger f in <namespace>/f'),
        _from_parameter('mode', note=' (every finger)'),
        HandOption(
            'patient',
            NOMINAL_PATIENT,
            "patient preset or YAML merged over every plant's finger file (nominal: the finger "
            'files alone; the controllers and estimators assume them)',
        ),
        HandOption(
            'estimator', 'true', 'run an estimator per finger', choices=BOOLEANS, switch=True
        ),
        *(_from_parameter(name, note=' (the whole hand)') for name in TIME_PARAMETERS),
        _from_parameter('pause_at', note=' (the whole hand)'),
    )


def add_hand_arguments(parser: argparse.ArgumentParser) -> None:
    """Put every hand option on ``parser`` (values stay text; :func:`hand_config` reads them)."""
    for option in hand_options():
        extra = {'nargs': '?', 'const': 'true'} if option.switch else {}
        parser.add_argument(
            option.flag,
            default=option.default,
            choices=option.choices or None,
            help=f'{option.help} (default {option.default})',
            metavar=None if option.choices else option.name.upper(),
            **extra,
        )


def _checked(name: str, text: str):
    """The plant's check of a time option (HandError naming the option)."""
    spec = PLANT_NODE.table[name]
    try:
        value = (text == 'true') if isinstance(spec.default, bool) else type(spec.default)(text)
        return spec.check(value)
    except ValueError as error:
        flag = '--' + name.replace('_', '-')
        raise HandError(f'{flag} {text}: {" ".join(str(error).split())}') from None


@dataclass(frozen=True)
class HandConfig:
    """One hand: which fingers, where, how their commands and their time run.

    Attributes
    ----------
    fingers : tuple of str
        Finger names, each in :data:`FINGERS` at most once.
    namespace : str
        Absolute namespace of the hand.
    mode : str
        ``pressure_command`` mode of every finger.
    patient : str
        ``nominal``, a patient preset or a patient YAML merged over every plant's finger file.
    estimator : bool
        An estimator per finger.
    clock : str
        ``wall`` or ``sim``.
    time : TimeSettings
        With ``clock`` sim: pace, lockstep, pause.
    """

    fingers: tuple[str, ...] = FINGERS
    namespace: str = '/hand'
    mode: str = PRESSURE_COMMAND_NODE.table['mode'].default
    patient: str = NOMINAL_PATIENT
    estimator: bool = True
    clock: str = PLANT_NODE.table['clock'].default
    time: TimeSettings = field(default_factory=TimeSettings)

    def __post_init__(self) -> None:
        unknown = [f for f in self.fingers if f not in FINGERS]
        if unknown or not self.fingers or len(set(self.fingers)) != len(self.fingers):
            raise HandError(
                f'--fingers {",".join(self.fingers)}: give distinct names from {",".join(FINGERS)}'
            )
        timed = self.time.lockstep or self.time.start_paused or self.time.real_time_factor != 1.0
        if self.clock != 'sim' and timed:
            raise HandError('--lockstep, --start-paused and --real-time-factor need --clock sim')

    def node_entries(self, part: str = 'all'):
        """The catalog entries of a finger's nodes in ``part`` (:data:`PARTS`), in start order."""
        return tuple(
            entry for entry in PARTS[part] if self.estimator or entry is not ESTIMATOR_NODE
        )

    def finger_namespace(self, finger: str) -> str:
        """``<namespace>/<finger>``."""
        return f'{self.namespace.rstrip("/")}/{finger}'

    def model_files(self, finger: str) -> list[str]:
        """The nominal model of ``finger`` (what its controller and estimator assume)."""
        return [str(hand_config_dir() / f'{finger}.yaml')]

    def plant_files(self, finger: str) -> list[str]:
        """The plant's model of ``finger``: its file, then the patient merged over it."""
        return with_patient(self.model_files(finger), self.patient)

    def parameters(self, executable: str, finger: str) -> dict:
        """The per-finger parameters of one node (they win over ``--ros-args`` values)."""
        sim = self.clock == 'sim'
        if executable == PLANT_NODE.executable:
            values = {
                'params_file': self.plant_files(finger),
                'joint_prefix': f'{finger}_',
                'clock': self.clock,
            }
            if sim:
                values.update(
                    real_time_factor=self.time.real_time_factor,
                    lockstep=self.time.lockstep,
                    lockstep_timeout=self.time.lockstep_timeout,
                    start_paused=self.time.start_paused,
                    pause_at=self.time.pause_at,
                )
            return values
        values = {'params_file': self.model_files(finger), 'use_sim_time': sim}
        if executable == PRESSURE_COMMAND_NODE.executable:
            values.update(mode=self.mode, lockstep=sim and self.time.lockstep)
        return values

    def arguments(self) -> list[str]:
        """The command line that gives ``hand_nodes`` this configuration."""
        values = {
            'fingers': ','.join(self.fingers),
            'namespace': self.namespace,
            'mode': self.mode,
            'patient': self.patient,
            'estimator': _text(self.estimator),
            'clock': self.clock,
            'real_time_factor': repr(self.time.real_time_factor),
            'lockstep': _text(self.time.lockstep),
            'lockstep_timeout': repr(self.time.lockstep_timeout),
            'start_paused': _text(self.time.start_paused),
            'pause_at': repr(self.time.pause_at),
        }
        return [text for option in hand_options() for text in (option.flag, values[option.name])]


def hand_config(options: argparse.Namespace) -> HandConfig:
    """The :class:`HandConfig` of parsed :func:`add_hand_arguments` options (HandError)."""
    try:
        check_namespace(options.namespace, '/hand or /left/hand')
    except UsageError as error:  # refused here: a node refuses it only once started
        raise HandError(str(error)) from None
    return HandConfig(
        fingers=tuple(f.strip() for f in options.fingers.split(',') if f.strip()),
        namespace=options.namespace,
        mode=options.mode,
        patient=options.patient,
        estimator=options.estimator == 'true',
        clock=options.clock,
        time=TimeSettings(
            real_time_factor=_checked('real_time_factor', options.real_time_factor),
            lockstep=options.lockstep == 'true',
            lockstep_timeout=_checked('lockstep_timeout', options.lockstep_timeout),
            start_paused=options.start_paused == 'true',
            pause_at=_checked('pause_at', options.pause_at),
        ),
    )
