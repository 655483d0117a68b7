"""The glove model: one object that answers every question the nodes and tools ask.

:class:`GloveModel` holds the validated parameters and everything derived from them once (the
pressure moments of eq 12, the τ_s tables). Its methods take and return numpy arrays in SI
units, joints in the order MCP, PIP, DIP:

- the patient: :meth:`GloveModel.finger_torque` (τ_H of docs/spec/model.md eq 11.1);
- forward: :meth:`GloveModel.solve` (eq 36 / 11.4 for q given p, static or stepped in time),
  :meth:`GloveModel.solve_batch`, :meth:`GloveModel.solve_free` (no finger, paper §3.3);
- inverse: :meth:`GloveModel.hold` (p and the bottom-face lengths for desired q, with whether
  they lie inside the validated model: :class:`.inverse.Hold`), :meth:`GloveModel.pressure_for`;
- estimation: :meth:`GloveModel.estimate` (robot side, needs no finger model; an
  :class:`.inverse.Estimate`), :meth:`GloveModel.estimate_batch`,
  :meth:`GloveModel.estimate_forces`,
  :meth:`GloveModel.estimate_finger_torque`, :meth:`GloveModel.finger_forces` (finger side),
  :meth:`GloveModel.fit_stiffness` (stiffness and rest angle of an effective linear patient).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..kernels.constants import DEGREE, PIECES, GloveConstants, pack
from ..kernels.inverse import (
    contact_torques,
    estimate_one,
    estimate_rows,
    hold,
    robot_contact_torques,
)
from ..kernels.kinematics import chord_terms, finger_points, frames
from ..kernels.linear import transpose_solve
from ..kernels.solves import (
    evaluate_state,
    finger_torques,
    jacobians_at,
    solve_rows,
    solve_state,
    validity_rows,
)
from ..kernels.structural import structural_torques
from .identification import StiffnessFit, fit_stiffness
from .inverse import BatchEstimate, Estimate, Hold
from .params import JOINT_NAMES, GloveParams, load_params
from .patient import finger_rows
from .section import SectionQuadrature, pressure_area, pressure_moment
from .solver import CONVERGED_STEP, STATUS
from .structural import torque_tables
from .validity import (
    SUPPLY_PRESSURE,
    VALID_STRETCH,
    state_warnings,
    validity_message,
    validity_status,
    warn_outside,
    within_supply,
)

_STATIC_LIMITS = (0.0, *VALID_STRETCH)
"""The limits argument of :func:`~.kernels.solves.solve_state` for a static solve (rate 0)."""


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
        Why the iteration stopped: a key of :data:`exodigit_model.physics.solver.STATUS`.
    message : str
        The status in words.
    iterations : int
        Newton steps taken.
    residual : float
        2-norm of F(q, p) at ``q``, N·m.
    in_valid_range : bool
        Whether every fibre's stretch lies in 0.95 ≤ λ ≤ 1.5, :data:`VALID_STRETCH` (the model's
        validated range: the paper's, §2.1.3, starts at λ = 1; docs/spec/model.md §12 extends it
        down to 0.95 because a bottom face slightly compressed by the finger is harmless).
    in_range_of_motion : bool
        Whether every joint lies within the finger's range of motion [rom_min, rom_max].
    lengths : ndarray, shape (3,)
        ℓ_i, the bottom-face arc lengths of the segments, m (the rest lengths unless a segment
        is extensible, docs/spec/model.md §12).
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
    """``value`` as a finite float array of shape (3,) (a copy), or a ValueError naming it."""
    if type(value) is np.ndarray and value.shape == (3,) and value.dtype == np.float64:
        # the hot path of every step: an array of three floats already
        q0, q1, q2 = value.tolist()
        if not (math.isfinite(q0) and math.isfinite(q1) and math.isfinite(q2)):
            raise ValueError(f'{name} must be finite, got {[q0, q1, q2]}')
        return value.copy()
    return np.array(as_joint_list(name, value))


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


_AT_REST = np.zeros((3, 3))
"""The ``motion`` of a static solve with no effort (read-only: the kernels only read it)."""
_AT_REST.flags.writeable = False


def _chords(q: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """e^{iq/2} and the unit chords C(q) of the arcs (:func:`.kernels.kinematics.chord_terms`)."""
    terms = [np.empty(3, complex) for _ in range(4)]
    chord_terms(q, *terms)
    return terms[0], terms[1]


def glove_constants(params: GloveParams) -> GloveConstants:
    """The kernels' constants of validated ``params`` (the τ_s tables built once, here)."""
    segments = params.exo_digit.segments
    rules = [SectionQuadrature.of(segment) for segment in segments]
    material = params.material
    finger_half_lengths, laws = finger_rows([params.finger])
    constants = GloveConstants(
        arc_lengths=np.array([s.arc_length for s in segments]),
        block_half_lengths=np.array(
            [params.exo_digit.base_block_half_length, *(s.block_half_length for s in segments)]
        ),
        finger_half_lengths=finger_half_lengths[0],
        pressure_moments=np.array([pressure_moment(s) for s in segments]),
        pressure_areas=np.array([pressure_area(s) for s in segments]),
        layer_stiffness=np.array([s.layer_axial_stiffness for s in segments]),
        extensible_segments=np.array([float(s.extensible) for s in segments]),
        extensible=any(s.extensible for s in segments),
        strain_per_angle=np.array([s.height / s.arc_length for s in segments]),
        table=np.zeros((3, DEGREE + 1, PIECES)),
        heights=np.stack([rule.heights for rule in rules]),
        weights=np.stack([rule.weights for rule in rules]),
        material=np.array([material.c1, material.c2, material.c3]),
        laws=laws[0],
    )
    return constants._replace(table=torque_tables(constants))


