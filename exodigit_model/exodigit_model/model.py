"""The glove model: one object that answers every question the nodes and tools ask.

:class:`GloveModel` holds the validated parameters and everything derived from them once (the
pressure moments of eq 12, the τ_s tables). Its methods take and return numpy arrays in SI
units, joints in the order MCP, PIP, DIP:

- forward: :meth:`GloveModel.solve` (eq 36 for q given p), :meth:`GloveModel.solve_batch`,
  :meth:`GloveModel.solve_free` (no finger, paper §3.3);
- inverse: :meth:`GloveModel.pressure_for` (p for desired q, exact);
- estimation: :meth:`GloveModel.estimate_forces` (robot side, needs no finger model),
  :meth:`GloveModel.finger_forces` (finger side), :meth:`GloveModel.identify_stiffness`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._backend import ArrayOps, ScalarOps
from .coupling import (
    Evaluation,
    Geometry,
    contact_jacobians,
    transpose_product,
    transpose_solve,
)
from .identification import StiffnessFit, fit_stiffness
from .kinematics import arc_points, chain, chords, finger_chain
from .params import GloveParams, load_params
from .section import pressure_moment
from .solver import newton
from .structural import StructuralTorque

VALID_STRETCH = (1.0, 1.5)
"""Stretch range the model is validated for (paper §2.1.3)."""


@dataclass(frozen=True)
class Solution:
    """Result of one coupled (or free) solve.

    Attributes
    ----------
    q : ndarray, shape (3,)
        Joint angles, rad. The start guess if the solve did not converge (never NaN).
    forces : ndarray, shape (3,)
        Contact forces f = (J_H*)^{-T} K_H q, N (zero for free motion).
    pressure : ndarray, shape (3,)
        The chamber pressures solved for, Pa.
    converged : bool
        Whether the residual norm reached :data:`.solver.RESIDUAL_TOLERANCE`.
    iterations : int
        Newton steps taken.
    residual : float
        2-norm of F(q, p) at ``q``, N·m.
    in_valid_range : bool
        Whether every fibre's stretch lies in 1 ≤ λ ≤ 1.5 (the model's validated range).
    """

    q: NDArray[np.float64]
    forces: NDArray[np.float64]
    pressure: NDArray[np.float64]
    converged: bool
    iterations: int
    residual: float
    in_valid_range: bool


@dataclass(frozen=True)
class GlovePose:
    """Positions of the exo-digit and the finger at joint angles q, m, as (x, y) rows.

    The exo-digit's base block starts at the origin and points along +x; q > 0 bends towards +y,
    the side of its inextensible layer, where the finger is. The finger is given in its own
    frame, MCP joint at the origin, links along +x at q = 0; place it under the exo-digit with
    ``finger_joints + offset`` when drawing.

    Attributes
    ----------
    block_origins : ndarray, shape (4, 2)
        Proximal ends of the base block and blocks 1-3.
    block_ends : ndarray, shape (4, 2)
        Distal ends of the base block and blocks 1-3.
    contact_points : ndarray, shape (3, 2)
        Centres of blocks 1-3, where the contact forces act.
    contact_normals : ndarray, shape (3, 2)
        Unit normals n_i of blocks 1-3 (direction of a positive contact force on the finger).
    arcs : ndarray, shape (3, samples, 2)
        Points along the three soft arcs.
    finger_joints : ndarray, shape (4, 2)
        MCP, PIP, DIP joints and the fingertip.
    finger_contacts : ndarray, shape (3, 2)
        Centres of the three finger links.
    """

    block_origins: NDArray[np.float64]
    block_ends: NDArray[np.float64]
    contact_points: NDArray[np.float64]
    contact_normals: NDArray[np.float64]
    arcs: NDArray[np.float64]
    finger_joints: NDArray[np.float64]
    finger_contacts: NDArray[np.float64]


def _xy(points) -> NDArray[np.float64]:
    array = np.asarray(points, dtype=complex)
    return np.stack([array.real, array.imag], axis=-1)


@dataclass(frozen=True)
class BatchSolution:
    """Result of :meth:`GloveModel.solve_batch`; the fields of :class:`Solution`, per row."""

    q: NDArray[np.float64]
    forces: NDArray[np.float64]
    pressure: NDArray[np.float64]
    converged: NDArray[np.bool_]
    iterations: NDArray[np.int_]
    residual: NDArray[np.float64]
    in_valid_range: NDArray[np.bool_]


def as_joint_list(name: str, value: ArrayLike) -> list[float]:
    """``value`` as a list of three finite floats (MCP, PIP, DIP), or a ValueError naming it."""
    try:
        values = [float(v) for v in value]
    except (TypeError, ValueError):
        values = None
    if values is None or len(values) != 3:
        raise ValueError(
            f'{name} must be three numbers (MCP, PIP, DIP), got shape {np.shape(value)}'
        )
    if not (math.isfinite(values[0]) and math.isfinite(values[1]) and math.isfinite(values[2])):
        raise ValueError(f'{name} must be finite, got {values}')
    return values


def as_joint_vector(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a finite float array of shape (3,), or a ValueError naming ``name``."""
    return np.array(as_joint_list(name, value))


