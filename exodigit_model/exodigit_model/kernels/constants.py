"""What the kernels know of one glove: its parameters as flat arrays (SI), built once.

:class:`GloveConstants` is a named tuple of small arrays, the one argument every kernel takes for
the glove and the finger; :func:`exodigit_model.physics.model.glove_constants` builds it from
validated parameters. The patient's joint laws are the rows of :attr:`GloveConstants.laws`, whose
columns are named by the ``LAW_*`` indices below (docs/spec/model.md §11).

From Python the kernels are called with the same constants packed into one array
(:func:`pack`), which the entry kernels :func:`unpack` into views: numba takes a named tuple of
fourteen arrays apart at every call from Python (about 3 µs), one array in about 0.3 µs.

A batch of gloves on a population of patients shares the exo-digit's constants and gives each
glove its own finger: rows of ``finger_half_lengths`` (N, 3) and of ``laws`` (N, 3,
LAW_COLUMNS), which :func:`with_finger` puts in place of the packed finger's, one glove at a
time (docs/spec/model.md §13, "A population").
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .jit import kernel

U_MIN = -0.6
"""Lowest tabulated top-fibre strain (λ_top = 0.4)."""
U_MAX = 1.6
"""Highest tabulated top-fibre strain (λ_top = 2.6)."""
PIECES = 44
"""Number of equal pieces of the table in u."""
DEGREE = 9
"""Polynomial degree of each piece."""
PIECE_WIDTH = (U_MAX - U_MIN) / PIECES
"""Width of one piece in u."""

LAW_PARAMETERS = (
    'stiffness',
    'rest_angle',
    'rom_torque',
    'rom_sharpness',
    'rom_min',
    'rom_max',
    'damping',
    'spasticity',
    'extensor_spasticity',
    'spasticity_threshold',
)
"""The first columns of GloveConstants.laws: the finger joint's parameter of that name."""
# Columns of GloveConstants.laws (one row per joint; eqs 11.1-11.3).
LAW_STIFFNESS = 0  # k, N·m/rad
LAW_REST_ANGLE = 1  # q_r, rad
LAW_ROM_TORQUE = 2  # a, N·m
LAW_ROM_SHARPNESS = 3  # β, 1/rad
LAW_ROM_MIN = 4  # q_min, rad
LAW_ROM_MAX = 5  # q_max, rad
LAW_DAMPING = 6  # c, N·m·s/rad
LAW_SPASTICITY = 7  # g_f, N·m·s/rad
LAW_EXTENSOR_SPASTICITY = 8  # g_e, N·m·s/rad
LAW_SPASTICITY_THRESHOLD = 9  # v_t, rad/s
LAW_UPPER_AT_REST = 10  # exp(β (q_r − q_max)): zeroes e(q_r)
LAW_LOWER_AT_REST = 11  # exp(β (q_min − q_r))
LAW_SPASTIC_AT_ZERO = 12  # S(0) of eq 11.3: zeroes s(0)
LAW_COLUMNS = 13


class GloveConstants(NamedTuple):
    """The glove's and the finger's constants, SI (joint order MCP, PIP, DIP).

    Attributes
    ----------
    arc_lengths : ndarray, shape (3,)
        ℓ̂_k, rest arc lengths of the segments' bottom faces, m.
    block_half_lengths : ndarray, shape (4,)
        d_0..d_3, half lengths of the base block and the three blocks, m.
    finger_half_lengths : ndarray, shape (3,)
        Half lengths of the finger links, m.
    pressure_moments : ndarray, shape (3,)
        (r_p A_p)_k of eq 12, m³ (the diagonal of B_R).
    pressure_areas : ndarray, shape (3,)
        A_p,k of (12.3), m².
    layer_stiffness : ndarray, shape (3,)
        E_L,k, N (``inf``: inextensible).
    extensible_segments : ndarray, shape (3,)
        1.0 where segment k's bottom face stretches (a finite E_L,k), else 0.0.
    extensible : bool
        Whether any does: six unknowns (q, ε) instead of three.
    strain_per_angle : ndarray, shape (3,)
        H_k / ℓ̂_k: the top fibre's strain per radian of bending.
    table : ndarray, shape (3, DEGREE + 1, PIECES)
        τ_s tables: per joint, the monomial coefficients of G(u) = M(q)/q per piece
        (:mod:`.structural`).
    heights, weights : ndarray, shape (3, K)
        Quadrature of each cross-section: fibre heights y (m) and area weights (m²).
    material : ndarray, shape (3,)
        Yeoh C1, C2, C3, Pa.
    laws : ndarray, shape (3, LAW_COLUMNS)
        The patient's joint laws, columns ``LAW_*``.
    """

    arc_lengths: np.ndarray
    block_half_lengths: np.ndarray
    finger_half_lengths: np.ndarray
    pressure_moments: np.ndarray
    pressure_areas: np.ndarray
    layer_stiffness: np.ndarray
    extensible_segments: np.ndarray
    extensible: bool
    strain_per_angle: np.ndarray
    table: np.ndarray
    heights: np.ndarray
    weights: np.ndarray
    material: np.ndarray
    laws: np.ndarray


