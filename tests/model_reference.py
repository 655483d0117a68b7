"""Independent reference computations for the model tests, written from docs/spec/model.md only.

Nothing here calls the quadrature, kinematics or solver of ``exodigit_model``: the integrals use
adaptive ``scipy.integrate.quad``/``dblquad``, the kinematics use eqs 1-4 with plain sin/cos
(y-row of eq 4 corrected, docs/spec/model.md §9), and the numbers are copied from
docs/spec/model.md §10. Parameter objects are only read for their values.
"""

import math

import numpy as np
from scipy.integrate import dblquad, quad
from scipy.optimize import brentq

QUAD_OPTIONS = {'epsabs': 0.0, 'epsrel': 1e-12, 'limit': 200}
"""Adaptive quadrature settings of every reference integral (no absolute floor: M is small)."""
JACOBIAN_STEP = 1e-6
"""Central-difference step of the reference contact Jacobian, rad."""

SPEC_DEFAULTS = {
    'material': {'c1': 1.1e5, 'c2': 2.0e4, 'c3': 0.0},
    'exo_digit': {
        'base_block_half_length': 0.010,
        'segments': [
            {
                'name': name,
                'arc_length': arc,
                'inner_radius': 0.006,
                'wall_thickness': 0.001,
                'wall_height': 0.004,
                'base_thickness': 0.0015,
                'block_half_length': 0.005,
                'layer_axial_stiffness': math.inf,  # inextensible, docs/spec/model.md §12
            }
            for name, arc in (('mcp', 0.046), ('pip', 0.031), ('dip', 0.015))
        ],
    },
    'finger': {
        'joints': [
            {
                'name': name,
                'link_half_length': half,
                'stiffness': k,
                # docs/spec/model.md §11 defaults: a linear spring about q = 0.
                'rest_angle': 0.0,
                'rom_min': low,
                'rom_max': high,
                'rom_torque': 0.0,
                'rom_sharpness': 10.0,
                'damping': 0.0,
                'spasticity': 0.0,
                'extensor_spasticity': 0.0,
                'spasticity_threshold': 0.5,
            }
            for name, half, k, low, high in (
                ('mcp', 0.023, 0.040, -0.35, 1.57),
                ('pip', 0.0135, 0.030, 0.0, 1.75),
                ('dip', 0.009, 0.015, 0.0, 1.40),
            )
        ]
    },
    'pneumatics': {
        'supply_pressure': None,
        'temperature': 293.15,
        'chambers': [
            {
                'name': name,
                'inlet_conductance': 5.0e-10,
                'inlet_critical_ratio': 0.3,
                'outlet_conductance': 5.0e-10,
                'outlet_critical_ratio': 0.3,
                'dead_volume': 1.0e-6,
                'leak_conductance': 0.0,
            }
            for name in ('mcp', 'pip', 'dip')
        ],
    },
}
"""The parameter file of docs/spec/model.md §10 with the defaults of §11-12 and §14, typed in
from it."""
SEGMENT_LENGTH_KEYS = (
    'arc_length',
    'inner_radius',
    'wall_thickness',
    'wall_height',
    'base_thickness',
    'block_half_length',
)
"""The lengths of one segment in docs/spec/model.md §10 (all must be > 0)."""


# -- material (eqs 21-22) ----------------------------------------------------------------------


def yeoh_stress(material, stretch):
    """σ = 2(λ² − λ⁻²)·∂W/∂I1 with W of eq 22 (∂W/∂I1 = C1 + 2C2·x + 3C3·x², x = I1 − 3)."""
    lam = np.asarray(stretch, dtype=float)
    excess = lam**2 + lam**-2 - 2.0
    dw_di1 = material.c1 + 2.0 * material.c2 * excess + 3.0 * material.c3 * excess**2
    return 2.0 * (lam**2 - lam**-2) * dw_di1


# -- cross-section (eqs 12, 27) ----------------------------------------------------------------


def _section(segment):
    r0, t = segment.inner_radius, segment.wall_thickness
    return r0, t, segment.wall_height, segment.base_thickness


def region_first_moment(segment):
    """∫ y dA over the rectangle |x| ≤ R, b ≤ y ≤ b+h plus the half disc of radius R on top."""
    r0, t, h, b = _section(segment)
    outer = r0 + t
    value, _ = dblquad(
        lambda y, x: y,
        -outer,
        outer,
        lambda x: b,
        lambda x: b + h + math.sqrt(max(outer * outer - x * x, 0.0)),
        **{k: v for k, v in QUAD_OPTIONS.items() if k != 'limit'},
    )
    return value


