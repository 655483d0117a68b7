"""Independent reference of docs/spec/model.md §14 (supply, valves, chamber volume).

Written from the contract alone, like tests/model_reference.py, whose statics it reuses: the
flow function ψ and mass flow Q of (14.3), the chamber volume (14.1), and a tight-tolerance
integration of the DAE {(14.4), (14.2), statics}. The state is the three air masses; at every
evaluation the pose is solved from them: the angles q such that, with p_i = m_i·R·T/V_i(q) − P_atm
(the gas law), the statics of eq 36 / 11.4 hold (``scipy.optimize.root``). The masses are
integrated by ``scipy.integrate.solve_ivp`` (LSODA, which switches to BDF where the laminar
region near equal pressures makes the system stiff; Radau gives the same pressures to 1e-3 Pa
and takes five times longer) one opening at a time (zero-order hold), so a step's end is a grid
point.

Only inextensible segments and a finger without velocity terms are covered (the defaults of
docs/spec/model.md §10-11): then the statics are eq 36 and need no q̇. Nothing here calls
``exodigit_model``: numbers are typed in from the document, parameter objects are read for their
values only.
"""

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from model_reference import (
    SPEC_DEFAULTS,
    coupled_residual,
    region_first_moment,
    yeoh_stress,
)
from scipy.integrate import solve_ivp

ATMOSPHERIC_PRESSURE = 101325.0
"""P_atm, Pa (docs/spec/model.md §14)."""
GAS_CONSTANT = 287.05
"""R of air, J/(kg K)."""
REFERENCE_DENSITY = 1.185
"""ρ0 of ISO 6358, kg/m³."""
REFERENCE_TEMPERATURE = 293.15
"""T0 of ISO 6358, K."""
LAMINAR_RATIO = 0.999
"""Pressure ratio above which (14.3) is linear in the pressure difference."""
SPEC_PNEUMATICS = {**SPEC_DEFAULTS['pneumatics'], 'supply_pressure': 100e3}
"""The ``pneumatics`` section of docs/spec/model.md §14 (tests/model_reference.py) with the
supply its ``null`` stands for: SimulationSettings' default max_supply_pressure, Pa gauge."""
RTOL = 1e-9
"""Relative tolerance of the reference integration."""
MASS_ATOL = 1e-16
"""Absolute tolerance of the integrated masses, kg (a chamber holds ~1e-5 kg)."""
POSE_TOLERANCE = 1e-12
"""The pose solve stops at a Newton step below this, rad (≈ 3e-8 Pa through (14.2))."""
POSE_ITERATIONS = 50
"""Newton steps the pose solve may take."""
PRESSURE_TOLERANCE = 1e-6
"""The pose solve of :class:`SolvedChambers` stops at a Newton step below this, Pa."""
COMPLEX_STEP = 1e-30
"""Imaginary step of the complex-step derivatives, rad."""
GAUSS_POINTS = 32
"""Gauss-Legendre points per direction of the fast section integral (the integrand is smooth;
tests/test_valves_reference.py compares it with adaptive quadrature)."""


# -- flow through a valve (14.3) ----------------------------------------------------------------


def flow_function(ratio, critical_ratio):
    """ψ(r) of (14.3): 1 when choked, the ISO elliptic law above b, linear above 0.999."""
    r, b = float(ratio), float(critical_ratio)
    if r <= b:
        return 1.0
    if r <= LAMINAR_RATIO:
        return math.sqrt(1.0 - ((r - b) / (1.0 - b)) ** 2)
    return flow_function(LAMINAR_RATIO, b) * (1.0 - r) / (1.0 - LAMINAR_RATIO)


def mass_flow(upstream, downstream, conductance, critical_ratio, temperature):
    """Q(P_u, P_d) of (14.3), kg/s; absolute pressures in Pa; negative when P_d > P_u."""
    if downstream > upstream:
        return -mass_flow(downstream, upstream, conductance, critical_ratio, temperature)
    if upstream == 0.0:
        return 0.0
    return (
        conductance
        * REFERENCE_DENSITY
        * upstream
        * math.sqrt(REFERENCE_TEMPERATURE / temperature)
        * flow_function(downstream / upstream, critical_ratio)
    )


