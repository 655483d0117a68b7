"""The patient's finger as the kernels see it: constants per joint (docs/spec/model.md §11).

The torque law itself, eqs (11.1)-(11.3), is :func:`.kernels.patient.finger_torque`; this module
turns a validated :class:`.params.FingerJoint` into its row of ``GloveConstants.laws`` (columns
``LAW_*`` of :mod:`.kernels.constants`), with the offsets that make e(q_r) = 0 and s(0) = 0
computed once.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .kernels.constants import (
    LAW_COLUMNS,
    LAW_LOWER_AT_REST,
    LAW_PARAMETERS,
    LAW_SPASTIC_AT_ZERO,
    LAW_UPPER_AT_REST,
)
from .kernels.patient import SPASTICITY_WIDTH, softplus_and_sigmoid
from .params import FingerJoint


def law_row(joint: FingerJoint) -> NDArray[np.float64]:
    """The constants of (11.1)-(11.3) for one validated joint, shape (LAW_COLUMNS,)."""
    row = np.zeros(LAW_COLUMNS)
    for column, name in enumerate(LAW_PARAMETERS):
        row[column] = getattr(joint, name)
    beta = joint.rom_sharpness
    row[LAW_UPPER_AT_REST] = math.exp(beta * (joint.rest_angle - joint.rom_max))
    row[LAW_LOWER_AT_REST] = math.exp(beta * (joint.rom_min - joint.rest_angle))
    threshold = -joint.spasticity_threshold / SPASTICITY_WIDTH
    row[LAW_SPASTIC_AT_ZERO] = SPASTICITY_WIDTH * softplus_and_sigmoid(threshold)[0]
    return row