def as_joint_rows(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a finite float array of shape (N, 3), or a ValueError naming ``name``."""
    array = np.asarray(value, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f'{name} must have shape (N, 3) (MCP, PIP, DIP), got {array.shape}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} must be finite')
    return array


class GloveModel:
    """Quasi-static model of the soft exo-digit strapped to a finger (MODEL.md).

    Parameters
    ----------
    params : GloveParams, optional
        Validated parameters; the defaults of MODEL.md §10 when omitted.

    Examples
    --------
    >>> model = GloveModel(load_params())
    >>> sol = model.solve([50e3, 50e3, 50e3])
    >>> bool(sol.converged), bool(np.all(sol.q > 0))
    (True, True)
    """

    def __init__(self, params: GloveParams | None = None) -> None:
        self.params = load_params() if params is None else params
        segments = self.params.exo_digit.segments
        joints = self.params.finger.joints
        self.geometry = Geometry(
            arc_lengths=tuple(s.arc_length for s in segments),
            block_half_lengths=(
                self.params.exo_digit.base_block_half_length,
                *(s.block_half_length for s in segments),
            ),
            finger_half_lengths=tuple(j.link_half_length for j in joints),
            stiffness=tuple(j.stiffness for j in joints),
            pressure_moments=tuple(pressure_moment(s) for s in segments),
        )
        self._free_geometry = replace(self.geometry, stiffness=(0.0, 0.0, 0.0))
        self.structural = StructuralTorque(self.params.material, segments)
        self._strain_per_angle = tuple(s.height / s.arc_length for s in segments)

    # -- torques and Jacobians ------------------------------------------------------------

    def structural_torque(self, q: ArrayLike) -> NDArray[np.float64]:
        """τ_s(q), N·m, shape (3,) or (N, 3): negative for q > 0 (eqs 13, 27)."""
        return self.structural.torque(q)[0]

    def structural_stiffness(self, q: ArrayLike) -> NDArray[np.float64]:
        """dτ_s/dq, N·m/rad, shape like ``q`` (negative: the segments resist bending)."""
        return self.structural.torque(q)[1]

    def pressure_torque(self, p: ArrayLike) -> NDArray[np.float64]:
        """τ_p = B_R p, N·m (eqs 11-12)."""
        return np.asarray(self.geometry.pressure_moments) * np.asarray(p, dtype=float)

    def contact_jacobians(self, q: ArrayLike) -> tuple[NDArray, NDArray]:
        """(J_R*, J_H*), each (3, 3) lower triangular, J[i, k] = n_i·∂r_i/∂q_k (MODEL.md §3)."""
        angles = as_joint_vector('q', q).tolist()
        j_robot, j_finger = contact_jacobians(angles, ScalarOps, self.geometry)
        return np.array(j_robot), np.array(j_finger)

    def residual(self, q: ArrayLike, p: ArrayLike, *, free: bool = False) -> NDArray[np.float64]:
        """F(q, p) of eq 36 (or of free motion), N·m."""
        return np.array(self._evaluate(q, p, free=free).residual)

    def residual_jacobian(
        self, q: ArrayLike, p: ArrayLike, *, free: bool = False
    ) -> NDArray[np.float64]:
        """∂F/∂q of eq 36 (analytic), N·m/rad, shape (3, 3)."""
        return np.array(self._evaluate(q, p, free=free).jacobian(), dtype=float)

    def _evaluate(self, q, p, *, free: bool) -> Evaluation:
        geometry = self._free_geometry if free else self.geometry
        return self._evaluate_at(as_joint_list('q', q), as_joint_list('p', p), geometry)

    # -- forward solves ------------------------------------------------------------------

    def solve(
        self, p: ArrayLike, q0: ArrayLike | Solution | None = None, *, free: bool = False
    ) -> Solution:
        """Joint angles and contact forces for chamber pressures ``p`` (eq 36).

        Parameters
        ----------
        p : array_like, shape (3,)
            Gauge pressures, Pa.
        q0 : array_like, shape (3,), or Solution, optional
            Start of the Newton iteration (warm start; a Solution starts from its angles); zero
            when omitted.
        free : bool
            Solve free motion (no finger, τ_s + B_R p = 0) instead.

        Returns
        -------
        Solution
            Never raises for a solve that fails to converge: ``converged`` is False and ``q`` is
            the last finite iterate.
        """
        pressure = as_joint_list('p', p)
        if isinstance(q0, Solution):
            q0 = q0.q
        start = [0.0, 0.0, 0.0] if q0 is None else as_joint_list('q0', q0)
        geometry = self._free_geometry if free else self.geometry
        return self._solve(pressure, self._evaluate_at(start, pressure, geometry))[0]

    def _evaluate_at(self, q: list, p: list, geometry: Geometry) -> Evaluation:
        return Evaluation(q, ScalarOps, geometry, self.structural.scalar_joints, p)

    def _solve(self, pressure: list, first: Evaluation) -> tuple[Solution, Evaluation]:
        """Newton from the evaluation ``first`` at pressures ``pressure``; also the final one.

        The final evaluation is what a stepper keeps to warm-start its next solve
        (:meth:`.Evaluation.at_pressure` re-prices it exactly, F being affine in p).
        """
        geometry = first.geometry

        def evaluate(q, p_):
            return self._evaluate_at(q, p_, geometry)

        outcome = newton(first.q, pressure, evaluate, ScalarOps, self._strain_per_angle, first)
        low, high = VALID_STRETCH
        solution = Solution(
            q=np.array(outcome.q),
            forces=np.array(outcome.forces),
            pressure=np.array(pressure),
            converged=outcome.converged,
            iterations=outcome.iterations,
            residual=outcome.residual,
            in_valid_range=all(
                low <= 1.0 + angle * strain <= high
                for angle, strain in zip(outcome.q, self._strain_per_angle, strict=True)
            ),
        )
        return solution, outcome.final

    def solve_free(self, p: ArrayLike) -> NDArray[np.float64]:
        """Free bending angles (no finger), rad: τ_s,i(q_i) + (r_pA_p)_i p_i = 0 (paper §3.3).

        Warns (RuntimeWarning) if the solve does not converge.
        """
        solution = self.solve(p, free=True)
        if not solution.converged:
            warnings.warn(
                f'free-motion solve did not converge (residual {solution.residual:.3g} N·m)',
                RuntimeWarning,
                stacklevel=2,
            )
        return solution.q

    def solve_batch(
        self, P: ArrayLike, Q0: ArrayLike | None = None, *, free: bool = False
    ) -> BatchSolution:
        """Vectorised :meth:`solve` over rows of pressures.

        Parameters
        ----------
        P : array_like, shape (N, 3)
            Pressures, Pa.
        Q0 : array_like, shape (N, 3), optional
            Start angles per row; zero when omitted.
        free : bool
            Solve free motion instead.
        """
        pressure = as_joint_rows('P', P)
        rows = pressure.shape[0]
        start = np.zeros_like(pressure) if Q0 is None else as_joint_rows('Q0', Q0)
        if start.shape != pressure.shape:
            raise ValueError(f'Q0 must have the shape of P {pressure.shape}, got {start.shape}')
        geometry = self._free_geometry if free else self.geometry

        def evaluate(q, p_):
            return Evaluation(q, ArrayOps, geometry, self.structural.array_joints, p_)

        if rows == 0:
            empty = np.zeros((0, 3))
            return BatchSolution(
                empty,
                empty,
                empty,
                np.zeros(0, bool),
                np.zeros(0, int),
                np.zeros(0),
                np.zeros(0, bool),
            )
        outcome = newton(
            [start[:, k].copy() for k in range(3)],
            [pressure[:, k] for k in range(3)],
            evaluate,
            ArrayOps,
            self._strain_per_angle,
        )
        q = np.column_stack(outcome.q)
        return BatchSolution(
            q=q,
            forces=np.column_stack(outcome.forces),
            pressure=pressure,
            converged=np.asarray(outcome.converged, dtype=bool),
            iterations=np.asarray(outcome.iterations, dtype=int),
            residual=np.asarray(outcome.residual, dtype=float),
            in_valid_range=self.in_valid_range(q),
        )

    # -- inverse and estimation ----------------------------------------------------------

    def pressure_for(self, q: ArrayLike) -> NDArray[np.float64]:
        """Pressures that hold the glove at angles ``q`` on the finger, Pa (eq 36 solved for p).

        p = B_R^{-1} ((J_R*)ᵀ (J_H*)^{-T} K_H q - τ_s(q)); exact, no iteration. The result may be
        negative where holding ``q`` would need suction.
        """
        angles = as_joint_vector('q', q)
        residual_at_zero = self.residual(angles, np.zeros(3))
        return -residual_at_zero / np.asarray(self.geometry.pressure_moments)

    def finger_forces(self, q: ArrayLike) -> NDArray[np.float64]:
        """Finger-side contact forces f = (J_H*)^{-T} K_H q, N (eq 34, MODEL.md §7)."""
        angles = as_joint_vector('q', q)
        _, j_finger = self.contact_jacobians(angles)
        return np.array(
            transpose_solve(j_finger.tolist(), (np.asarray(self.geometry.stiffness) * angles))
        )

    def estimate_forces(self, q: ArrayLike, p: ArrayLike) -> NDArray[np.float64]:
        """Robot-side contact forces f = (J_R*)^{-T} (τ_s(q) + B_R p), N (MODEL.md §7).

        Needs no finger model: from measured angles and pressures only.
        """
        angles = as_joint_vector('q', q)
        torque = self.structural_torque(angles) + self.pressure_torque(as_joint_vector('p', p))
        j_robot, _ = self.contact_jacobians(angles)
        return np.array(transpose_solve(j_robot.tolist(), torque))

    def estimate_forces_batch(self, Q: ArrayLike, P: ArrayLike) -> NDArray[np.float64]:
        """:meth:`estimate_forces` for rows of angles and pressures, shape (N, 3), N."""
        angles, pressure = as_joint_rows('Q', Q), as_joint_rows('P', P)
        torque = self.structural_torque(angles) + self.pressure_torque(pressure)
        j_robot, _ = contact_jacobians(list(angles.T), ArrayOps, self.geometry)
        return np.column_stack(transpose_solve(j_robot, list(torque.T)))

    def fit_stiffness(self, Q: ArrayLike, P: ArrayLike) -> StiffnessFit:
        """Least-squares K_H from samples (eq 34 is linear in K_H), with standard errors."""
        angles, pressure = as_joint_rows('Q', Q), as_joint_rows('P', P)
        forces = self.estimate_forces_batch(angles, pressure)
        _, j_finger = contact_jacobians(list(angles.T), ArrayOps, self.geometry)
        joint_torque = np.column_stack(transpose_product(j_finger, list(forces.T)))
        return fit_stiffness(angles, joint_torque)

    def identify_stiffness(self, Q: ArrayLike, P: ArrayLike) -> NDArray[np.float64]:
        """K_H diagonal identified from samples of angles Q and pressures P, N·m/rad."""
        return self.fit_stiffness(Q, P).stiffness

    # -- geometry -------------------------------------------------------------------------

    def pose(self, q: ArrayLike, arc_samples: int = 12) -> GlovePose:
        """Positions of blocks, arcs, contacts and finger at angles ``q`` (eqs 1-4, 33)."""
        angles = as_joint_vector('q', q).tolist()
        geometry = self.geometry
        half = geometry.block_half_lengths
        frames = chain(chords(angles, ScalarOps), geometry.arc_lengths, half)
        joints, contacts = finger_chain(angles, ScalarOps, geometry.finger_half_lengths)
        return GlovePose(
            block_origins=_xy(frames.origins),
            block_ends=_xy(
                [
                    z + t * 2.0 * d
                    for z, t, d in zip(frames.origins, frames.turns, half, strict=True)
                ]
            ),
            contact_points=_xy(frames.centres),
            contact_normals=_xy([1j * t for t in frames.turns[1:]]),
            arcs=_xy(arc_points(angles, geometry.arc_lengths, half, arc_samples, ScalarOps)),
            finger_joints=_xy(joints),
            finger_contacts=_xy(contacts),
        )

    # -- validity ------------------------------------------------------------------------

    def top_fibre_stretch(self, q: ArrayLike) -> NDArray[np.float64]:
        """λ of each segment's top fibre, 1 + q (b + h + R)/ℓ̂ (eq 26); shape like ``q``."""
        return 1.0 + np.asarray(q, dtype=float) * np.asarray(self._strain_per_angle)

    def in_valid_range(self, q: ArrayLike) -> NDArray[np.bool_]:
        """Whether all fibres stretch within 1 ≤ λ ≤ 1.5 (scalar for (3,), per row for (N, 3))."""
        stretch = self.top_fibre_stretch(q)
        low, high = VALID_STRETCH
        return np.all((stretch >= low) & (stretch <= high), axis=-1)
