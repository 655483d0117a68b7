"""Identification of the finger's joint stiffness K_H from measured states (MODEL.md §7).

Eq 34 reads τ_H,k = k_H,k q_k per joint, with τ_H = (J_H*)ᵀ f the joint torque that the
contact forces apply to the finger. F is linear in K_H, so given samples of q and τ_H (the
forces from the robot-side estimate) each k_H,k is an ordinary least-squares slope through the
origin, with the usual standard error. The estimator node and ``exodigit calibrate`` both use
this one function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .params import JOINT_NAMES

MIN_EXCITATION = 1e-6
"""Smallest Σ q_k² (rad²) that identifies k_H,k: a joint that never moved says nothing."""


@dataclass(frozen=True)
class StiffnessFit:
    """Least-squares joint stiffness.

    Attributes
    ----------
    stiffness : ndarray, shape (3,)
        k_H per joint, N·m/rad.
    standard_error : ndarray, shape (3,)
        Standard error of each estimate, N·m/rad (NaN with a single sample).
    samples : int
        Number of samples used.
    """

    stiffness: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    samples: int


def fit_stiffness(angles: NDArray, joint_torque: NDArray) -> StiffnessFit:
    """Fit τ_H,k = k_k q_k per joint over samples of shape (N, 3).

    Raises
    ------
    ValueError
        If there are no samples, or a joint never moved (Σ q² < MIN_EXCITATION).
    """
    samples = angles.shape[0]
    if samples == 0:
        raise ValueError('no samples: stiffness identification needs at least one state')
    excitation = np.sum(angles * angles, axis=0)
    for name, value in zip(JOINT_NAMES, excitation, strict=True):
        if value < MIN_EXCITATION:
            raise ValueError(
                f'the {name} joint barely moved (sum of q^2 = {value:.3g} rad^2 < '
                f'{MIN_EXCITATION:g}): no excitation to identify its stiffness'
            )
    stiffness = np.sum(angles * joint_torque, axis=0) / excitation
    if samples > 1:
        misfit = joint_torque - angles * stiffness
        variance = np.sum(misfit * misfit, axis=0) / (samples - 1)
        standard_error = np.sqrt(variance / excitation)
    else:
        standard_error = np.full(3, np.nan)
    return StiffnessFit(stiffness, standard_error, samples)