QUADRATURE_POINTS = 44
"""Points of each cross-section's quadrature (:class:`..section.SectionQuadrature`)."""
_SHAPES = (
    (3,),
    (4,),
    (3,),
    (3,),
    (3,),
    (3,),
    (3,),
    (),
    (3,),
    (3, DEGREE + 1, PIECES),
    (3, QUADRATURE_POINTS),
    (3, QUADRATURE_POINTS),
    (3,),
    (3, LAW_COLUMNS),
)
"""The shape of each field of GloveConstants, in order (``extensible`` is one number)."""
_SIZES = tuple(int(np.prod(shape)) for shape in _SHAPES)
_ENDS = tuple(int(end) for end in np.cumsum(_SIZES))
PACKED_SIZE = _ENDS[-1]
"""Length of a packed GloveConstants."""
(
    _ARCS,
    _BLOCKS,
    _LINKS,
    _MOMENTS,
    _AREAS,
    _LAYERS,
    _EXTENSIBLE_SEGMENTS,
    _EXTENSIBLE,
    _STRAIN,
    _TABLE,
    _HEIGHTS,
    _WEIGHTS,
    _MATERIAL,
    _LAWS,
) = (end - size for end, size in zip(_ENDS, _SIZES, strict=True))


def pack(glove: GloveConstants) -> np.ndarray:
    """``glove`` as one float array of PACKED_SIZE (what the entry kernels take)."""
    fields = [np.asarray(value, dtype=float).ravel() for value in glove]
    for name, value, size in zip(GloveConstants._fields, fields, _SIZES, strict=True):
        if value.size != size:
            raise ValueError(f'GloveConstants.{name} has {value.size} numbers, not {size}')
    return np.concatenate(fields)


@kernel(forceinline=True)
def unpack(packed):
    """The GloveConstants whose fields are views of ``packed`` (:func:`pack`).

    Counted (:func:`.jit.kernel`): the entry kernels that call it release the views it returns.
    """
    return GloveConstants(
        packed[_ARCS:_BLOCKS],
        packed[_BLOCKS:_LINKS],
        packed[_LINKS:_MOMENTS],
        packed[_MOMENTS:_AREAS],
        packed[_AREAS:_LAYERS],
        packed[_LAYERS:_EXTENSIBLE_SEGMENTS],
        packed[_EXTENSIBLE_SEGMENTS:_EXTENSIBLE],
        packed[_EXTENSIBLE] != 0.0,
        packed[_STRAIN:_TABLE],
        packed[_TABLE:_HEIGHTS].reshape((3, DEGREE + 1, PIECES)),
        packed[_HEIGHTS:_WEIGHTS].reshape((3, QUADRATURE_POINTS)),
        packed[_WEIGHTS:_MATERIAL].reshape((3, QUADRATURE_POINTS)),
        packed[_MATERIAL:_LAWS],
        packed[_LAWS:].reshape((3, LAW_COLUMNS)),
    )


@kernel(counted=False, forceinline=True)
def with_finger(glove, finger_half_lengths, laws):
    """``glove`` on another finger: its link half lengths (3,), m, and laws (3, LAW_COLUMNS).

    The laws are the constants of the patient's torque τ_H, eqs (11.1)-(11.3); the other
    fields are ``glove``'s own (views, nothing copied): the exo-digit is the same. Counts no
    references, so only a kernel that counts none either may call it (:func:`.jit.kernel`).
    """
    return GloveConstants(
        glove.arc_lengths,
        glove.block_half_lengths,
        finger_half_lengths,
        glove.pressure_moments,
        glove.pressure_areas,
        glove.layer_stiffness,
        glove.extensible_segments,
        glove.extensible,
        glove.strain_per_angle,
        glove.table,
        glove.heights,
        glove.weights,
        glove.material,
        laws,
    )