@dataclass(frozen=True)
class Supply:
    """The valves, leaks and supply of (14.4), from a ``pneumatics`` dict."""

    pneumatics: dict

    @property
    def temperature(self):
        return self.pneumatics['temperature']

    @property
    def supply(self):
        """P_s, Pa absolute."""
        return self.pneumatics['supply_pressure'] + ATMOSPHERIC_PRESSURE

    def mass_rates(self, pressures, openings):
        """dm_i/dt of (14.4), kg/s: six openings (inlets MCP, PIP, DIP, then outlets)."""
        rates = np.zeros(3)
        for i, chamber in enumerate(self.pneumatics['chambers']):
            p = pressures[i]
            inflow = mass_flow(
                self.supply,
                p,
                chamber['inlet_conductance'],
                chamber['inlet_critical_ratio'],
                self.temperature,
            )
            outflow = mass_flow(
                p,
                ATMOSPHERIC_PRESSURE,
                chamber['outlet_conductance'],
                chamber['outlet_critical_ratio'],
                self.temperature,
            )
            leak = chamber['leak_conductance'] * (p - ATMOSPHERIC_PRESSURE)
            rates[i] = openings[i] * inflow - openings[3 + i] * outflow - leak
        return rates

    def mass_of(self, pressures, volumes):
        """m = P·V/(R·T) of (14.2), kg (absolute pressures)."""
        return np.asarray(pressures) * np.asarray(volumes) / (GAS_CONSTANT * self.temperature)


# -- chambers: a rigid one (closed forms) and the glove's (14.1) --------------------------------


@dataclass(frozen=True)
class RigidChambers:
    """Three chambers of fixed volumes (m³): P = m·R·T/V, for the closed-form checks."""

    supply: Supply
    volumes: tuple

    def pose(self, mass):
        """(absolute pressures, volumes, None): nothing moves."""
        volumes = np.asarray(self.volumes, dtype=float)
        return mass * GAS_CONSTANT * self.supply.temperature / volumes, volumes, None


def cross_section_area(segment):
    """A_c = 2·r0·h + (π/2)·r0² of (14.1), m²: the cavity's rectangle and half disc."""
    r0 = segment.inner_radius
    return 2.0 * r0 * segment.wall_height + 0.5 * math.pi * r0 * r0


def section_rule(segment):
    """Heights y_j and weights w_j with ∫ g(y) dA ≈ Σ w_j·g(y_j) over eq 27's three zones.

    Gauss-Legendre in y over the base (width 2R) and the side walls (2t), and in (r, φ) over
    the two quarter annuli (weight r).
    """
    r0, t, h, b = (
        segment.inner_radius,
        segment.wall_thickness,
        segment.wall_height,
        segment.base_thickness,
    )
    x, w = np.polynomial.legendre.leggauss(GAUSS_POINTS)

    def on(low, high):
        return low + 0.5 * (high - low) * (x + 1.0), 0.5 * (high - low) * w

    y_base, w_base = on(0.0, b)
    y_wall, w_wall = on(b, b + h)
    radius, w_radius = on(r0, r0 + t)
    angle, w_angle = on(0.0, 0.5 * math.pi)
    y_arch = b + h + np.outer(radius, np.sin(angle))
    w_arch = 2.0 * np.outer(w_radius * radius, w_angle)
    heights = np.concatenate([y_base, y_wall, y_arch.ravel()])
    weights = np.concatenate([2.0 * (r0 + t) * w_base, 2.0 * t * w_wall, w_arch.ravel()])
    return heights, weights


def centres_and_normals(params, q):
    """Centres r^C_i and normals n_i of the exo-digit's blocks by docs/spec/model.md §2.

    The chord of segment i is written ℓ̂·sinc(q/2)·(cos, sin)(φ_{i−1} + q/2), finite at q = 0
    (``np.sinc(x)`` is sin(πx)/(πx)); complex angles are accepted (:func:`robot_jacobian`).
    """
    exo = params.exo_digit
    half = np.array([exo.base_block_half_length] + [s.block_half_length for s in exo.segments])
    arcs = np.array([s.arc_length for s in exo.segments])
    phi = np.concatenate([[0.0], np.cumsum(q)])
    middle = phi[:-1] + 0.5 * np.asarray(q)
    chords = arcs * np.sinc(0.5 * np.asarray(q) / math.pi)

    def along(angle):
        return np.column_stack([np.cos(angle), np.sin(angle)])

    origins = np.cumsum(
        2.0 * half[:-1, None] * along(phi[:-1]) + chords[:, None] * along(middle), 0
    )
    normals = np.column_stack([-np.sin(phi[1:]), np.cos(phi[1:])])
    return origins + half[1:, None] * along(phi[1:]), normals


def jacobian_by_differences_of(function, x, step=1e-7):
    """∂function/∂x by central differences (square; the Newton matrix of the pose solve)."""
    columns = []
    for k in range(len(x)):
        offset = np.zeros(len(x))
        offset[k] = step
        columns.append((function(x + offset) - function(x - offset)) / (2.0 * step))
    return np.column_stack(columns)


