"""The patient identified as an effective linear spring (docs/spec/model.md §7, §11 "Estimation").

Whatever the true finger is, the estimate τ̂_H = (J_H*)ᵀ f̂ of the torque it resists with is
fitted per joint by ordinary least squares with an intercept,

    τ̂_H,k ≈ k_k q_k + b_k = k_k (q_k − q_r,k),     q_r,k = −b_k / k_k,

which gives the joint's stiffness k and rest angle q_r with their standard errors (the rest
angle's by the delta method), and the fit's RMSE: how far a linear spring is from explaining the
data (large for a finger that stiffens near its range of motion or resists fast stretch). A
steady voluntary effort u the fit does not see is indistinguishable from a shift of the rest
angle: the fit returns q_r + u/k. The estimator node and ``exodigit calibrate`` both use this one
function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .params import JOINT_NAMES

MIN_EXCITATION = 1e-6
"""Smallest Σ (q_k − mean q_k)² (rad²) that identifies joint k: a joint that did not move says
nothing about its stiffness."""


@dataclass(frozen=True)
class StiffnessFit:
    """The effective linear patient fitted to samples, per joint (MCP, PIP, DIP).

    Attributes
    ----------
    stiffness : ndarray, shape (3,)
        k per joint, N·m/rad.
    standard_error : ndarray, shape (3,)
        Standard error of each stiffness, N·m/rad (NaN with fewer than three samples).
    rest_angle : ndarray, shape (3,)
        q_r per joint, rad (NaN where the fitted stiffness is zero).
    rest_angle_standard_error : ndarray, shape (3,)
        Its standard error, rad (delta method; NaN with fewer than three samples).
    rmse : ndarray, shape (3,)
        Root-mean-square misfit of the linear spring, N·m.
    samples : int
        Number of samples used.
    """

    stiffness: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    rest_angle: NDArray[np.float64]
    rest_angle_standard_error: NDArray[np.float64]
    rmse: NDArray[np.float64]
    samples: int


def fit_stiffness(angles: NDArray, joint_torque: NDArray) -> StiffnessFit:
    """Fit τ_H,k = k_k (q_k − q_r,k) per joint over samples of shape (N, 3).

    Parameters
    ----------
    angles : ndarray, shape (N, 3)
        Joint angles, rad.
    joint_torque : ndarray, shape (N, 3)
        The torque the finger resists with at each sample, N·m.

    Raises
    ------
    ValueError
        If there are fewer than two samples, or a joint did not move (its spread of angles is
        below MIN_EXCITATION).
    """
    samples = angles.shape[0]
    if samples < 2:
        raise ValueError(
            f'{samples} sample(s): identifying stiffness and rest angle needs at least two states'
        )
    mean_q, mean_torque = angles.mean(axis=0), joint_torque.mean(axis=0)
    spread = angles - mean_q
    excitation = np.sum(spread * spread, axis=0)
    for name, value in zip(JOINT_NAMES, excitation, strict=True):
        if value < MIN_EXCITATION:
            raise ValueError(
                f'the {name} joint barely moved (sum of (q - mean q)^2 = {value:.3g} rad^2 < '
                f'{MIN_EXCITATION:g}): no excitation to identify its stiffness'
            )
    stiffness = np.sum(spread * (joint_torque - mean_torque), axis=0) / excitation
    intercept = mean_torque - stiffness * mean_q
    misfit = joint_torque - (stiffness * angles + intercept)
    squares = np.sum(misfit * misfit, axis=0)
    with np.errstate(divide='ignore', invalid='ignore'):
        rest_angle = -intercept / stiffness
        if samples > 2:
            variance = squares / (samples - 2)
            var_k = variance / excitation
            var_b = variance * (1.0 / samples + mean_q * mean_q / excitation)
            cov_kb = -mean_q * variance / excitation
            # q_r = −b/k: ∂q_r/∂b = −1/k, ∂q_r/∂k = b/k².
            d_b, d_k = -1.0 / stiffness, intercept / (stiffness * stiffness)
            var_rest = d_b * d_b * var_b + d_k * d_k * var_k + 2.0 * d_b * d_k * cov_kb
            standard_error, rest_error = np.sqrt(var_k), np.sqrt(np.maximum(var_rest, 0.0))
        else:
            standard_error = rest_error = np.full(3, np.nan)
    return StiffnessFit(
        stiffness=stiffness,
        standard_error=standard_error,
        rest_angle=rest_angle,
        rest_angle_standard_error=rest_error,
        rmse=np.sqrt(squares / samples),
        samples=samples,
    )
