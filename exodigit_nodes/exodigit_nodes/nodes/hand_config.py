"""What a hand is: its gloves, where they live, and the one option table (no rclpy).

A hand is a set of gloves (:class:`Glove`), one per finger, each in ``<namespace>/<finger>``
with its model file ``config/hand/<finger>.yaml``; a lone glove is the hand of one finger with
no finger level (docs/running.md, "A whole hand"). :func:`command_options` is the one table of
options of the glove and hand runners, ``hand_nodes`` and ``launch/hand.launch.py``;
:func:`hand_config` reads and checks the parsed options of any of them.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path

from ..logic.options import NOMINAL_PATIENT, UsageError, check_namespace, with_patient
from ..logic.pacing import TimeSettings
from .catalog import ESTIMATOR_NODE, HARDWARE_NODE, NODES, PLANT_NODE, PRESSURE_COMMAND_NODE
from .run_options import (
    BOOLEANS,
    TIME_OPTIONS,
    RunOption,
    check_sim_only,
    flag,
    parameter_option,
    text,
    time_parameters,
    time_settings,
)

FINGERS = ('thumb', 'index', 'middle', 'ring', 'little')
"""The fingers of a hand, thumb first."""
COMMANDS = ('glove', 'hand', 'hand_nodes')
"""The commands :func:`command_options` has a table for."""
EMULATED = 'emulated'
"""``--hardware`` value for the emulated board (``mcu_emulator``)."""
DEFAULT_PATIENTS = {'glove': 'stroke_moderate', 'hand': NOMINAL_PATIENT}
"""The finger the plants simulate by default: the glove's shows the estimator identifying a
patient who is not the finger it assumes; a hand's fingers are their own files'."""


def hand_config_dir() -> Path:
    """``config/hand`` of the package: in the source tree, or in its ament share directory."""
    source = Path(__file__).resolve().parents[2] / 'config' / 'hand'
    if source.is_dir():
        return source
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory('exodigit_nodes')) / 'config' / 'hand'


def command_options(command: str) -> tuple[RunOption, ...]:
    """The options of ``command`` (of :data:`COMMANDS`), in ``--help`` order: the one table.

    The glove has ``--params-file`` and ``--hardware``, no finger level (``--fingers``,
    ``--estimator``) and no ``--lockstep-timeout``; the runners ``--record``, ``hand_nodes``
    ``--start-paused`` (the runners start paused with ``--clock sim``).
    """
    from exodigit_model.physics.params import PATIENT_PRESETS

    if command not in COMMANDS:
        raise ValueError(f'command {command!r}: one of {", ".join(COMMANDS)}')
    glove = command == 'glove'
    hand = '' if glove else ' (the whole hand)'
    whom = 'the glove' if glove else 'the hand; finger f in <namespace>/f'
    options = [
        RunOption(
            'fingers',
            ','.join(FINGERS),
            f'comma-separated fingers, each of {",".join(FINGERS)} at most once',
        ),
        RunOption('namespace', '/glove' if glove else '/hand', f'ROS namespace of {whom}'),
        parameter_option('mode', note='' if glove else ' (every finger)'),
        parameter_option(
            'actuation',
            note=' (every finger)' * (not glove) + '; with valves pressure_command publishes '
            'valve_command from its pressure loop (output valves)'
            + '; default regulator, valves with --hardware'
            * glove,
            default='' if glove else None,
        ),
        RunOption(
            'hardware',
            '',
            "run the glove on a board, the hardware bridge in the plant's place (docs/"
            f'hardware.md): {EMULATED} (mcu_emulator, the simulated patient behind an emulated '
            'board on a pseudo-terminal) or the serial port of a board (/dev/ttyACM0); the '
            'chambers then have valves (actuation valves) and the glove runs on the wall clock; '
            'default none (the simulated plant)',
            metavar=f'{EMULATED}|PORT',
        ),
        RunOption(
            'params_file',
            '',
            'model parameter YAML (docs/spec/model.md §10) of the glove, for every node; default '
            'built-in values',
            metavar='FILE',
        ),
        RunOption(
            'patient',
            DEFAULT_PATIENTS['glove' if glove else 'hand'],
            'the finger the plant simulates (docs/spec/model.md §11): a preset '
            f'({", ".join(PATIENT_PRESETS)}), a patient YAML, or nominal, merged over '
            + ('the glove file' if glove else "every plant's finger file")
            + '; the controllers and estimators assume the nominal finger',
            metavar='NAME|FILE',
        ),
        RunOption(
            'estimator', 'true', 'run an estimator per finger', choices=BOOLEANS, switch=True
        ),
        *(parameter_option(name, note=hand) for name in ('clock', *TIME_OPTIONS)),
        RunOption(
            'record',
            'false',
            'also record every topic to a rosbag2 MCAP bag in the run directory'
            + ('' if glove else ' (a bag per finger: bag/<finger>)'),
            choices=BOOLEANS,
            switch=True,
        ),
    ]
    lone = {'fingers', 'estimator', 'lockstep_timeout'} if glove else {'params_file', 'hardware'}
    runner = {'start_paused'} if command in ('glove', 'hand') else {'record'}
    return tuple(option for option in options if option.name not in lone | runner)


@dataclass(frozen=True)
class Glove:
    """One glove of a hand: where its nodes live and the finger they assume.

    Attributes
    ----------
    finger : str
        The finger's name; empty for a lone glove (no finger level).
    namespace : str
        Absolute namespace of its nodes.
    joint_prefix : str
        Prefix of its joint names (``index_``: ``index_mcp, ...``).
    model_files : tuple of str
        The nominal model, which its controller and estimator assume (empty: built-in).
    plant_files : tuple of str
        The plant's model: the nominal one with the patient merged over it.
    """

    finger: str
    namespace: str
    joint_prefix: str
    model_files: tuple[str, ...]
    plant_files: tuple[str, ...]


@dataclass(frozen=True)
class HandConfig:
    """One hand: which gloves, where, how their commands and their time run.

    Attributes
    ----------
    fingers : tuple of str
        Finger names, each in :data:`FINGERS` at most once; empty: a lone glove.
    namespace : str
        Absolute namespace of the hand.
    mode : str
        ``pressure_command`` mode of every finger.
    actuation : str
        Every plant's ``actuation``; with ``valves`` every ``pressure_command`` has ``output``
        valves.
    patient : str
        ``nominal``, a patient preset or a patient YAML merged over every plant's finger file.
    estimator : bool
        An estimator per finger.
    clock : str
        ``wall`` or ``sim``.
    time : TimeSettings
        With ``clock`` sim: pace, lockstep, pause.
    params_file : str
        The lone glove's model file (empty: built-in); the fingers have their own.
    hardware : str
        A lone glove on a board, the ``hardware`` bridge in the plant's place: :data:`EMULATED`
        or the board's serial port; empty: the simulated plant.
    """

    fingers: tuple[str, ...] = FINGERS
    namespace: str = '/hand'
    mode: str = PRESSURE_COMMAND_NODE.table['mode'].default
    actuation: str = PLANT_NODE.table['actuation'].default
    patient: str = NOMINAL_PATIENT
    estimator: bool = True
    clock: str = PLANT_NODE.table['clock'].default
    time: TimeSettings = field(default_factory=TimeSettings)
    params_file: str = ''
    hardware: str = ''

    def __post_init__(self) -> None:
        unknown = [f for f in self.fingers if f not in FINGERS]
        if unknown or len(set(self.fingers)) != len(self.fingers):
            raise UsageError(
                f'--fingers {",".join(self.fingers)}: give distinct names from {",".join(FINGERS)}'
            )
        if self.fingers and self.params_file:
            raise UsageError('--params-file: a lone glove has one; every finger has its own')
        if self.hardware and (self.fingers or self.clock != 'wall' or self.actuation != 'valves'):
            actuation = '' if self.actuation == 'valves' else f' and --actuation {self.actuation}'
            raise UsageError(
                f'--hardware {self.hardware}: a lone glove with valves on the wall clock (a board '
                f'has no simulated time): leave out --clock sim{actuation}'
            )

    def node_entries(self):
        """The catalog entries of a finger's nodes, in start order (:data:`.catalog.NODES`).

        On a board the ``hardware`` bridge stands in the plant's place.
        """
        glove = HARDWARE_NODE if self.hardware else PLANT_NODE
        return tuple(
            glove if entry is PLANT_NODE else entry
            for entry in NODES
            if self.estimator or entry is not ESTIMATOR_NODE
        )

    def gloves(self) -> tuple[Glove, ...]:
        """The gloves of the hand, one per finger (a lone glove: one)."""
        if not self.fingers:
            files = (self.params_file,) if self.params_file else ()
            return (self._glove('', self.namespace, '', files),)
        return tuple(
            self._glove(
                finger,
                f'{self.namespace.rstrip("/")}/{finger}',
                f'{finger}_',
                (str(hand_config_dir() / f'{finger}.yaml'),),
            )
            for finger in self.fingers
        )

    def _glove(self, finger: str, namespace: str, prefix: str, files: tuple) -> Glove:
        plant = tuple(with_patient(list(files), self.patient))
        return Glove(finger, namespace, prefix, files, plant)

    def parameters(self, executable: str, glove: Glove, emulator_link: str = '') -> dict:
        """The parameters of one node of ``glove`` (they win over ``--ros-args`` values).

        Those at the node's default (no joint prefix, no model file) are left out. The bridge's
        port is the board's, or ``emulator_link`` (where the emulated board's pty appears).
        """
        values = time_parameters(executable, self.clock, self.time)
        bridge = executable == HARDWARE_NODE.executable
        plant = executable == PLANT_NODE.executable
        if bridge:
            if self.hardware == EMULATED and not emulator_link:
                raise ValueError('the bridge to an emulated board needs its emulator_link')
            values['port'] = emulator_link if self.hardware == EMULATED else self.hardware
        elif files := (glove.plant_files if plant else glove.model_files):
            values['params_file'] = list(files)
        if (bridge or plant) and glove.joint_prefix:
            values['joint_prefix'] = glove.joint_prefix
        if executable == ESTIMATOR_NODE.executable and self.hardware:
            values['glove_node'] = HARDWARE_NODE.executable
        if plant and self.actuation == 'valves':
            values['actuation'] = 'valves'
        if executable == PRESSURE_COMMAND_NODE.executable:
            values['mode'] = self.mode
            if self.actuation == 'valves':
                values['output'] = 'valves'
        return values

    def arguments(self) -> list[str]:
        """The command line that gives ``hand_nodes`` this configuration (a hand of fingers)."""
        words = []
        for option in command_options('hand_nodes'):
            value = getattr(self.time if option.name in TIME_OPTIONS else self, option.name)
            given = ','.join(value) if option.name == 'fingers' else text(value)
            words += [flag(option.name), given]
        return words


def hand_config(options: argparse.Namespace) -> HandConfig:
    """The :class:`HandConfig` of parsed :func:`command_options` options (UsageError).

    The options a command does not have keep their defaults: no ``--fingers``, a lone glove.
    The time options on the wall clock are refused naming those the command has. A glove on a
    board (``--hardware``) has valves: ``--actuation`` left out means valves there (regulator
    elsewhere), and ``--actuation regulator`` is refused.
    """
    check_namespace(options.namespace, '/glove, /hand or /left/hand')
    names = [name for name in TIME_OPTIONS if hasattr(options, name)]
    time = time_settings({name: getattr(options, name) for name in names})
    check_sim_only(options.clock, time, names)
    fingers = ()
    if hasattr(options, 'fingers'):
        fingers = tuple(f.strip() for f in options.fingers.split(',') if f.strip())
        if not fingers:
            raise UsageError(f'--fingers {options.fingers!r}: give at least one finger')
    hardware = getattr(options, 'hardware', '')
    return HandConfig(
        fingers=fingers,
        namespace=options.namespace,
        mode=options.mode,
        actuation=options.actuation or ('valves' if hardware else HandConfig.actuation),
        patient=options.patient,
        estimator=getattr(options, 'estimator', 'true') == 'true',
        clock=options.clock,
        time=time,
        params_file=getattr(options, 'params_file', ''),
        hardware=hardware,
    )