def section_integral(segment, integrand):
    """∫ g(y) dA over eq 27's zones: base (width 2R), side walls (2t), two quarter annuli."""
    r0, t, h, b = _section(segment)
    base, _ = quad(lambda y: integrand(y) * 2.0 * (r0 + t), 0.0, b, **QUAD_OPTIONS)
    walls, _ = quad(lambda y: integrand(y) * 2.0 * t, b, b + h, **QUAD_OPTIONS)
    arch, _ = dblquad(
        lambda phi, r: integrand(b + h + r * math.sin(phi)) * r,
        r0,
        r0 + t,
        0.0,
        0.5 * math.pi,
        epsabs=0.0,
        epsrel=QUAD_OPTIONS['epsrel'],
    )
    return base + walls + 2.0 * arch


def resisting_moment(material, segment, angle):
    """M(q) of eq 27: ∫ σ(λ(y))·y dA with λ(y) = 1 + y·q/ℓ̂."""
    arc = segment.arc_length
    return section_integral(
        segment, lambda y: float(yeoh_stress(material, 1.0 + y * angle / arc)) * y
    )


def section_second_moment(segment):
    """∫ y² dA over the section (the small-angle stiffness is 8·C1·this/ℓ̂)."""
    return section_integral(segment, lambda y: y * y)


def section_height(segment):
    """b + h + r0 + t: the top fibre's height above the inextensible bottom face."""
    r0, t, h, b = _section(segment)
    return b + h + r0 + t


def eq12_pressure_moment(segment):
    """r_p·A_p of eq 12 as printed in the paper (outer radius R = r0 + t)."""
    r0, t, h, b = _section(segment)
    outer = r0 + t
    return 0.5 * math.pi * outer**2 * (4.0 * outer / (3.0 * math.pi) + h + b) + (
        2.0 * outer * (0.5 * h + b) * h
    )


# -- kinematics (eqs 1-4, 32-33) ----------------------------------------------------------------


def exo_digit_points(params, q):
    """Block origins r_0..r_3, block ends, centres r^C_1..3 and normals n_1..3 by eq 4.

    Uses ℓ̂/q with sin/cos exactly as printed (y-row sign corrected), so q_k must not be 0.
    """
    exo = params.exo_digit
    half = [exo.base_block_half_length] + [s.block_half_length for s in exo.segments]
    phi = np.concatenate([[0.0], np.cumsum(q)])
    origins = [np.zeros(2)]
    for i in range(1, 4):
        arc = exo.segments[i - 1].arc_length / q[i - 1]
        c0, s0, c1, s1 = (
            math.cos(phi[i - 1]),
            math.sin(phi[i - 1]),
            math.cos(phi[i]),
            math.sin(phi[i]),
        )
        step = [
            2 * half[i - 1] * c0 - arc * s0 + arc * s1,
            2 * half[i - 1] * s0 + arc * c0 - arc * c1,
        ]
        origins.append(origins[-1] + np.array(step))
    axes = np.array([[math.cos(a), math.sin(a)] for a in phi])
    normals = np.array([[-math.sin(a), math.cos(a)] for a in phi[1:]])
    origins = np.array(origins)
    ends = origins + 2.0 * np.array(half)[:, None] * axes
    centres = origins[1:] + np.array(half[1:])[:, None] * axes[1:]
    return origins, ends, centres, normals


def finger_points(params, q):
    """Finger joints (MCP, PIP, DIP, tip), link centres and link normals, MCP at the origin."""
    half = np.array([j.link_half_length for j in params.finger.joints])
    psi = np.cumsum(q)
    axes = np.column_stack([np.cos(psi), np.sin(psi)])
    joints = np.vstack([np.zeros(2), np.cumsum(2.0 * half[:, None] * axes, axis=0)])
    centres = joints[:3] + half[:, None] * axes
    normals = np.column_stack([-np.sin(psi), np.cos(psi)])
    return joints, centres, normals


def printed_finger_jacobian_transposed(params, q):
    """The paper's printed (J_H*)ᵀ (upper triangular; ℓ_i half link lengths)."""
    l1, l2, l3 = (j.link_half_length for j in params.finger.joints)
    c2, c3, c23 = math.cos(q[1]), math.cos(q[2]), math.cos(q[1] + q[2])
    return np.array(
        [
            [l1, l2 + 2 * l1 * c2, l3 + 2 * l2 * c3 + 2 * l1 * c23],
            [0.0, l2, l3 + 2 * l2 * c3],
            [0.0, 0.0, l3],
        ]
    )


