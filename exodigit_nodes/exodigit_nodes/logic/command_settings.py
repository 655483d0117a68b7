"""``pressure_command``'s parameter values checked together: safety limits and valve loop.

The controller of its ``mode`` is :func:`exodigit_model.control.mode_controller`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from exodigit_model.control import (
    LIMIT_PARAMETERS,
    LOOP_PARAMETERS,
    SafetyLimits,
    ValveLoopSettings,
)

LIMIT_NAMES = frozenset({*LIMIT_PARAMETERS, 'feedback_timeout'})
"""The parameters that change limits only: a new value keeps the controller and its session."""
VALVE_NAMES = frozenset(LOOP_PARAMETERS)
"""The valve loop's parameters (:class:`exodigit_model.control.ValveLoopSettings`' fields)."""
ORDERED = (('sine_low', 'sine_high'), ('staircase_step', 'staircase_peak'))
"""Pairs of pressures (Pa) whose first may not exceed the second."""


def safety_limits(values: dict[str, Any]) -> SafetyLimits:
    """The safety limits of a set of pressure_command parameter values."""
    return SafetyLimits(**{field: values[name] for name, field in LIMIT_PARAMETERS.items()})


def command_settings(values: dict[str, Any]) -> tuple[SafetyLimits, ValveLoopSettings]:
    """Check the parameters together: the safety limits and the valve loop's settings.

    Raises
    ------
    ValueError
        Naming the parameters whose values do not go together.
    """
    for low, high in ORDERED:
        if values[low] > values[high]:
            raise ValueError(
                f'{low} ({values[low]:g} Pa) must not exceed {high} ({values[high]:g} Pa)'
            )
    limits = safety_limits(values)
    targets = np.array(values['joint_targets'])
    if ((targets < limits.joint_lower) | (targets > limits.joint_upper)).any():
        raise ValueError(
            f'joint_targets {list(values["joint_targets"])} rad must lie inside '
            'joint_lower_limits .. joint_upper_limits'
        )
    return limits, ValveLoopSettings(**{name: values[name] for name in VALVE_NAMES})