def robot_jacobian(params, q):
    """J_R*[i, k] = n_i·∂r^C_i/∂q_k by complex-step differences of :func:`centres_and_normals`
    (exact to rounding, valid at q = 0 too)."""
    q = np.asarray(q, dtype=float)
    normals = centres_and_normals(params, q)[1]
    jacobian = np.zeros((3, 3))
    for k in range(3):
        shifted = q.astype(complex)
        shifted[k] += 1j * COMPLEX_STEP
        slope = centres_and_normals(params, shifted)[0].imag / COMPLEX_STEP
        jacobian[:, k] = np.sum(normals * slope, axis=1)
    return jacobian


class GloveChambers:
    """The glove's three chambers: volume (14.1), gas law (14.2) and the statics of eq 36.

    ``pose(mass)`` solves for q with p_i = m_i·R·T/V_i(q) − P_atm, so that eq 36 holds, and
    returns (absolute pressures, volumes, q). Inextensible segments only (ℓ_i = ℓ̂_i).
    """

    def __init__(self, params, supply):
        for segment in params.exo_digit.segments:
            if math.isfinite(segment.layer_axial_stiffness):
                raise ValueError(f'{segment.name}: the reference covers inextensible segments')
        self.params, self.supply = params, supply
        self.rules = [section_rule(s) for s in params.exo_digit.segments]
        self.pressure_moments = np.array(
            [region_first_moment(s) for s in params.exo_digit.segments]
        )
        dead = np.array([c['dead_volume'] for c in supply.pneumatics['chambers']])
        self.rest_volumes = dead + np.array(
            [cross_section_area(s) * s.arc_length for s in params.exo_digit.segments]
        )
        self._guess, self._jacobian, self._last_step = np.zeros(3), None, math.inf

    def moment(self, material, segment, angle):
        """M(q) of eq 27 by :func:`section_rule` (a drop-in for model_reference's quadrature)."""
        heights, weights = self.rules[self.params.exo_digit.segments.index(segment)]
        stress = yeoh_stress(material, 1.0 + heights * angle / segment.arc_length)
        return float(np.sum(weights * stress * heights))

    def volumes(self, q):
        """V_i of (14.1), m³ (inextensible: ℓ_i = ℓ̂_i)."""
        return self.rest_volumes + self.pressure_moments * np.asarray(q)

    def residual(self, q, mass):
        """Eq 36 at the angles q and the gauge pressures the gas law gives them, N·m."""
        gauge = (
            mass * GAS_CONSTANT * self.supply.temperature / self.volumes(q) - ATMOSPHERIC_PRESSURE
        )
        return coupled_residual(
            self.params,
            q,
            gauge,
            moment=self.moment,
            pressure_moments=self.pressure_moments,
            robot_jacobian=robot_jacobian,
        )

    def pose(self, mass):
        """(absolute pressures, volumes, q) of the glove holding the air masses ``mass``.

        Newton's method from the last pose, with a difference Jacobian of the residual that is
        kept while it still shrinks each step a hundredfold (the states an integrator asks for
        lie close together), until the step is below ``POSE_TOLERANCE``.
        """
        q = self._guess.copy()
        for _ in range(POSE_ITERATIONS):
            if self._jacobian is None:
                self._jacobian = jacobian_by_differences_of(lambda a: self.residual(a, mass), q)
            step = -np.linalg.solve(self._jacobian, self.residual(q, mass))
            q = q + step
            size = np.abs(step).max()
            if size < POSE_TOLERANCE:
                break
            if size > 0.01 * self._last_step:
                self._jacobian = None
            self._last_step = size
        else:
            raise RuntimeError(f'reference pose at m = {mass}: no convergence')
        self._guess, self._last_step = q, math.inf
        volumes = self.volumes(q)
        return mass * GAS_CONSTANT * self.supply.temperature / volumes, volumes, q

    @cached_property
    def rest_mass(self):
        """m_rest: the masses at p = 0 (vented; q = 0 for a finger resting at 0), kg."""
        return self.supply.mass_of(np.full(3, ATMOSPHERIC_PRESSURE), self.volumes(np.zeros(3)))