class GloveModel:
    """Quasi-static model of the soft exo-digit strapped to a finger (docs/model.md).

    Parameters
    ----------
    params : GloveParams, optional
        Validated parameters; the defaults of docs/spec/model.md §10 when omitted.

    Examples
    --------
    >>> model = GloveModel(load_params())
    >>> sol = model.solve([50e3, 50e3, 50e3])
    >>> bool(sol.converged), bool(np.all(sol.q > 0))
    (True, True)
    """

    def __init__(self, params: GloveParams | None = None) -> None:
        self.params = load_params() if params is None else params
        self.constants = glove_constants(self.params)
        """Everything the kernels need of this glove and finger (:mod:`.kernels.constants`)."""
        self.packed = pack(self.constants)
        """The same constants as one array: what the kernels are called with from Python."""
        self.extensible = self.constants.extensible
        """Whether a segment's bottom face stretches (docs/spec/model.md §12): six unknowns."""
        joints = self.params.finger.joints
        self.range_of_motion = (
            np.array([j.rom_min for j in joints]),
            np.array([j.rom_max for j in joints]),
        )
        """(rom_min, rom_max) per joint, rad."""

    # -- torques and Jacobians ------------------------------------------------------------

    def structural_torque(self, q: ArrayLike) -> NDArray[np.float64]:
        """τ_s(q), N·m, shape (3,) or (N, 3) like ``q``: negative for q > 0 (eqs 13, 27)."""
        return self._structural(q)[0]

    def structural_stiffness(self, q: ArrayLike) -> NDArray[np.float64]:
        """dτ_s/dq, N·m/rad, shape like ``q`` (negative: the segments resist bending)."""
        return self._structural(q)[1]

    def _structural(self, q: ArrayLike) -> tuple[NDArray, NDArray]:
        angles = as_joint_array('q', q)
        torque, slope = structural_torques(self.packed, np.atleast_2d(angles))
        return torque.reshape(angles.shape), slope.reshape(angles.shape)

    def pressure_torque(self, p: ArrayLike) -> NDArray[np.float64]:
        """τ_p = B_R p, N·m (eqs 11-12), shape (3,) or (N, 3) like ``p``."""
        return self.constants.pressure_moments * as_joint_array('p', p)

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
        angles = as_joint_vector('q', q)
        motion, _ = self._motion(effort=effort, qdot=qdot)
        return finger_torques(self.packed, angles, motion)

    def contact_jacobians(self, q: ArrayLike) -> tuple[NDArray, NDArray]:
        """(J_R*, J_H*), each (3, 3) lower triangular, J[i, k] = n_i·∂r_i/∂q_k (§3)."""
        angles = as_joint_vector('q', q)
        j_robot, j_finger, _ = jacobians_at(self.packed, angles, self.constants.arc_lengths)
        return j_robot, j_finger

    def length_jacobian(self, q: ArrayLike, lengths: ArrayLike | None = None) -> NDArray:
        """J_ℓ*[i, k] = n_i·∂r^C_i/∂ℓ_k (docs/spec/model.md §12), (3, 3) lower triangular.

        At angles ``q`` and bottom-face ``lengths`` (m; the rest lengths when omitted).
        """
        angles = as_joint_vector('q', q)
        arcs = self._lengths(lengths)
        return jacobians_at(self.packed, angles, arcs)[2]

    def residual(self, q: ArrayLike, p: ArrayLike, **solve_options) -> NDArray[np.float64]:
        """F(q, p) of eq 36 / 11.4, N·m.

        Keyword options ``free``, ``effort``, ``q_previous`` and ``dt`` as :meth:`solve`. With
        extensible segments the residual has six rows, (12.4) and ℓ̂ × (12.5), at bottom-face
        ``lengths`` (m; the rest lengths when omitted).
        """
        return self._evaluation(q, p, **solve_options)[0]

    def residual_jacobian(
        self, q: ArrayLike, p: ArrayLike, **solve_options
    ) -> NDArray[np.float64]:
        """∂F/∂x of eq 36 / 11.4 (analytic), (3, 3) or (6, 6); options as :meth:`residual`."""
        return self._evaluation(q, p, **solve_options)[1]

    def _evaluation(
        self, q, p, *, free=False, effort=None, q_previous=None, dt=None, lengths=None
    ) -> tuple[NDArray, NDArray]:
        motion, rate = self._motion(effort=effort, q_previous=q_previous, dt=dt)
        x = self.unknowns(q, lengths)
        pressure = as_joint_vector('p', p)
        return evaluate_state(self.packed, x, pressure, free, motion, rate)

    def _motion(self, *, effort=None, q_previous=None, dt=None, qdot=None, rows=None):
        """The finger's ``motion`` rows (q_prev, speed, effort) and ``rate`` of a solve, checked.

        ``rows``: None for one state, else the number of rows of a batch (``motion`` then has
        shape (rows, 3, 3)).
        """
        if (q_previous is None) != (dt is None):
            raise ValueError('q_previous and dt go together: give both for a stepped solve')
        if dt is not None and not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
            raise ValueError(f'dt = {dt!r}: must be a finite time step > 0 s')
        if rows is None and q_previous is None and qdot is None and effort is None:
            return _AT_REST, 0.0
        shape = (3, 3) if rows is None else (rows, 3, 3)
        motion = np.zeros(shape)
        for index, (name, value) in enumerate(
            (('q_previous', q_previous), ('qdot', qdot), ('effort', effort))
        ):
            if value is None:
                continue
            if rows is None:
                motion[index] = as_joint_vector(name, value)
            else:
                values = as_joint_rows(name, value)
                _require_shape(name, values, 'P', (rows, 3))
                motion[:, index] = values
        # Read-only as _AT_REST is: numba compiles a kernel once per argument type, and a
        # writable array is another type than a read-only one.
        motion.flags.writeable = False
        return motion, 0.0 if dt is None else 1.0 / dt

    def _lengths(self, lengths: ArrayLike | None) -> NDArray[np.float64]:
        """Bottom-face lengths ℓ, m: the rest lengths when None."""
        if lengths is None:
            return self.constants.arc_lengths
        return as_joint_vector('lengths', lengths)

    def unknowns(
        self, q: ArrayLike, lengths: ArrayLike | None = None, *, name: str = 'q'
    ) -> NDArray[np.float64]:
        """The solver's unknowns for angles ``q`` (and bottom-face ``lengths``, m): a new array.

        With extensible segments also the strains ε = ℓ/ℓ̂ − 1 (zero when ``lengths`` is None).
        ``name``: what a ValueError calls ``q``.
        """
        angles = as_joint_vector(name, q)
        if not self.extensible:
            return angles
        strain = self._lengths(lengths) / self.constants.arc_lengths - 1.0
        return np.concatenate([angles, strain])

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
        """Joint angles and contact forces at chamber pressures ``p`` (docs/spec/model.md (11.4)).

        Parameters
        ----------
        p : array_like, shape (3,)
            Gauge pressures, Pa.
        q0 : array_like, shape (3,), or Solution, optional
            Start of the Newton iteration (warm start; a Solution starts from its angles and
            lengths); the previous angles of a stepped solve, else zero, when omitted.
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
        pressure = as_joint_vector('p', p)
        motion, rate = self._motion(effort=effort, q_previous=q_previous, dt=dt)
        lengths = None
        if isinstance(q0, Solution):
            q0, lengths = q0.q, q0.lengths
        x = self.unknowns(motion[0] if q0 is None else q0, lengths, name='q0')  # checked, a copy
        limits = _STATIC_LIMITS if rate == 0.0 else (rate, *VALID_STRETCH)
        status, iterations, residual, forces, torque, valid, moving_range = solve_state(
            self.packed, pressure, x, free, motion, limits
        )
        status = int(status)
        # Positional, in the order of Solution's fields: keywords cost 0.3 µs of a solve's 8.
        return Solution(
            x[:3],  # q
            forces,
            torque,  # finger_torque
            pressure,
            status,
            STATUS[status],  # message
            int(iterations),
            float(residual),
            valid,  # in_valid_range
            moving_range,  # in_range_of_motion
            self._lengths_of(x),
        )

    def _lengths_of(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bottom-face lengths ℓ_k (m) of the solver's unknowns (one state or rows)."""
        rest = self.constants.arc_lengths
        if not self.extensible:
            return rest.copy() if x.ndim == 1 else np.tile(rest, (x.shape[0], 1))
        return rest * (1.0 + x[..., 3:])

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
        """:meth:`solve` over rows (each row solved as :meth:`solve` solves it).

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
        motion, rate = self._motion(effort=effort, q_previous=Q_previous, dt=dt, rows=rows)
        start = motion[:, 0] if Q0 is None else as_joint_rows('Q0', Q0)
        _require_shape('Q0', start, 'P', pressure.shape)
        x = start
        if self.extensible:
            rest = self.constants.arc_lengths
            if lengths0 is None:
                strain = np.zeros_like(start)
            else:
                lengths = as_joint_rows('lengths0', lengths0)
                _require_shape('lengths0', lengths, 'P', pressure.shape)
                strain = lengths / rest - 1.0
            x = np.concatenate([start, strain], axis=1)
        x, forces, torque, status, iterations, residual = solve_rows(
            self.packed, pressure, np.array(x, order='C'), free, motion, rate
        )
        valid, moving_range = validity_rows(self.packed, x, *VALID_STRETCH)
        return BatchSolution(
            q=x[:, :3].copy(),
            forces=forces,
            finger_torque=torque,
            pressure=pressure,
            status=status,
            iterations=iterations,
            residual=residual,
            in_valid_range=valid,
            in_range_of_motion=moving_range,
            lengths=self._lengths_of(x),
        )

    # -- inverse and estimation ----------------------------------------------------------

    def pressure_for(
        self, q: ArrayLike, qdot: ArrayLike | None = None, effort: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Pressures that hold the glove at angles ``q`` on the finger, Pa (eq 11.4 for p).

        p = B_R^{-1} ((J_R*)ᵀ (J_H*)^{-T} τ_H(q, q̇, u) − τ_s(q)); exact, no iteration (with
        extensible segments the bottom strains are solved for too): ``hold(q, qdot,
        effort).pressure``. The result may be negative where holding ``q`` would need suction.

        Warns
        -----
        OutsideModelWarning
            If the answer leaves the validated model (a fibre stretch, the range of motion or
            the supply range, :mod:`.validity`); :meth:`hold` says which without warning.
        """
        _, pressure, _, valid, moving_range, enough = self._held(q, qdot, effort, SUPPLY_PRESSURE)
        if not (valid and moving_range and enough):  # the status only then: a hot path
            status = validity_status(valid, moving_range, enough)
            warn_outside('pressure_for', status, SUPPLY_PRESSURE)
        return pressure

    def hold(
        self,
        q: ArrayLike,
        qdot: ArrayLike | None = None,
        effort: ArrayLike | None = None,
        *,
        supply: float = SUPPLY_PRESSURE,
    ) -> Hold:
        """The inverse: pressures (Pa) and bottom-face lengths ℓ (m) that hold angles ``q``.

        Constant-length segments: exact. Extensible ones (docs/spec/model.md §12): (12.4) gives p
        for given strains exactly, and (12.5) with that p is solved for the strains (Newton
        with their analytic Jacobian, :mod:`.kernels.inverse`).

        Parameters
        ----------
        q : array_like, shape (3,)
            Angles to hold, rad.
        qdot : array_like, shape (3,), optional
            Joint speeds, rad/s (None: at rest).
        effort : array_like, shape (3,), optional
            The patient's voluntary effort u, N·m (None: none).
        supply : float
            The supply pressure the answer's pressures are checked against, Pa.

        Returns
        -------
        Hold
            The pressures and lengths, with ``status`` and ``message`` saying whether they lie
            inside the validated stretch, the range of motion and [0, ``supply``].

        Raises
        ------
        ValueError
            If no bottom-face strain balances the segments (extensible segments only): the
            message names the segment left most out of balance, its residual and its stretches.
        """
        angles, pressure, strain, valid, moving_range, enough = self._held(q, qdot, effort, supply)
        status = validity_status(valid, moving_range, enough)
        return Hold(
            q=angles,
            pressure=pressure,
            lengths=self.constants.arc_lengths * (1.0 + strain),
            status=status,
            message=validity_message(status, supply),
            in_valid_range=valid,
            in_range_of_motion=moving_range,
            within_supply=enough,
            supply=supply,
        )

    def _held(self, q, qdot, effort, supply: float) -> tuple:
        """Angles, pressures, bottom strains and the three validity flags of :meth:`hold`."""
        angles = as_joint_vector('q', q)
        motion, _ = self._motion(effort=effort, qdot=qdot)
        converged, strain, pressure, left = hold(self.packed, angles, motion)
        if not converged:
            raise ValueError(self._unbalanced('hold', angles, strain, left))
        valid, moving_range = self._validity(angles[None], strain[None])
        enough = within_supply(pressure, supply)
        return angles, pressure, strain, bool(valid[0]), bool(moving_range[0]), enough

    def _validity(self, angles: NDArray, strains: NDArray) -> tuple[NDArray, NDArray]:
        """Per row of angles and bottom strains (N, 3): in_valid_range, in_range_of_motion."""
        x = np.concatenate([angles, strains], axis=1) if self.extensible else angles
        return validity_rows(self.packed, np.ascontiguousarray(x), *VALID_STRETCH)

    def _unbalanced(self, what: str, q: NDArray, strain: NDArray, left: NDArray) -> str:
        """Why the strain balance of ``what`` failed: the segment left most out of balance."""
        k = int(np.argmax(np.abs(left)))
        stretch = self.top_fibre_stretch(q, strain)[k]
        low, high = VALID_STRETCH
        where = (
            'inside' if low <= 1.0 + strain[k] <= high and low <= stretch <= high else 'outside'
        )
        return (
            f'{what}: no bottom-face strain balances the segments at q = {np.round(q, 6)} rad '
            f'(the {JOINT_NAMES[k]} segment stopped {left[k]:.3g} N·m out of balance at '
            f'bottom stretch {1.0 + strain[k]:.4g}, top {stretch:.4g}: {where} the validated '
            f'range {low:g}..{high:g})'
        )

    def finger_forces(
        self, q: ArrayLike, qdot: ArrayLike | None = None, effort: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Finger-side contact forces f = (J_H*)^{-T} τ_H(q, q̇, u), N (eqs 34, 11.1)."""
        _, j_finger = self.contact_jacobians(q)
        forces = np.empty(3)
        transpose_solve(j_finger, self.finger_torque(q, qdot, effort), forces)
        return forces

    def estimate_forces(self, q: ArrayLike, p: ArrayLike) -> NDArray[np.float64]:
        """Robot-side contact forces f = (J_R*)^{-T} (τ_s(q) + B_R p), N (docs/spec/model.md §7).

        Needs no finger model: from measured angles and pressures only (with extensible
        segments the bottom strains are solved for too): ``estimate(q, p).forces``.

        Warns
        -----
        OutsideModelWarning
            If the state leaves the validated model (a fibre stretch or the range of motion);
            :meth:`estimate` says which without warning.
        """
        angles, pressure = as_joint_vector('q', q), as_joint_vector('p', p)
        if self.extensible:
            rows, _, valid_rows, moving_rows = self._estimated(angles[None], pressure[None])
            forces, valid, moving_range = rows[0], bool(valid_rows[0]), bool(moving_rows[0])
        else:  # the hot path: one kernel call
            forces, valid, moving_range = estimate_one(
                self.packed, angles, pressure, *VALID_STRETCH
            )
        if not (valid and moving_range):  # the status only then
            warn_outside('estimate_forces', validity_status(valid, moving_range))
        return forces

    def estimate(self, q: ArrayLike, p: ArrayLike) -> Estimate:
        """The robot-side estimator: contact forces f (N) and bottom-face lengths ℓ (m).

        From measured angles and pressures, no finger model: (12.4) gives f for given strains,
        (12.5) with that f is solved for the strains (docs/spec/model.md §12). The result's
        ``status`` and ``message`` say whether the state lies inside the validated stretch and
        the (nominal) finger's range of motion.

        Raises
        ------
        ValueError
            If no bottom-face strain balances the segments (extensible segments only).
        """
        angles, pressure = as_joint_vector('q', q), as_joint_vector('p', p)
        forces, strains, valid, moving_range = self._estimated(angles[None], pressure[None])
        status = validity_status(bool(valid[0]), bool(moving_range[0]))
        return Estimate(
            q=angles,
            pressure=pressure,
            forces=forces[0],
            lengths=self.constants.arc_lengths * (1.0 + strains[0]),
            status=status,
            message=validity_message(status),
            in_valid_range=bool(valid[0]),
            in_range_of_motion=bool(moving_range[0]),
        )

    def estimate_batch(self, Q: ArrayLike, P: ArrayLike) -> BatchEstimate:
        """:meth:`estimate` for rows of angles and pressures (N, 3), with per-row masks.

        Raises
        ------
        ValueError
            If no bottom-face strain balances the segments in some row (the first is named).
        """
        angles, pressure = as_joint_rows('Q', Q), as_joint_rows('P', P)
        _require_shape('P', pressure, 'Q', angles.shape)
        forces, strains, valid, moving_range = self._estimated(angles, pressure)
        return BatchEstimate(
            forces=forces,
            lengths=self.constants.arc_lengths * (1.0 + strains),
            status=validity_status(valid, moving_range),
            in_valid_range=valid,
            in_range_of_motion=moving_range,
        )

    def _estimated(self, angles: NDArray, pressure: NDArray) -> tuple[NDArray, ...]:
        """Forces, bottom strains and the two validity masks of checked rows (N, 3).

        ValueError where no bottom-face strain balances the segments (the first row named).
        """
        converged, strains, forces, left = estimate_rows(self.packed, angles, pressure)
        if not converged.all():
            row = int(np.argmin(converged))
            message = self._unbalanced('estimate', angles[row], strains[row], left[row])
            raise ValueError(message if len(angles) == 1 else f'{message} (row {row})')
        return (forces, strains, *self._validity(angles, strains))

    def estimate_forces_batch(self, Q: ArrayLike, P: ArrayLike) -> NDArray[np.float64]:
        """:meth:`estimate_forces` for rows of angles and pressures, shape (N, 3), N.

        Warns
        -----
        OutsideModelWarning
            If a row leaves the validated model (:meth:`estimate_batch` says which rows).
        """
        rows = self.estimate_batch(Q, P)
        warn_outside('estimate_forces_batch', int(np.bitwise_or.reduce(rows.status)))
        return rows.forces

    def contact_torque(self, q: ArrayLike, forces: ArrayLike) -> NDArray[np.float64]:
        """(J_H*)ᵀ f: the joint torque contact forces f (N) apply to the finger, N·m (eq 34).

        ``q`` and ``forces`` of shape (3,), or (N, 3) rows.
        """
        angles, rows = as_joint_array('q', q), as_joint_array('forces', forces)
        _require_shape('forces', rows, 'q', angles.shape)
        torque = contact_torques(self.packed, np.atleast_2d(angles), np.atleast_2d(rows))
        return torque.reshape(angles.shape)

    def robot_contact_torque(self, q: ArrayLike, forces: ArrayLike) -> NDArray[np.float64]:
        """(J_R*)ᵀ f: the joint torque contact forces f (N) put on the exo-digit, N·m (eq 34).

        At the segments' rest lengths; ``q`` and ``forces`` of shape (3,), or (N, 3) rows. What
        the force mode's feed-forward needs (docs/spec/model.md §7, for p).
        """
        angles, rows = as_joint_array('q', q), as_joint_array('forces', forces)
        _require_shape('forces', rows, 'q', angles.shape)
        # a writable copy: a read-only view (np.broadcast_to's) compiles the kernel anew
        torque = robot_contact_torques(self.packed, np.atleast_2d(angles), np.array(rows, ndmin=2))
        return torque.reshape(angles.shape)

    def estimate_finger_torque(self, Q: ArrayLike, P: ArrayLike) -> NDArray[np.float64]:
        """τ̂_H = (J_H*)ᵀ f̂ from the robot-side estimate, N·m (docs/spec/model.md §11).

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
        how well a linear spring explains the data (docs/spec/model.md §11, "Estimation").
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

        ``lengths`` are the arcs' bottom-face lengths ℓ (m, docs/spec/model.md §12; a
        ``Solution``'s ``lengths``); the rest lengths when omitted. A point at fraction s of
        arc k is z_k + e^{iφ_k}(2 d_k + s ℓ_k C(s q_k)): the arc traced by the chord formula
        with a shorter length and angle.
        """
        angles = as_joint_vector('q', q)
        half = self.constants.block_half_lengths
        arcs = self._lengths(lengths)
        half_turn, chord = _chords(angles)
        turns, origins = np.empty(4, complex), np.empty(4, complex)
        centres = np.empty(3, complex)
        frames(half_turn, chord, arcs, half, turns, origins, centres)
        joints, contacts = finger_points(angles, self.constants.finger_half_lengths)
        fractions = np.linspace(0.0, 1.0, arc_samples)
        partial = np.array([_chords(f * angles)[1] for f in fractions])  # (samples, 3)
        starts = origins[:3] + turns[:3] * (2.0 * half[:3])
        points = starts + turns[:3] * (fractions[:, None] * arcs) * partial
        return GlovePose(
            block_origins=_xy(origins),
            block_ends=_xy(origins + turns * (2.0 * half)),
            contact_points=_xy(centres),
            contact_normals=_xy(1j * turns[1:]),
            arcs=_xy(points.T),
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
        return bottom + angles * self.constants.strain_per_angle

    def in_valid_range(self, q: ArrayLike, strain: ArrayLike = 0.0) -> NDArray[np.bool_]:
        """Whether every fibre's stretch (12.1) lies in VALID_STRETCH (per row for (N, 3)).

        The extreme fibres are the bottom face and the top.
        """
        angles = as_joint_array('q', q)
        strains = np.broadcast_to(np.asarray(strain, dtype=float), angles.shape)
        x = np.concatenate([np.atleast_2d(angles), np.atleast_2d(strains)], axis=1)
        valid, _ = validity_rows(self.packed, x, *VALID_STRETCH)
        return valid[0] if angles.ndim == 1 else valid

    def in_range_of_motion(self, q: ArrayLike) -> NDArray[np.bool_]:
        """Whether every joint lies in [rom_min, rom_max] (scalar for (3,), per row for (N, 3))."""
        angles = as_joint_array('q', q)
        _, moving_range = validity_rows(self.packed, np.atleast_2d(angles), *VALID_STRETCH)
        return moving_range[0] if angles.ndim == 1 else moving_range
