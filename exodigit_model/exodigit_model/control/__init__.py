"""The glove's built-in controllers and its safety limiter, without ROS.

What the ``pressure_command`` node of ``exodigit_nodes`` computes each step (docs/spec/ros.md,
"Safety behaviour"), for in-process use: :class:`~exodigit_model.gym.env.GloveEnv` puts the same
limiter between an agent and the chambers, and a controller can be tried on a simulated patient
with no ROS at all. The same classes control one glove (arrays (3,)) or a batch of gloves
((N, 3), one row each); :class:`BatchController` is the protocol a virtual-patient trial steps,
and :class:`BuiltInMode` runs a built-in mode behind the limiter as one. Behind valves
(docs/spec/model.md §14) :class:`ValveLoop` turns the pressures a mode and the limiter give into
the six valve openings, as ``pressure_command`` does with ``output:=valves``. A
:class:`Trajectory` is the position mode's timed targets, sampled by the node and in process
alike, and a :class:`Setpoint` the node's targets over time (:mod:`.trajectory`).
"""

from .batch import BatchController, BuiltInMode
from .controllers import (
    MODE_DEFAULTS,
    MODES,
    Command,
    CommandLoop,
    Controller,
    Feedback,
    ForceController,
    Hold,
    OpenLoop,
    PIController,
    PositionController,
    Sine,
    Staircase,
    mode_controller,
)
from .safety import LIMIT_KINDS, LIMIT_PARAMETERS, Limited, SafetyLimiter, SafetyLimits
from .trajectory import Setpoint, Trajectory, TrajectoryError
from .valve_loop import LOOP_PARAMETERS, OUTPUTS, ValveLoop, ValveLoopSettings

__all__ = [
    'LIMIT_KINDS',
    'LIMIT_PARAMETERS',
    'LOOP_PARAMETERS',
    'MODES',
    'MODE_DEFAULTS',
    'OUTPUTS',
    'BatchController',
    'BuiltInMode',
    'Command',
    'CommandLoop',
    'Controller',
    'Feedback',
    'ForceController',
    'Hold',
    'Limited',
    'OpenLoop',
    'PIController',
    'PositionController',
    'SafetyLimiter',
    'SafetyLimits',
    'Setpoint',
    'Sine',
    'Staircase',
    'Trajectory',
    'TrajectoryError',
    'ValveLoop',
    'ValveLoopSettings',
    'mode_controller',
]