class SolvedChambers:
    """The chambers of any glove, extensible segments too, posed by the model's own statics.

    For gloves :class:`GloveChambers` does not cover (an extensible segment's length is an
    unknown of (12.4)-(12.5)): ``pose(mass)`` finds the gauge pressures p with
    p_i = m_i·R·T/V_i(q(p), ℓ(p)) − P_atm, where q(p), ℓ(p) are the equilibrium of
    ``model.solve(p)`` (the statics, checked against quadrature by the model's own tests) and
    V_i is (14.1) written here, by Newton's method on p with a difference Jacobian. What this
    checks of the model is the air: the integration of (14.4) and its coupling to the pose.
    """

    def __init__(self, model, supply):
        self.model, self.supply = model, supply
        segments = model.params.exo_digit.segments
        dead = np.array([c['dead_volume'] for c in supply.pneumatics['chambers']])
        self.areas = np.array([cross_section_area(s) for s in segments])
        self.arcs = np.array([s.arc_length for s in segments])
        self.dead = dead
        self.pressure_moments = np.array([region_first_moment(s) for s in segments])
        self._guess = np.zeros(3)
        self._last = None

    def volumes(self, q, lengths):
        """V_i = V_d + A_c·ℓ + (r_p·A_p)·q of (14.1), m³."""
        return self.dead + self.areas * np.asarray(lengths) + self.pressure_moments * q

    def _posed(self, gauge):
        """(q, volumes) at the gauge pressures: the statics from the last pose, else from rest."""
        solution = self.model.solve(gauge, self._last)
        if solution.status > 1:
            solution = self.model.solve(gauge, np.zeros(3))
        if solution.status > 1:
            raise RuntimeError(f'reference statics at p = {gauge}: {solution.message}')
        self._last = solution
        return solution.q, self.volumes(solution.q, solution.lengths)

    def gap(self, gauge, mass):
        """p − (m·R·T/V(p) − P_atm), Pa: zero at the pose of ``mass``."""
        volumes = self._posed(gauge)[1]
        absolute = mass * GAS_CONSTANT * self.supply.temperature / volumes
        return gauge - (absolute - ATMOSPHERIC_PRESSURE)

    def pose(self, mass):
        """(absolute pressures, volumes, q) of the glove holding the air masses ``mass``."""
        gauge = self._guess.copy()
        for _ in range(POSE_ITERATIONS):
            jacobian = jacobian_by_differences_of(lambda p: self.gap(p, mass), gauge, step=1.0)
            step = -np.linalg.solve(jacobian, self.gap(gauge, mass))
            gauge = gauge + step
            if np.abs(step).max() < PRESSURE_TOLERANCE:
                break
        else:
            raise RuntimeError(f'reference pose at m = {mass}: no convergence')
        self._guess = gauge
        q, volumes = self._posed(gauge)
        return gauge + ATMOSPHERIC_PRESSURE, volumes, q

    @cached_property
    def rest_mass(self):
        """m_rest: the masses vented at the pose of p = 0, kg."""
        return self.supply.mass_of(np.full(3, ATMOSPHERIC_PRESSURE), self._posed(np.zeros(3))[1])


# -- the integration -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Trajectory:
    """The reference at t_0..t_K: times (K+1,), masses, gauge pressures, volumes (K+1, 3)."""

    t: np.ndarray
    mass: np.ndarray
    pressure: np.ndarray
    volume: np.ndarray
    q: np.ndarray | None


def integrate(chambers, openings, period, mass):
    """Integrate (14.4) with the chambers' pose at every evaluation, one opening per period.

    Parameters
    ----------
    chambers : RigidChambers or GloveChambers
        What turns masses into pressures (its ``supply`` gives (14.4)).
    openings : array (K, 6)
        u_in (MCP, PIP, DIP) then u_out, held over each period (zero-order hold).
    period : float
        Δt of the openings, s.
    mass : array (3,)
        Air masses at t_0, kg.
    """
    openings = np.asarray(openings, dtype=float)
    masses = [np.asarray(mass, dtype=float)]

    def rates(_, m, u):
        return chambers.supply.mass_rates(chambers.pose(m)[0], u)

    for k, u in enumerate(openings):
        result = solve_ivp(
            rates,
            (k * period, (k + 1) * period),
            masses[-1],
            method='LSODA',
            rtol=RTOL,
            atol=MASS_ATOL,
            args=(u,),
        )
        if not result.success:
            raise RuntimeError(f'reference integration, step {k}: {result.message}')
        masses.append(result.y[:, -1])
    poses = [chambers.pose(m) for m in masses]
    pressures = np.array([pose[0] for pose in poses]) - ATMOSPHERIC_PRESSURE
    angles = None if poses[0][2] is None else np.array([pose[2] for pose in poses])
    return Trajectory(
        t=period * np.arange(len(masses)),
        mass=np.array(masses),
        pressure=pressures,
        volume=np.array([pose[1] for pose in poses]),
        q=angles,
    )
