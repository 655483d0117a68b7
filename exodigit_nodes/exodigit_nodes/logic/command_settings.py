"""What ``pressure_command``'s parameters mean: checked settings, safety limits and controller.

Its parameter values (the node table, ``nodes/catalog.py``) checked together into
:class:`CommandSettings`, and the controller of its ``mode``
(:mod:`exodigit_model.control`, the controllers of in-process trials too).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from exodigit_model.control import (
    LOOP_PARAMETERS,
    Controller,
    ForceController,
    Hold,
    PositionController,
    SafetyLimits,
    Sine,
    Staircase,
    ValveLoopSettings,
)

if TYPE_CHECKING:
    from exodigit_model import GloveModel

LIMIT_NAMES = frozenset(
    {
        'max_pressure',
        'max_pressure_rate',
        'joint_lower_limits',
        'joint_upper_limits',
        'max_contact_force',
        'feedback_timeout',
    }
)
"""The parameters that change limits only: a new value keeps the controller and its session."""
VALVE_NAMES = frozenset(LOOP_PARAMETERS)
"""The valve loop's parameters (:class:`exodigit_model.control.ValveLoopSettings`' fields)."""


def safety_limits(values: dict[str, Any]) -> SafetyLimits:
    """The safety limits of a set of pressure_command parameter values."""
    return SafetyLimits(
        max_pressure=values['max_pressure'],
        max_pressure_rate=values['max_pressure_rate'],
        joint_lower=values['joint_lower_limits'],
        joint_upper=values['joint_upper_limits'],
        max_contact_force=values['max_contact_force'],
    )


@dataclass(frozen=True)
class CommandSettings:
    """The command node's settings: its parameter values, the safety limits and valve loop."""

    values: dict[str, Any]
    limits: SafetyLimits
    valve_loop: ValveLoopSettings


def command_settings(values: dict[str, Any]) -> CommandSettings:
    """Check the parameters together (ValueError naming the parameter)."""
    if values['sine_low'] > values['sine_high']:
        raise ValueError(
            f'sine_low ({values["sine_low"]:g} Pa) must not exceed sine_high '
            f'({values["sine_high"]:g} Pa)'
        )
    if values['staircase_peak'] < values['staircase_step']:
        raise ValueError(
            f'staircase_peak ({values["staircase_peak"]:g} Pa) must be at least '
            f'staircase_step ({values["staircase_step"]:g} Pa)'
        )
    limits = safety_limits(values)
    targets = np.array(values['joint_targets'])
    if ((targets < limits.joint_lower) | (targets > limits.joint_upper)).any():
        raise ValueError(
            f'joint_targets {list(values["joint_targets"])} rad must lie inside '
            'joint_lower_limits .. joint_upper_limits'
        )
    valve_loop = ValveLoopSettings(**{name: values[name] for name in VALVE_NAMES})
    return CommandSettings(values, limits, valve_loop)


def make_controller(
    values: dict[str, Any], model: Callable[[], GloveModel], targets: np.ndarray
) -> Controller:
    """The controller of ``values['mode']``; ``model()`` gives the feed-forward's model.

    ``targets``: the joint angles (rad) the position mode starts at.
    """
    v = values
    mode = v['mode']
    if mode == 'staircase':
        return Staircase(v['staircase_step'], v['staircase_peak'], v['step_duration'])
    if mode == 'sine':
        return Sine(v['sine_low'], v['sine_high'], v['sine_period'])
    if mode == 'hold':
        return Hold(np.array(v['hold_pressure']))
    if mode == 'position':
        return PositionController(model(), targets, v['position_kp'], v['position_ki'])
    return ForceController(model(), v['force_targets'], v['force_kp'], v['force_ki'])
