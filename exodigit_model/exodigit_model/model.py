"""The glove model: one object that answers every question the nodes and tools ask.

:class:`GloveModel` holds the validated parameters and everything derived from them once (the
pressure moments of eq 12, the τ_s tables). Its methods take and return numpy arrays in SI
units, joints in the order MCP, PIP, DIP:

- the patient: :meth:`GloveModel.finger_torque` (τ_H of MODEL.md eq 11.1);
- forward: :meth:`GloveModel.solve` (eq 36 / 11.4 for q given p, static or stepped in time),
  :meth:`GloveModel.solve_batch`, :meth:`GloveModel.solve_free` (no finger, paper §3.3);
- inverse: :meth:`GloveModel.pressure_for` (p for desired q, exact);
- estimation: :meth:`GloveModel.estimate_forces` (robot side, needs no finger model),
  :meth:`GloveModel.estimate_finger_torque`, :meth:`GloveModel.finger_forces` (finger side),
  :meth:`GloveModel.fit_stiffness` (stiffness and rest angle of an effective linear patient).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize

from ._backend import ArrayOps, ScalarOps
from .coupling import (
    Evaluation,
    Geometry,
    allowed_bending,
    contact_jacobians,
    solve3,
    transpose_product,
    transpose_solve,
)
from .extensible import ExtensibleEvaluation, Layers, allowed_stretch, solve_linear
from .identification import StiffnessFit, fit_stiffness
from .kinematics import arc_points, chain, chords, finger_chain, robot_jacobian
from .params import GloveParams, load_params
from .patient import FingerLoad, JointLaw
from .section import SectionResultants, pressure_area, pressure_moment
from .solver import CONVERGED_STEP, STATUS, newton
from .structural import StructuralTorque

STRAIN_XTOL = 1e-13
"""Relative step tolerance of the bottom-strain roots of the extensible inverse and estimator."""
VALID_STRETCH = (0.95, 1.5)
"""Fibre stretches the model is validated for (paper §2.1.3; MODEL.md §12: a bottom face
slightly compressed by the finger, λ ≥ 0.95, is harmless)."""


@dataclass(frozen=True)
class Solution:
    """Result of one coupled (or free) solve, scipy-style.

    Attributes
    ----------
    q : ndarray, shape (3,)
        Joint angles, rad. The last finite iterate if the solve did not converge (never NaN).
    forces : ndarray, shape (3,)
        Contact forces f = (J_H*)^{-T} τ_H, N (zero for free motion).
    finger_torque : ndarray, shape (3,)
        τ_H of eq 11.1 at ``q``, N·m: the torque the exo-digit applies to each finger joint.
    pressure : ndarray, shape (3,)
        The chamber pressures solved for, Pa.
    status : int
        Why the iteration stopped: a key of :data:`exodigit_model.solver.STATUS`.
    message : str
        The status in words.
    iterations : int
        Newton steps taken.
    residual : float
        2-norm of F(q, p) at ``q``, N·m.
    in_valid_range : bool
        Whether every fibre's stretch lies in 1 ≤ λ ≤ 1.5 (the model's validated range).
    in_range_of_motion : bool
        Whether every joint lies within the finger's range of motion [rom_min, rom_max].
    lengths : ndarray, shape (3,)
        ℓ_i, the bottom-face arc lengths of the segments, m (the rest lengths unless a segment
        is extensible, MODEL.md §12).
    """

    q: NDArray[np.float64]
    forces: NDArray[np.float64]
    finger_torque: NDArray[np.float64]
    pressure: NDArray[np.float64]
    status: int
    message: str
    iterations: int
    residual: float
    in_valid_range: bool
    in_range_of_motion: bool
    lengths: NDArray[np.float64]

    @property
    def converged(self) -> bool:
        """Whether the solve converged (status ≤ CONVERGED_STEP)."""
        return self.status <= CONVERGED_STEP

    def warnings(self) -> list[str]:
        """Why this state is not to be trusted as a model result (empty when it is)."""
        return state_warnings(self.converged, self.in_valid_range, self.in_range_of_motion)


def state_warnings(converged: bool, in_valid_range: bool, in_range_of_motion: bool) -> list[str]:
    """One sentence per way a state leaves the model (the tools and nodes say them)."""
    low, high = VALID_STRETCH
    messages = []
    if not converged:
        messages.append('the solve did not converge')
    if not in_valid_range:
        messages.append(
            f'a fibre stretch is outside the validated range {low:g} <= lambda <= {high:g}'
        )
    if not in_range_of_motion:
        messages.append("a joint is outside the finger's range of motion")
    return messages


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
    finger_torque: NDArray[np.float64]
    pressure: NDArray[np.float64]
    status: NDArray[np.int_]
    iterations: NDArray[np.int_]
    residual: NDArray[np.float64]
    in_valid_range: NDArray[np.bool_]
    in_range_of_motion: NDArray[np.bool_]
    lengths: NDArray[np.float64]

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Per row: whether the solve converged."""
        return self.status <= CONVERGED_STEP

    @property
    def message(self) -> list[str]:
        """Per row: the status in words."""
        return [STATUS[int(code)] for code in self.status]


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


