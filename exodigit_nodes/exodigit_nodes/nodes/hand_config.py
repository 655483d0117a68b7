"""What a hand is: its fingers, where they live, and the options that configure it (no rclpy).

One table of options, :func:`hand_options`, serves ``hand_nodes`` (the process that runs every
finger's nodes), the hand runner ``python -m exodigit_nodes.hand`` and ``launch/hand.launch.py``;
its entries and checks are the glove runner's too (:mod:`.run_options`): the time options are
the plant's parameters of the same names (:mod:`.catalog`), with their defaults, descriptions
and checks, and ``mode`` is ``pressure_command``'s.

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
from .run_options import (
    BOOLEANS,
    RunOption,
    add_options,
    check_sim_only,
    namespace_option,
    parameter_option,
    patient_option,
    text,
    time_options,
    time_parameters,
    time_settings,
)

FINGERS = ('thumb', 'index', 'middle', 'ring', 'little')
"""The fingers of a hand, thumb first."""
TIME_PARAMETERS = ('real_time_factor', 'lockstep', 'lockstep_timeout', 'start_paused', 'pause_at')
"""Plant parameters that are options of the hand besides ``clock`` (one simulated time for every
finger)."""
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


def hand_config_dir() -> Path:
    """``config/hand`` of the package: in the source tree, or in its ament share directory."""
    source = Path(__file__).resolve().parents[2] / 'config' / 'hand'
    if source.is_dir():
        return source
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory('exodigit_nodes')) / 'config' / 'hand'


def hand_options() -> tuple[RunOption, ...]:
    """Every option of the hand, in ``--help`` order."""
    return (
        RunOption(
            'fingers',
            ','.join(FINGERS),
            f'comma-separated fingers, each of {",".join(FINGERS)} at most once',
        ),
        namespace_option('/hand', 'the hand; finger f in <namespace>/f'),
        parameter_option('mode', note=' (every finger)'),
        patient_option(NOMINAL_PATIENT, "every plant's finger file"),
        RunOption(
            'estimator', 'true', 'run an estimator per finger', choices=BOOLEANS, switch=True
        ),
        *time_options(TIME_PARAMETERS, note=' (the whole hand)'),
    )


def add_hand_arguments(parser: argparse.ArgumentParser) -> None:
    """Put every hand option on ``parser`` (values stay text; :func:`hand_config` reads them)."""
    add_options(parser, hand_options())


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
            raise UsageError(
                f'--fingers {",".join(self.fingers)}: give distinct names from {",".join(FINGERS)}'
            )
        check_sim_only(self.clock, self.time, TIME_PARAMETERS)

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
        values = time_parameters(executable, self.clock, self.time, TIME_PARAMETERS)
        if executable == PLANT_NODE.executable:
            return {
                'params_file': self.plant_files(finger),
                'joint_prefix': f'{finger}_',
                **values,
            }
        values['params_file'] = self.model_files(finger)
        if executable == PRESSURE_COMMAND_NODE.executable:
            values['mode'] = self.mode
        return values

    def arguments(self) -> list[str]:
        """The command line that gives ``hand_nodes`` this configuration."""
        values = {
            'fingers': ','.join(self.fingers),
            'namespace': self.namespace,
            'mode': self.mode,
            'patient': self.patient,
            'estimator': text(self.estimator),
            'clock': self.clock,
            'real_time_factor': repr(self.time.real_time_factor),
            'lockstep': text(self.time.lockstep),
            'lockstep_timeout': repr(self.time.lockstep_timeout),
            'start_paused': text(self.time.start_paused),
            'pause_at': repr(self.time.pause_at),
        }
        return [text for option in hand_options() for text in (option.flag, values[option.name])]


def hand_config(options: argparse.Namespace) -> HandConfig:
    """The :class:`HandConfig` of parsed :func:`add_hand_arguments` options (UsageError)."""
    check_namespace(options.namespace, '/hand or /left/hand')  # a node refuses it only started
    return HandConfig(
        fingers=tuple(f.strip() for f in options.fingers.split(',') if f.strip()),
        namespace=options.namespace,
        mode=options.mode,
        patient=options.patient,
        estimator=options.estimator == 'true',
        clock=options.clock,
        time=time_settings({name: getattr(options, name) for name in TIME_PARAMETERS}),
    )
