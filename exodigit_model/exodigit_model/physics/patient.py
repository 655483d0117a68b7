"""The patient's finger as the kernels see it: constants per joint (docs/spec/model.md §11).

The torque law itself, eqs (11.1)-(11.3), is :func:`.kernels.patient.finger_torque`; this module
turns a validated :class:`.params.FingerJoint` into its row of ``GloveConstants.laws`` (columns
``LAW_*`` of :mod:`.kernels.constants`), with the offsets that make e(q_r) = 0 and s(0) = 0
computed once. :func:`finger_rows` gives the same constants for several fingers at once: the
patients of a batch (docs/spec/model.md §13, "A population").
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..kernels.constants import (
    LAW_COLUMNS,
    LAW_LOWER_AT_REST,
    LAW_PARAMETERS,
    LAW_SPASTIC_AT_ZERO,
    LAW_UPPER_AT_REST,
)
from ..kernels.patient import SPASTICITY_WIDTH, softplus_and_sigmoid
from .params import Finger, FingerJoint


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


def finger_rows(fingers: Sequence[Finger]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The kernels' constants of each of ``fingers`` (validated), as rows.

    Returns
    -------
    finger_half_lengths : ndarray, shape (N, 3)
        The links' half lengths, m (``GloveConstants.finger_half_lengths`` per finger).
    laws : ndarray, shape (N, 3, LAW_COLUMNS)
        :func:`law_row` of each joint (``GloveConstants.laws`` per finger).
    """
    finger_half_lengths = np.array(
        [[joint.link_half_length for joint in finger.joints] for finger in fingers]
    )
    laws = np.array([[law_row(joint) for joint in finger.joints] for finger in fingers])
    return finger_half_lengths, laws