def _joint_columns(name: str, value: ArrayLike) -> list[NDArray[np.float64]]:
    """Rows of shape (N, 3) as three columns (the batch backend's per-joint arrays)."""
    rows = as_joint_rows(name, value)
    return [rows[:, k] for k in range(3)]


def as_joint_rows(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a finite float array of shape (N, 3), or a ValueError naming ``name``."""
    return _joint_array(name, value, rows_only=True)


def as_joint_array(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a finite float array of shape (3,) or (N, 3), or a ValueError naming it."""
    return _joint_array(name, value, rows_only=False)


def _joint_array(name: str, value: ArrayLike, rows_only: bool) -> NDArray[np.float64]:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = None
    rows = array is not None and array.ndim == 2 and array.shape[1] == 3
    if not (rows or (not rows_only and array is not None and array.shape == (3,))):
        shapes = '(N, 3)' if rows_only else '(3,) or (N, 3)'
        got = 'no array of numbers' if array is None else f'shape {array.shape}'
        raise ValueError(f'{name} must have shape {shapes} (MCP, PIP, DIP), got {got}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} must be finite')
    return array


def _require_shape(name: str, array: NDArray, reference: str, shape: tuple) -> None:
    """A ValueError naming ``name`` unless ``array`` has ``shape``, that of ``reference``."""
    if array.shape != shape:
        raise ValueError(f'{name} must have the shape of {reference} {shape}, got {array.shape}')


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
            pressure_moments=tuple(pressure_moment(s) for s in segments),
        )
        self.laws = tuple(JointLaw.of(joint) for joint in joints)
        """The patient's joint torque laws (eqs 11.1-11.3), MCP, PIP, DIP."""
        self.viscous = any(law.viscous for law in self.laws)
        """Whether τ_H depends on the joint speed (damping or spasticity)."""
        self.range_of_motion = (
            np.array([j.rom_min for j in joints]),
            np.array([j.rom_max for j in joints]),
        )
        """(rom_min, rom_max) per joint, rad."""
        self.structural = StructuralTorque(self.params.material, segments)
        self._strain_per_angle = tuple(s.height / s.arc_length for s in segments)
        self.extensible = any(s.extensible for s in segments)
        """Whether a segment's bottom face stretches (MODEL.md §12): six unknowns, not three."""
        self.layers = Layers(
            rest_lengths=self.geometry.arc_lengths,
            stiffness=tuple(s.layer_axial_stiffness for s in segments),
            areas=tuple(pressure_area(s) for s in segments),
            extensible=tuple(s.extensible for s in segments),
        )
        if self.extensible:
            self.resultants = SectionResultants(
                self.params.material, segments, self.structural.rules
            )
            self._newton_options = {
                'linear_solve': solve_linear,
                'allowed': lambda x: allowed_stretch(x, self._strain_per_angle),
            }
        else:
            self._newton_options = {
                'linear_solve': solve3,
                'allowed': lambda q: allowed_bending(q, self._strain_per_angle),
            }

    # -- torques and Jacobians ------------------------------------------------------------

    def structural_torque(self, q: ArrayLike) -> NDArray[np.float64]:
        """τ_s(q), N·m, shape (3,) or (N, 3) like ``q``: negative for q > 0 (eqs 13, 27)."""
        return self.structural.torque(as_joint_array('q', q))[0]

    def structural_stiffness(self, q: ArrayLike) -> NDArray[np.float64]:
        """dτ_s/dq, N·m/rad, shape like ``q`` (negative: the segments resist bending)."""
        return self.structural.torque(as_joint_array('q', q))[1]

    def pressure_torque(self, p: ArrayLike) -> NDArray[np.float64]:
        """τ_p = B_R p, N·m (eqs 11-12), shape (3,) or (N, 3) like ``p``."""
        return np.asarray(self.geometry.pressure_moments) * as_joint_array('p', p)

    def finger_torque(
        self, q: ArrayLike, qdot: ArrayLike | None = None, effort: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """τ_H of eq 11.1, N·m, shape (3,): what the finger needs to hold ``q`` at ``qdot``.

        Parameters
        ----------
        q : array_like, shape (3,)
            Joint angles, rad.
        qdot : array_like, shape (3,), optional
            Joint speeds, rad/s (None: at rest).
        effort : array_like, shape (3,), optional
            The patient's voluntary effort u, N·m (None: none).
        """
        angles = as_joint_list('q', q)
        load = self._load(ScalarOps, qdot=qdot, effort=effort)
        return np.array(load(angles)[0])

    def contact_jacobians(self, q: ArrayLike) -> tuple[NDArray, NDArray]:
        """(J_R*, J_H*), each (3, 3) lower triangular, J[i, k] = n_i·∂r_i/∂q_k (MODEL.md §3)."""
        angles = as_joint_vector('q', q).tolist()
        j_robot, j_finger = contact_jacobians(angles, ScalarOps, self.geometry)
        return np.array(j_robot), np.array(j_finger)

    def residual(self, q: ArrayLike, p: ArrayLike, **solve_options) -> NDArray[np.float64]:
        """F(q, p) of eq 36 / 11.4, N·m.

        Keyword options ``free``, ``effort``, ``q_previous`` and ``dt`` as :meth:`solve`. With
        extensible segments the residual has six rows, (12.4) and ℓ̂ × (12.5), at bottom-face
        ``lengths`` (m; the rest lengths when omitted).
        """
        return np.array(self._evaluation(q, p, **solve_options).residual)

    def residual_jacobian(
        self, q: ArrayLike, p: ArrayLike, **solve_options
    ) -> NDArray[np.float64]:
        """∂F/∂q of eq 36 / 11.4 (analytic), N·m/rad, shape (3, 3); options as :meth:`residual`."""
        return np.array(self._evaluation(q, p, **solve_options).jacobian(), dtype=float)

    def _evaluation(
        self, q, p, *, free=False, effort=None, q_previous=None, dt=None, lengths=None
    ) -> Evaluation:
        load = self._load(ScalarOps, free=free, effort=effort, q_previous=q_previous, dt=dt)
        return self._evaluate(q, p, load, lengths)

    def length_jacobian(self, q: ArrayLike, lengths: ArrayLike | None = None) -> NDArray:
        """J_ℓ*[i, k] = n_i·∂r^C_i/∂ℓ_k (MODEL.md §12), (3, 3) lower triangular.

        At angles ``q`` and bottom-face ``lengths`` (m; the rest lengths when omitted).
        """
        angles = as_joint_list('q', q)
        arcs = self.geometry.arc_lengths if lengths is None else as_joint_list('lengths', lengths)
        robot = robot_jacobian(chords(angles, ScalarOps), arcs, self.geometry.block_half_lengths)
        return np.array(robot.length_terms(arcs)[0])

    def _load(
        self, ops, *, free=False, effort=None, q_previous=None, dt=None, qdot=None
    ) -> FingerLoad | None:
        """The finger of one solve (None for free motion), its arguments checked."""
        if free:
            return None
        if (q_previous is None) != (dt is None):
            raise ValueError('q_previous and dt go together: give both for a stepped solve')
        if dt is not None and not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
            raise ValueError(f'dt = {dt!r}: must be a finite time step > 0 s')
        joint = as_joint_list if ops is ScalarOps else _joint_columns
        return FingerLoad(
            self.laws,
            ops,
            q_previous=None if q_previous is None else joint('q_previous', q_previous),
            dt=dt,
            effort=None if effort is None else joint('effort', effort),
            qdot=None if qdot is None else joint('qdot', qdot),
        )

    def _evaluate(self, q, p, load, lengths=None) -> Evaluation:
        x = self.unknowns(as_joint_list('q', q), lengths)
        return self._evaluate_at(x, as_joint_list('p', p), load)

    def unknowns(self, q: list, lengths=None) -> list:
        """The solver's unknowns for angles ``q`` (and bottom-face ``lengths``, m).

        With extensible segments also the strains ε = ℓ/ℓ̂ − 1 (the rest lengths when None).
        """
        if not self.extensible:
            return q
        if lengths is None:
            return [*q, 0.0, 0.0, 0.0]
        rest = self.geometry.arc_lengths
        return [*q, *(length / rest[k] - 1.0 for k, length in enumerate(lengths))]

    def _evaluate_at(self, x: list, p: list, load):
        if self.extensible:
            return ExtensibleEvaluation(
                x, ScalarOps, self.geometry, self.resultants, self.layers, p, load
            )
        return Evaluation(x, ScalarOps, self.geometry, self.structural.scalar_joints, p, load)

    def _evaluate_batch(self, x: list, p: list, load):
        if self.extensible:
            return ExtensibleEvaluation(
                x, ArrayOps, self.geometry, self.resultants, self.layers, p, load
            )
        return Evaluation(x, ArrayOps, self.geometry, self.structural.array_joints, p, load)

    # -- forward solves ------------------------------------------------------------------

    def solve(
        self,
        p: ArrayLike,
        q0: ArrayLike | Solution | None = None,
        *,
        free: bool = False,
        effort: ArrayLike | None = None,
        q_previous: ArrayLike | None = None,
        dt: float | None = None,
    ) -> Solution:
        """Joint angles and contact forces for chamber pressures ``p`` (eq 36, MODEL.md 11.4).

        Parameters
        ----------
        p : array_like, shape (3,)
            Gauge pressures, Pa.
        q0 : array_like, shape (3,), or Solution, optional
            Start of the Newton iteration (warm start; a Solution starts from its angles); the
            previous angles of a stepped solve, else zero, when omitted.
        free : bool
            Solve free motion (no finger, τ_s + B_R p = 0) instead.
        effort : array_like, shape (3,), optional
            The patient's voluntary effort u of eq 11.1, N·m.
        q_previous : array_like, shape (3,), optional
            Angles at the previous time step, rad. With ``dt`` the solve is stepped in time:
            q̇ = (q − q_previous)/dt inside the equation (damping and spasticity act).
        dt : float, optional
            Time step, s.

        Returns
        -------
        Solution
            Never raises for a solve that fails to converge: ``status`` and ``message`` say why
            and ``q`` is the last finite iterate.
        """
        pressure = as_joint_list('p', p)
        load = self._load(ScalarOps, free=free, effort=effort, q_previous=q_previous, dt=dt)
        lengths = None
        if isinstance(q0, Solution):
            q0, lengths = q0.q, q0.lengths
        if q0 is not None:
            start = as_joint_list('q0', q0)
        elif load is not None and load.stepped:
            start = list(load.q_previous)
        else:
            start = [0.0, 0.0, 0.0]
        first = self._evaluate_at(self.unknowns(start, lengths), pressure, load)
        return self._solve(pressure, first)[0]

    def _solve(self, pressure: list, first) -> tuple[Solution, object]:
        """Newton from the evaluation ``first`` at pressures ``pressure``; also the final one.

        The final evaluation is what a stepper keeps to warm-start its next solve
        (:meth:`.Evaluation.at_pressure` re-prices it exactly, F being affine in p).
        """
        load = first.load

        def evaluate(x, p_):
            return self._evaluate_at(x, p_, load)

        outcome = newton(pressure, evaluate, ScalarOps, first, **self._newton_options)
        q, lengths = self._angles_and_lengths(outcome.q)
        rom_min, rom_max = self.range_of_motion
        solution = Solution(
            q=np.array(q),
            forces=np.array(outcome.forces),
            finger_torque=np.array(outcome.finger_torque),
            pressure=np.array(pressure),
            status=outcome.status,
            message=STATUS[outcome.status],
            iterations=outcome.iterations,
            residual=outcome.residual,
            in_valid_range=self._stretches_valid(outcome.q),
            in_range_of_motion=all(rom_min[k] <= q[k] <= rom_max[k] for k in range(3)),
            lengths=np.array(lengths),
        )
        return solution, outcome.final

    def _angles_and_lengths(self, x: list) -> tuple[list, list]:
        """Joint angles and bottom-face lengths ℓ_k (m) of the solver's unknowns."""
        rest = self.geometry.arc_lengths
        if not self.extensible:
            return x, list(rest)
        return x[:3], [rest[k] * (1.0 + x[3 + k]) for k in range(3)]

    def _stretches_valid(self, x: list) -> bool:
        """(12.1) over the whole section of every segment, one state (plain Python, fast)."""
        low, high = VALID_STRETCH
        for k in range(3):
            bottom = 1.0 + x[3 + k] if self.extensible else 1.0
            top = bottom + x[k] * self._strain_per_angle[k]
            if not (low <= bottom <= high and low <= top <= high):
                return False
        return True

    def solve_free(self, p: ArrayLike) -> NDArray[np.float64]:
        """Free bending angles (no finger), rad: τ_s,i(q_i) + (r_pA_p)_i p_i = 0 (paper §3.3).

        Warns (RuntimeWarning) if the solve does not converge.
        """
        solution = self.solve(p, free=True)
        if not solution.converged:
            warnings.warn(
                f'free-motion solve did not converge (residual {solution.residual:.3g} N·m): '
                f'{solution.message}',
                RuntimeWarning,
                stacklevel=2,
            )
        return solution.q

    def solve_batch(
        self,
        P: ArrayLike,
        Q0: ArrayLike | None = None,
        *,
        free: bool = False,
        effort: ArrayLike | None = None,
        Q_previous: ArrayLike | None = None,
        dt: float | None = None,
        lengths0: ArrayLike | None = None,
    ) -> BatchSolution:
        """Vectorised :meth:`solve` over rows.

        Parameters
        ----------
        P : array_like, shape (N, 3)
            Pressures, Pa.
        Q0 : array_like, shape (N, 3), optional
            Start angles per row; ``Q_previous`` (stepped), else zero, when omitted.
        free : bool
            Solve free motion instead.
        effort : array_like, shape (N, 3), optional
            Voluntary effort per row, N·m.
        Q_previous : array_like, shape (N, 3), optional
            Angles at the previous step per row, rad; with ``dt`` a stepped solve.
        dt : float, optional
            Time step, s.
        lengths0 : array_like, shape (N, 3), optional
            Start bottom-face lengths per row, m (extensible segments; the rest lengths when
            omitted).
        """
        pressure = as_joint_rows('P', P)
        rows = pressure.shape[0]
        for name, value in (
            ('Q0', Q0),
            ('effort', effort),
            ('Q_previous', Q_previous),
            ('lengths0', lengths0),
        ):
            if value is not None:
                _require_shape(name, as_joint_rows(name, value), 'P', pressure.shape)
        load = self._load(ArrayOps, free=free, effort=effort, q_previous=Q_previous, dt=dt)
        if Q0 is not None:
            start = as_joint_rows('Q0', Q0)
        elif Q_previous is not None and dt is not None:
            start = as_joint_rows('Q_previous', Q_previous)
        else:
            start = np.zeros_like(pressure)
        if rows == 0:
            empty = np.zeros((0, 3))
            return BatchSolution(
                empty,
                empty,
                empty,
                empty,
                np.zeros(0, int),
                np.zeros(0, int),
                np.zeros(0),
                np.zeros(0, bool),
                np.zeros(0, bool),
                empty,
            )

        def evaluate(x, p_):
            return self._evaluate_batch(x, p_, load)

        columns = [pressure[:, k] for k in range(3)]
        x = [start[:, k].copy() for k in range(3)]
        if self.extensible:
            rest = self.geometry.arc_lengths
            lengths = (
                rest * np.ones((rows, 3))
                if lengths0 is None
                else as_joint_rows('lengths0', lengths0)
            )
            x += [lengths[:, k] / rest[k] - 1.0 for k in range(3)]
        first = evaluate(x, columns)
        outcome = newton(columns, evaluate, ArrayOps, first, **self._newton_options)
        q = np.column_stack(outcome.q[:3])
        strain = np.column_stack(outcome.q[3:]) if self.extensible else np.zeros_like(q)
        return BatchSolution(
            q=q,
            forces=np.column_stack(outcome.forces),
            finger_torque=np.column_stack(outcome.finger_torque),
            pressure=pressure,
            status=np.asarray(outcome.status, dtype=int),
            iterations=np.asarray(outcome.iterations, dtype=int),
            residual=np.asarray(outcome.residual, dtype=float),
            in_valid_range=self.in_valid_range(q, strain),
            in_range_of_motion=self.in_range_of_motion(q),
            lengths=np.asarray(self.geometry.arc_lengths) * (1.0 + strain),
        )

    # -- inverse and estimation ----------------------------------------------------------

    def pressure_for(
        self, q: ArrayLike, qdot: ArrayLike | None = None, effort: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Pressures that hold the glove at angles ``q`` on the finger, Pa (eq 11.4 for p).

        p = B_R^{-1} ((J_R*)ᵀ (J_H*)^{-T} τ_H(q, q̇, u) − τ_s(q)); exact, no iteration (with
        extensible segments the bottom strains are solved for too: :meth:`hold`). The result
        may be negative where holding ``q`` would need suction.
        """
        return self.hold(q, qdot, effort)[0]

    def hold(
        self, q: ArrayLike, qdot: ArrayLike | None = None, effort: ArrayLike | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The inverse: pressures (Pa) and bottom-face lengths ℓ (m) that hold angles ``q``.

        Constant-length segments: exact. Extensible ones (MODEL.md §12): (12.4) gives p for
        given strains exactly, and (12.5) with that p is solved for the strains (Newton with the
        analytic Jacobian of the 6×6 system, by ``scipy.optimize.root``).
        """
        angles = as_joint_list('q', q)
        load = self._load(ScalarOps, qdot=qdot, effort=effort)
        moments = np.asarray(self.geometry.pressure_moments)
        if not self.extensible:
            residual_at_zero = self._evaluate_at(angles, [0.0, 0.0, 0.0], load).residual
            return -np.array(residual_at_zero) / moments, np.asarray(self.geometry.arc_lengths)
        layers = self.layers
        weight = np.array(
            [
                layers.rest_lengths[k] * layers.areas[k] / moments[k]
                if layers.extensible[k]
                else 0.0
                for k in range(3)
            ]
        )

        def stretch_balance(strain):
            evaluation = self._evaluate_at([*angles, *strain], [0.0, 0.0, 0.0], load)
            residual, jacobian = np.array(evaluation.residual), np.array(evaluation.jacobian())
            value = residual[3:] - weight * residual[:3]
            slope = jacobian[3:, 3:] - weight[:, None] * jacobian[:3, 3:]
            return value, slope

        strain = self._root(stretch_balance, 'hold', jacobian=True)
        evaluation = self._evaluate_at([*angles, *strain], [0.0, 0.0, 0.0], load)
        pressure = -np.array(evaluation.residual[:3]) / moments
        return pressure, np.asarray(layers.rest_lengths) * (1.0 + strain)

    @staticmethod
    def _root(function, what: str, *, jacobian: bool) -> NDArray[np.float64]:
        """The bottom strains where ``function`` vanishes (``jacobian``: it gives its own)."""
        result = optimize.root(
            function, np.zeros(3), jac=jacobian, method='hybr', options={'xtol': STRAIN_XTOL}
        )
        if not result.success:
            raise ValueError(
                f'{what}: no bottom-face strain balances the segments ({result.message})'
            )
        return result.x

    def finger_forces(
        self, q: ArrayLike, qdot: ArrayLike | None = None, effort: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Finger-side contact forces f = (J_H*)^{-T} τ_H(q, q̇, u), N (eqs 34, 11.1)."""
        angles = as_joint_vector('q', q)
        _, j_finger = self.contact_jacobians(angles)
        return np.array(transpose_solve(j_finger.tolist(), self.finger_torque(q, qdot, effort)))

    def estimate_forces(self, q: ArrayLike, p: ArrayLike) -> NDArray[np.float64]:
        """Robot-side contact forces f = (J_R*)^{-T} (τ_s(q) + B_R p), N (MODEL.md §7).

        Needs no finger model: from measured angles and pressures only (with extensible
        segments the bottom strains are solved for too: :meth:`estimate`).
        """
        return self.estimate(q, p)[0]

    def estimate(
        self, q: ArrayLike, p: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The robot-side estimator: contact forces f (N) and bottom-face lengths ℓ (m).

        From measured angles and pressures, no finger model: (12.4) gives f for given strains,
        (12.5) with that f is solved for the strains (MODEL.md §12; ``scipy.optimize.root``).
        """
        angles = as_joint_vector('q', q)
        pressure = as_joint_vector('p', p)
        if not self.extensible:
            torque = self.structural_torque(angles) + self.pressure_torque(pressure)
            j_robot, _ = self.contact_jacobians(angles)
            forces = np.array(transpose_solve(j_robot.tolist(), torque))
            return forces, np.asarray(self.geometry.arc_lengths)
        free = self._load(ScalarOps, free=True)
        angle_list, pressure_list = angles.tolist(), pressure.tolist()

        def forces_at(strain):
            # the glove alone (no finger): its residual is what the contacts must hold
            evaluation = self._evaluate_at([*angle_list, *strain], pressure_list, free)
            robot = evaluation._robot.matrix
            forces = transpose_solve(robot, evaluation.residual[:3])
            return evaluation, forces

        def stretch_balance(strain):
            evaluation, forces = forces_at(strain)
            lengthwise = transpose_product(evaluation._lengthwise[0], forces)
            rest = self.layers.rest_lengths
            return np.array(
                [
                    evaluation.residual[3 + k] - rest[k] * lengthwise[k]
                    if self.layers.extensible[k]
                    else strain[k]
                    for k in range(3)
                ]
            )

        strain = self._root(stretch_balance, 'estimate', jacobian=False)
        _, forces = forces_at(strain.tolist())
        return np.array(forces), np.asarray(self.layers.rest_lengths) * (1.0 + strain)

    def estimate_forces_batch(self, Q: ArrayLike, P: ArrayLike) -> NDArray[np.float64]:
        """:meth:`estimate_forces` for rows of angles and pressures, shape (N, 3), N."""
        angles, pressure = as_joint_rows('Q', Q), as_joint_rows('P', P)
        _require_shape('P', pressure, 'Q', angles.shape)
        if self.extensible:
            return np.array(
                [self.estimate(q, p)[0] for q, p in zip(angles, pressure, strict=True)]
            )
        torque = self.structural_torque(angles) + self.pressure_torque(pressure)
        j_robot, _ = contact_jacobians(list(angles.T), ArrayOps, self.geometry)
        return np.column_stack(transpose_solve(j_robot, list(torque.T)))

    def contact_torque(self, q: ArrayLike, forces: ArrayLike) -> NDArray[np.float64]:
        """(J_H*)ᵀ f: the joint torque contact forces f (N) apply to the finger, N·m (eq 34).

        ``q`` and ``forces`` of shape (3,), or (N, 3) rows.
        """
        angles, rows = as_joint_array('q', q), as_joint_array('forces', forces)
        _require_shape('forces', rows, 'q', angles.shape)
        if angles.ndim == 1:
            _, j_finger = self.contact_jacobians(angles)
            return j_finger.T @ rows
        _, j_finger = contact_jacobians(list(angles.T), ArrayOps, self.geometry)
        return np.column_stack(transpose_product(j_finger, list(rows.T)))

    def estimate_finger_torque(self, Q: ArrayLike, P: ArrayLike) -> NDArray[np.float64]:
        """τ̂_H = (J_H*)ᵀ f̂ from the robot-side estimate, N·m (MODEL.md §11, "Estimation").

        The torque the finger actually resists with, from measured angles and pressures of
        shape (3,) or (N, 3).
        """
        angles = as_joint_array('Q', Q)
        if angles.ndim == 1:
            return self.contact_torque(angles, self.estimate_forces(angles, P))
        return self.contact_torque(angles, self.estimate_forces_batch(angles, P))

    def fit_stiffness(self, Q: ArrayLike, P: ArrayLike) -> StiffnessFit:
        """The effective linear patient τ̂_H,k = k_k (q_k − q_r,k) fitted to samples.

        Linear least squares with an intercept per joint on the robot-side estimate
        (:meth:`estimate_finger_torque`), whatever the true patient is; the fit's RMSE says
        how well a linear spring explains the data (MODEL.md §11, "Estimation").
        """
        angles, pressure = as_joint_rows('Q', Q), as_joint_rows('P', P)
        return fit_stiffness(angles, self.estimate_finger_torque(angles, pressure))

    def identify_stiffness(self, Q: ArrayLike, P: ArrayLike) -> NDArray[np.float64]:
        """K_H diagonal identified from samples of angles Q and pressures P, N·m/rad."""
        return self.fit_stiffness(Q, P).stiffness

    # -- geometry -------------------------------------------------------------------------

    def pose(
        self, q: ArrayLike, lengths: ArrayLike | None = None, arc_samples: int = 12
    ) -> GlovePose:
        """Positions of blocks, arcs, contacts and finger at angles ``q`` (eqs 1-4, 33).

        ``lengths`` are the arcs' bottom-face lengths ℓ (m, MODEL.md §12; a ``Solution``'s
        ``lengths``); the rest lengths when omitted.
        """
        angles = as_joint_vector('q', q).tolist()
        geometry = self.geometry
        half = geometry.block_half_lengths
        arcs = geometry.arc_lengths if lengths is None else as_joint_list('lengths', lengths)
        frames = chain(chords(angles, ScalarOps), arcs, half)
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
            arcs=_xy(arc_points(angles, arcs, half, arc_samples, ScalarOps)),
            finger_joints=_xy(joints),
            finger_contacts=_xy(contacts),
        )

    # -- validity ------------------------------------------------------------------------

    def top_fibre_stretch(self, q: ArrayLike, strain: ArrayLike = 0.0) -> NDArray[np.float64]:
        """λ of each segment's top fibre, λ_b + q (b + h + R)/ℓ̂ (eqs 26, 12.1); shape like q.

        ``q`` of shape (3,) or (N, 3); ``strain`` is the bottom face's ε = λ_b − 1 (0:
        inextensible), one number or shaped like ``q``.
        """
        angles = as_joint_array('q', q)
        bottom = 1.0 + np.asarray(strain, dtype=float)
        if bottom.ndim:
            _require_shape('strain', bottom, 'q', angles.shape)
        return bottom + angles * np.asarray(self._strain_per_angle)

    def in_valid_range(self, q: ArrayLike, strain: ArrayLike = 0.0) -> NDArray[np.bool_]:
        """Whether every fibre's stretch (12.1) lies in VALID_STRETCH (per row for (N, 3)).

        The extreme fibres are the bottom face and the top.
        """
        low, high = VALID_STRETCH
        top = self.top_fibre_stretch(q, strain)
        bottom = np.broadcast_to(1.0 + np.asarray(strain, dtype=float), top.shape)
        inside = (bottom >= low) & (bottom <= high) & (top >= low) & (top <= high)
        return np.all(inside, axis=-1)

    def in_range_of_motion(self, q: ArrayLike) -> NDArray[np.bool_]:
        """Whether every joint lies in [rom_min, rom_max] (scalar for (3,), per row for (N, 3))."""
        angles = as_joint_array('q', q)
        low, high = self.range_of_motion
        return np.all((angles >= low) & (angles <= high), axis=-1)