def jacobian_by_differences(centres_of, normals, q, step=JACOBIAN_STEP):
    """J[i, k] = n_i · ∂c_i/∂q_k by central differences of ``centres_of(q)`` (rows c_i)."""
    jacobian = np.zeros((3, 3))
    for k in range(3):
        offset = np.zeros(3)
        offset[k] = step
        slope = (centres_of(q + offset) - centres_of(q - offset)) / (2.0 * step)
        jacobian[:, k] = np.sum(normals * slope, axis=1)
    return jacobian


def robot_contact_jacobian(params, q):
    """J_R* by central differences of eq 4 (every |q_k| well above the step)."""
    normals = exo_digit_points(params, q)[3]
    return jacobian_by_differences(lambda a: exo_digit_points(params, a)[2], normals, q)


SPASTICITY_WIDTH = 0.01
"""w of docs/spec/model.md eq 11.3, rad/s (typed in from the document)."""
EVERY_TERM = {
    'rest_angle': 0.25,
    'rom_torque': 0.004,
    'rom_sharpness': 12.0,
    'damping': 0.003,
    'spasticity': 0.02,
    'extensor_spasticity': 0.005,
    'spasticity_threshold': 0.3,
}
"""A patient joint with every term of docs/spec/model.md (11.1)-(11.3) on (within its range)."""


def finger_torque(params, q, qdot=None, effort=None):
    """τ_H of docs/spec/model.md (11.1)-(11.3), written from the document in numpy (logaddexp)."""
    q = np.asarray(q, dtype=float)
    v = np.zeros(3) if qdot is None else np.asarray(qdot, dtype=float)
    u = np.zeros(3) if effort is None else np.asarray(effort, dtype=float)
    torque = np.zeros(3)
    for i, j in enumerate(params.finger.joints):
        beta, q_r = j.rom_sharpness, j.rest_angle
        stiffening = j.rom_torque * (
            np.exp(beta * (q[i] - j.rom_max)) - np.exp(beta * (q_r - j.rom_max))
        ) - j.rom_torque * (np.exp(beta * (j.rom_min - q[i])) - np.exp(beta * (j.rom_min - q_r)))

        def soft(x, threshold=j.spasticity_threshold):
            return SPASTICITY_WIDTH * np.logaddexp(0.0, (x - threshold) / SPASTICITY_WIDTH)

        spastic = j.extensor_spasticity * (soft(v[i]) - soft(0.0)) - j.spasticity * (
            soft(-v[i]) - soft(0.0)
        )
        torque[i] = j.stiffness * (q[i] - q_r) + stiffening + j.damping * v[i] + spastic - u[i]
    return torque


def coupled_residual(
    params,
    q,
    p,
    qdot=None,
    effort=None,
    *,
    moment=resisting_moment,
    pressure_moments=None,
    robot_jacobian=robot_contact_jacobian,
):
    """F(q, p) of eq 36 / 11.4: τ_s by quadrature, B_R from the region moment, J* from eq 4 and
    the print, τ_H from :func:`finger_torque` at the joint speed ``qdot``.

    ``moment(material, segment, angle)``, ``pressure_moments`` (the three r_p·A_p) and
    ``robot_jacobian(params, q)`` replace the quadratures and eq 4 where a caller evaluates F
    thousands of times (tests/valves_reference.py, which checks its replacements against these).
    """
    segments = params.exo_digit.segments
    torque = np.array([-moment(params.material, s, a) for s, a in zip(segments, q, strict=True)])
    if pressure_moments is None:
        pressure_moments = np.array([region_first_moment(s) for s in segments])
    forces = np.linalg.solve(
        printed_finger_jacobian_transposed(params, q), finger_torque(params, q, qdot, effort)
    )
    return torque + pressure_moments * p - robot_jacobian(params, q).T @ forces


def free_bending(params, joint, pressure):
    """Free-motion angle of one joint: the root of −M(q) + (r_pA_p)·p = 0 (paper §3.3)."""
    segment = params.exo_digit.segments[joint]
    drive = region_first_moment(segment) * pressure
    limit = 2.0 * segment.arc_length / section_height(segment)
    return brentq(
        lambda q: drive - resisting_moment(params.material, segment, q),
        0.0,
        limit,
        xtol=1e-15,
        rtol=1e-15,
    )
