"""``exodigit calibrate``: fit the material, the finger stiffness and/or the layer stiffness.

Samples come from a CSV file (header row; pressures kPa, angles deg, forces N, bottom-face
lengths mm; see :data:`REQUIRED_COLUMNS` and :data:`OPTIONAL_COLUMNS`). What is fitted is named
by ``--fit`` (:data:`FIT_MODES`), a combination of these groups:

- ``stiffness``: the finger's k_H from the ``finger`` samples by the exact linear identification
  :meth:`GloveModel.fit_stiffness` (eq 34 is linear in K_H; the estimator node uses the same
  function), with its standard errors; alone it is the whole fit, combined it is the start.
- ``material``: Yeoh C1, C2, C3.
- ``scale``: one factor s on the Yeoh coefficients of ``--params`` (C_i = s·C_i): the material's
  stiffness with the shape of its stress-stretch curve kept, for data too sparse to fit three
  coefficients.
- ``layer``: E_L = ``layer_axial_stiffness`` (N per unit strain, docs/spec/model.md §12) of every
  segment that has measured lengths, in the bounds 0 ≤ E_L ≤ :data:`LAYER_BOUNDS_N` (0 = no
  layer).

Nonlinear fits are bounded least squares (:func:`scipy.optimize.least_squares`, its own
finite-difference Jacobian) of the model's angles, contact forces and lengths against the
samples, the model rebuilt for every trial. Standard errors come from that Jacobian J at the
solution, cov = s² (JᵀJ)⁻¹ with s² the residual variance. Residuals are angles in degrees,
forces in units of :data:`FORCE_PER_DEGREE` and lengths in units of :data:`LENGTH_PER_DEGREE`.
Ill-posed fits (too few measured values, no excitation, a singular Jacobian) are refused with a
message saying what data is missing.
"""

from __future__ import annotations

import csv
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..extras import ToolError, progress
from ..physics.model import GloveModel
from ..physics.params import JOINT_NAMES, GloveParams, dump_params, load_params, params_from_dict

if TYPE_CHECKING:
    from matplotlib.figure import Figure

PRESSURE_COLUMNS = tuple(f'p_{name}_kpa' for name in JOINT_NAMES)
ANGLE_COLUMNS = tuple(f'q_{name}_deg' for name in JOINT_NAMES)
FORCE_COLUMNS = tuple(f'f_{name}_n' for name in JOINT_NAMES)
LENGTH_COLUMNS = tuple(f'l_{name}_mm' for name in JOINT_NAMES)
REQUIRED_COLUMNS = PRESSURE_COLUMNS + ANGLE_COLUMNS
"""Columns every samples file has; angle cells may be empty (not measured)."""
OPTIONAL_COLUMNS = (*FORCE_COLUMNS, *LENGTH_COLUMNS, 'condition')
"""Columns a samples file may have; empty cells are not measured."""

FIT_MODES = {
    'material': ('material',),
    'scale': ('scale',),
    'stiffness': ('stiffness',),
    'both': ('material', 'stiffness'),
    'layer': ('layer',),
    'layer+material': ('material', 'layer'),
    'layer+scale': ('scale', 'layer'),
}
"""``--fit`` choices and the parameter groups each fits (see the module docstring)."""

FORCE_PER_DEGREE = 0.05
"""Force misfit (N) that weighs as much as 1 degree of angle misfit in the nonlinear fits."""

LENGTH_PER_DEGREE = 1.0
"""Length misfit (mm) that weighs as much as 1 degree of angle misfit in the nonlinear fits."""

MATERIAL_BOUNDS_KPA = (1.0, 1.0e4)
"""Bounds of C1, kPa; C2 and C3 lie in [0, upper] (a Yeoh solid that stiffens monotonically)."""

STIFFNESS_BOUND = 10.0
"""Upper bound of k_H in a nonlinear fit, N·m/rad (lower bound 0)."""

LAYER_BOUNDS_N = (0.0, 1.0e6)
"""Bounds of a fitted E_L, N: 0 is no layer, 1e6 N is inextensible to the solver's digits."""

LAYER_START_N = 100.0
"""Start of a fitted E_L when ``--params`` has it inextensible (.inf), N."""

MAX_CONDITION = 1e8
"""Largest condition number of the column-normalised Jacobian accepted as a well-posed fit."""

RELATIVE_STEP = 1e-6
"""``diff_step`` of least_squares' Jacobian. It steps the fit variable u = 1 + x/x_typ (x in
displayed units, x_typ = :attr:`Parameter.typical`), so the step in x is 1e-6·(x_typ + x):
relative where x is large, and still well above the solver's noise (1e-13 N·m) where x sits on
a bound of 0."""

MAX_ITERATIONS = 30
"""Largest number of least-squares iterations (each costs one model per fitted parameter)."""


@dataclass(frozen=True)
class Samples:
    """Measured samples, SI; NaN where a value was not measured.

    Attributes
    ----------
    pressure : ndarray, shape (N, 3)
        Chamber pressures, Pa.
    angles : ndarray, shape (N, 3)
        Joint angles, rad.
    forces : ndarray, shape (N, 3)
        Contact forces, N (always NaN on free rows).
    lengths : ndarray, shape (N, 3)
        Bottom-face arc lengths ℓ of the soft segments, m (docs/spec/model.md §12).
    free : ndarray of bool, shape (N,)
        True for ``free`` samples (no finger), False for ``finger`` samples.
    columns : tuple of str
        The file's header.
    """

    pressure: NDArray[np.float64]
    angles: NDArray[np.float64]
    forces: NDArray[np.float64]
    lengths: NDArray[np.float64]
    free: NDArray[np.bool_]
    columns: tuple[str, ...] = REQUIRED_COLUMNS

    def measured(self) -> NDArray[np.int_]:
        """Per sample, how many values (angles, forces, lengths) were measured."""
        return sum(
            np.count_nonzero(~np.isnan(values), axis=1)
            for values in (self.angles, self.forces, self.lengths)
        )


def _number(text: str, line: int, column: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ToolError(f'line {line}, column {column}: {text!r} is not a number') from None
    if not math.isfinite(value):
        raise ToolError(f'line {line}, column {column}: {text!r} is not finite')
    return value


def _optional(row: dict, line: int, column: str) -> float:
    """The number in ``column``, NaN for an empty cell (or an absent column)."""
    text = (row.get(column) or '').strip()
    return _number(text, line, column) if text else math.nan


def read_samples(path: str | Path) -> Samples:
    """Read a samples CSV (see :data:`REQUIRED_COLUMNS`, :data:`OPTIONAL_COLUMNS`).

    Raises
    ------
    ToolError
        Naming the line and column of the first bad value, a missing or unknown column, or a
        sample with nothing measured.
    """
    with open(path, newline='', encoding='utf-8-sig') as handle:  # a spreadsheet's BOM is fine
        reader = csv.DictReader(handle)
        header = [name.strip() for name in reader.fieldnames or []]
        missing = [name for name in REQUIRED_COLUMNS if name not in header]
        if missing:
            raise ToolError(f'{path}: missing column(s) {", ".join(missing)}')
        unknown = [name for name in header if name not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
        if unknown:
            raise ToolError(
                f'{path}: unknown column(s) {", ".join(unknown)}; '
                f'known: {", ".join(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)}'
            )
        reader.fieldnames = header
        pressure, angles, forces, lengths, free = [], [], [], [], []
        for line, row in enumerate(reader, start=2):
            pressure.append([_number(row[c], line, c) * 1e3 for c in PRESSURE_COLUMNS])
            angles.append([math.radians(_optional(row, line, c)) for c in ANGLE_COLUMNS])
            condition = (row.get('condition') or 'finger').strip()
            if condition not in ('free', 'finger'):
                raise ToolError(
                    f'line {line}, column condition: {condition!r}, expected free or finger'
                )
            free.append(condition == 'free')
            forces.append(
                [
                    _optional(row, line, c) if condition == 'finger' else math.nan
                    for c in FORCE_COLUMNS
                ]
            )
            lengths.append([_optional(row, line, c) * 1e-3 for c in LENGTH_COLUMNS])
            if all(math.isnan(v) for v in (*angles[-1], *forces[-1], *lengths[-1])):
                raise ToolError(f'line {line}: nothing measured (no angle, force or length)')
    if not pressure:
        raise ToolError(f'{path}: no samples (only a header)')
    samples = Samples(
        np.array(pressure),
        np.array(angles),
        np.array(forces),
        np.array(lengths),
        np.array(free),
        tuple(header),
    )
    if np.any(samples.pressure < 0):
        raise ToolError(f'{path}: pressures must be >= 0 kPa (gauge)')
    if np.any(samples.lengths <= 0):
        raise ToolError(f'{path}: lengths must be > 0 mm')
    return samples


# -- predictions ------------------------------------------------------------------------------


class Prediction(NamedTuple):
    """Model values per sample, SI (angles rad, forces N, lengths m) and convergence."""

    angles: NDArray[np.float64]
    forces: NDArray[np.float64]
    lengths: NDArray[np.float64]
    converged: NDArray[np.bool_]


def predict(model: GloveModel, samples: Samples) -> Prediction:
    """Model angles, contact forces, lengths and convergence per sample (free or on finger).

    Each solve starts from the measured angles and lengths where they were measured.
    """
    angles = np.zeros_like(samples.angles)
    forces = np.zeros_like(samples.angles)
    lengths = np.zeros_like(samples.angles)
    converged = np.ones(samples.free.size, bool)
    rest = np.asarray(model.constants.arc_lengths)
    start_angles = np.nan_to_num(samples.angles, nan=0.0)
    start_lengths = np.where(np.isnan(samples.lengths), rest, samples.lengths)
    for free in (True, False):
        rows = samples.free == free
        if np.any(rows):
            batch = model.solve_batch(
                samples.pressure[rows],
                start_angles[rows],
                free=free,
                lengths0=start_lengths[rows],
            )
            angles[rows], forces[rows] = batch.q, batch.forces
            lengths[rows], converged[rows] = batch.lengths, batch.converged
    return Prediction(angles, forces, lengths, converged)


def _misfits(prediction: Prediction, samples: Samples) -> tuple[NDArray, NDArray, NDArray]:
    """Measured misfits: angles (deg), forces (N), lengths (mm); 1-D, not measured dropped."""
    pairs = (
        (np.degrees(prediction.angles), np.degrees(samples.angles)),
        (prediction.forces, samples.forces),
        (prediction.lengths * 1e3, samples.lengths * 1e3),
    )
    return tuple((model - measured)[~np.isnan(measured)] for model, measured in pairs)


def residuals(model: GloveModel, samples: Samples) -> NDArray[np.float64]:
    """Weighted misfit in degree units: angles (deg), then forces, then lengths.

    Forces are divided by :data:`FORCE_PER_DEGREE` (N), lengths by :data:`LENGTH_PER_DEGREE`
    (mm), so each counts as that many degrees of angle.
    """
    angles, forces, lengths = _misfits(predict(model, samples), samples)
    return np.concatenate([angles, forces / FORCE_PER_DEGREE, lengths / LENGTH_PER_DEGREE])


class Rmse(NamedTuple):
    """Root-mean-square misfits over the measured values (NaN where none was measured)."""

    angle_deg: float
    force_n: float
    length_mm: float


def rmse(model: GloveModel, samples: Samples) -> Rmse:
    """Angle (deg), force (N) and length (mm) RMSE over the measured values."""
    return Rmse(
        *(
            float(np.sqrt(np.mean(misfit**2))) if misfit.size else math.nan
            for misfit in _misfits(predict(model, samples), samples)
        )
    )


# -- parameters -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Parameter:
    """One fitted parameter: its name, how to show it and where it lives in the parameter file."""

    name: str
    unit: str
    scale: float  # SI value = scale * displayed value
    lower: float  # displayed units (all fitted parameters have lower >= 0)
    upper: float
    missing: str  # what data would excite it
    typical: float  # displayed units: the finite-difference step is RELATIVE_STEP * (typical + x)


def material_parameters() -> list[Parameter]:
    """Yeoh C1, C2, C3 in kPa."""
    low, high = MATERIAL_BOUNDS_KPA
    hint = 'samples at several pressures > 0'
    return [
        Parameter('c1', 'kPa', 1e3, low, high, hint, 10.0),
        Parameter('c2', 'kPa', 1e3, 0.0, high, f'{hint} reaching large bending', 10.0),
        Parameter('c3', 'kPa', 1e3, 0.0, high, f'{hint} reaching large bending', 10.0),
    ]


def scale_parameter(params: GloveParams) -> Parameter:
    """The factor s on the Yeoh coefficients of ``params``, bounded as C1 is."""
    low, high = MATERIAL_BOUNDS_KPA
    c1_kpa = params.material.c1 / 1e3
    return Parameter(
        'scale', 'x material', 1.0, low / c1_kpa, high / c1_kpa, 'samples at pressures > 0', 0.1
    )


def stiffness_parameters() -> list[Parameter]:
    """Finger k_H per joint in N·m/rad."""
    return [
        Parameter(
            f'k_{name}',
            'N·m/rad',
            1.0,
            0.0,
            STIFFNESS_BOUND,
            f'finger samples where the {name} joint bends',
            0.01,
        )
        for name in JOINT_NAMES
    ]


def layer_parameters(segments: list[int]) -> list[Parameter]:
    """E_L (``layer_axial_stiffness``) of the given segments (0 = MCP) in N."""
    low, high = LAYER_BOUNDS_N
    return [
        Parameter(
            f'EL_{JOINT_NAMES[k]}',
            'N',
            1.0,
            low,
            high,
            f'{LENGTH_COLUMNS[k]} at pressures > 0',
            10.0,
        )
        for k in segments
    ]


def with_values(params: GloveParams, names: list[str], values_si) -> GloveParams:
    """``params`` with the named fit parameters set to SI values.

    Names are ``c1``..``c3``, ``scale`` (multiplies the Yeoh coefficients of ``params``),
    ``k_mcp``.. (finger stiffness) and ``EL_mcp``.. (``layer_axial_stiffness``).
    """
    data = params.to_dict()
    for name, value in zip(names, values_si, strict=True):
        if name == 'scale':
            for key in ('c1', 'c2', 'c3'):
                data['material'][key] *= float(value)
        elif name.startswith('k_'):
            data['finger']['joints'][JOINT_NAMES.index(name[2:])]['stiffness'] = float(value)
        elif name.startswith('EL_'):
            segment = data['exo_digit']['segments'][JOINT_NAMES.index(name[3:])]
            segment['layer_axial_stiffness'] = float(value)
        else:
            data['material'][name] = float(value)
    return params_from_dict(data)


def current_values(params: GloveParams, names: list[str]) -> NDArray[np.float64]:
    """SI values of the named fit parameters in ``params`` (``scale`` is 1; E_L may be inf)."""
    data = params.to_dict()

    def value(name: str) -> float:
        if name == 'scale':
            return 1.0
        if name.startswith('k_'):
            return data['finger']['joints'][JOINT_NAMES.index(name[2:])]['stiffness']
        if name.startswith('EL_'):
            segment = data['exo_digit']['segments'][JOINT_NAMES.index(name[3:])]
            return segment['layer_axial_stiffness']
        return data['material'][name]

    return np.array([value(name) for name in names], dtype=float)


# -- fits -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FitResult:
    """Outcome of a calibration.

    Attributes
    ----------
    parameters : list of Parameter
        What was fitted.
    before, value, standard_error : ndarray
        Start values (as in ``--params``), fitted values and their standard errors, SI.
    at_bound : ndarray of int
        Per parameter: -1 at its lower bound, 1 at its upper bound, 0 inside.
    params : GloveParams
        The parameters with the fitted values in place.
    rmse_before, rmse_after : Rmse
        Angle (deg), force (N) and length (mm) RMSE with the start and the fitted parameters.
    method : str
        How the fit was made.
    converged : bool
        False if the least-squares iteration stopped at :data:`MAX_ITERATIONS`.
    """

    parameters: list[Parameter]
    before: NDArray[np.float64]
    value: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    at_bound: NDArray[np.int_]
    params: GloveParams
    rmse_before: Rmse
    rmse_after: Rmse
    method: str
    converged: bool = True


def fit_finger_stiffness(model: GloveModel, samples: Samples) -> tuple[NDArray, NDArray]:
    """k_H and standard errors from the finger samples, by :meth:`GloveModel.fit_stiffness`.

    Uses the finger samples whose three angles were measured.
    """
    finger = ~samples.free & np.all(~np.isnan(samples.angles), axis=1)
    if np.count_nonzero(finger) < 2:
        raise ToolError(
            f'stiffness fit needs at least 2 finger samples (condition finger) with the three '
            f'angles measured, got {np.count_nonzero(finger)}'
        )
    try:
        result = model.fit_stiffness(samples.angles[finger], samples.pressure[finger])
    except ValueError as error:
        raise ToolError(f'stiffness fit: {error}; add finger samples that bend it') from None
    return result.stiffness, result.standard_error


def length_segments(samples: Samples, mode: str) -> list[int]:
    """Segments (0 = MCP) with measured lengths; ToolError naming the columns if none."""
    absent = [column for column in LENGTH_COLUMNS if column not in samples.columns]
    if len(absent) == len(LENGTH_COLUMNS):
        raise ToolError(
            f'--fit {mode} needs measured bottom-face lengths (mm): missing column(s) '
            f'{", ".join(absent)}'
        )
    segments = [k for k in range(3) if np.any(~np.isnan(samples.lengths[:, k]))]
    if not segments:
        present = [column for column in LENGTH_COLUMNS if column in samples.columns]
        raise ToolError(
            f'--fit {mode} needs measured bottom-face lengths (mm): column(s) '
            f'{", ".join(present)} have no values'
        )
    return segments


def _check_excitation(samples: Samples, count: int) -> None:
    """Refuse a fit of ``count`` parameters that the measured values cannot determine."""
    measured = samples.measured()
    excited = int(np.sum(measured[np.any(samples.pressure > 0, axis=1)]))
    if excited < count:
        raise ToolError(
            f'fitting {count} parameters needs at least {count} measured values on samples '
            f'with a pressure > 0, got {excited}: add samples at several pressures'
        )
    total = int(np.sum(measured))
    if total < count + 1:
        raise ToolError(
            f'fitting {count} parameters needs at least {count + 1} measured values '
            f'(angles, forces, lengths), got {total}: add samples'
        )


def _standard_errors(jacobian: NDArray, residual: NDArray, parameters) -> NDArray:
    """Standard errors from the Jacobian at the solution; ToolError if it is singular."""
    norms = np.linalg.norm(jacobian, axis=0)
    for parameter, norm in zip(parameters, norms, strict=True):
        if norm == 0.0:
            raise ToolError(f'the data do not depend on {parameter.name}: add {parameter.missing}')
    normalised = jacobian / norms
    _, singular, right = np.linalg.svd(normalised, full_matrices=False)
    condition = singular[0] / singular[-1] if singular[-1] > 0 else math.inf
    if condition > MAX_CONDITION:
        weak = np.abs(right[-1]) > 0.3
        names = ', '.join(p.name for p, w in zip(parameters, weak, strict=True) if w)
        hints = '; '.join(sorted({p.missing for p, w in zip(parameters, weak, strict=True) if w}))
        raise ToolError(
            f'the data cannot separate {names} (Jacobian condition number {condition:.2g}): '
            f'add {hints}'
        )
    dof = residual.size - len(parameters)
    if dof <= 0:
        raise ToolError(
            f'{residual.size} residuals for {len(parameters)} parameters: add more samples'
        )
    variance = float(residual @ residual) / dof
    inverse = np.linalg.inv(normalised.T @ normalised)
    return np.sqrt(variance * np.diag(inverse)) / norms


class NonlinearFit(NamedTuple):
    """Fitted SI values, their standard errors, bound activity (-1, 0, 1) and convergence."""

    value: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    at_bound: NDArray[np.int_]
    converged: bool


def fit_nonlinear(
    params: GloveParams, samples: Samples, parameters: list[Parameter], start: NDArray
) -> NonlinearFit:
    """Bounded least squares of :func:`residuals` over ``parameters`` (SI start values).

    The fit variables are u = 1 + x/x_typ (x in displayed units, see :data:`RELATIVE_STEP`).
    The Jacobian is least_squares' own two-point finite difference (one-sided at a bound); the
    standard errors use the Jacobian it returns at the solution (``result.jac``, chained to x).
    A parameter that ends on a bound is set exactly to it.
    """
    names = [p.name for p in parameters]
    scales = np.array([p.scale for p in parameters])
    typical = np.array([p.typical for p in parameters])
    lower = np.array([p.lower for p in parameters])
    upper = np.array([p.upper for p in parameters])
    bar = progress(desc='calibrate', unit='model')

    def displayed(u: NDArray) -> NDArray:
        return (u - 1.0) * typical

    def misfit(u: NDArray) -> NDArray:
        bar.update()
        model = GloveModel(with_values(params, names, displayed(u) * scales))
        return residuals(model, samples)

    try:
        result = least_squares(
            misfit,
            1.0 + np.clip(start / scales, lower, upper) / typical,
            jac='2-point',
            diff_step=RELATIVE_STEP,
            bounds=(1.0 + lower / typical, 1.0 + upper / typical),
            x_scale='jac',
            max_nfev=MAX_ITERATIONS,
        )
    finally:
        bar.close()
    errors = _standard_errors(result.jac / typical, result.fun, parameters)
    at_bound = np.asarray(result.active_mask, dtype=int)
    x = np.where(at_bound < 0, lower, np.where(at_bound > 0, upper, displayed(result.x)))
    return NonlinearFit(x * scales, errors * scales, at_bound, result.status > 0)


def fit(params: GloveParams, samples: Samples, mode: str) -> FitResult:
    """Calibrate ``params`` to ``samples``; ``mode`` is a key of :data:`FIT_MODES`."""
    if mode not in FIT_MODES:
        raise ToolError(f'--fit {mode}: expected one of {", ".join(FIT_MODES)}')
    groups = FIT_MODES[mode]
    model = GloveModel(params)
    before_rmse = rmse(model, samples)
    converged = True
    if groups == ('stiffness',):
        parameters = stiffness_parameters()
        values, errors = fit_finger_stiffness(model, samples)
        at_bound = np.zeros(len(parameters), int)
        method = 'linear identification of k_H (eq 34) from the finger samples'
    else:
        parameters, start = [], []
        if 'material' in groups:
            parameters += material_parameters()
        if 'scale' in groups:
            parameters.append(scale_parameter(params))
        start = list(current_values(params, [p.name for p in parameters]))
        if 'stiffness' in groups:
            stiffness, _ = fit_finger_stiffness(model, samples)
            parameters += stiffness_parameters()
            start += list(stiffness)
        if 'layer' in groups:
            layers = layer_parameters(length_segments(samples, mode))
            now = current_values(params, [p.name for p in layers])
            parameters += layers
            start += list(np.where(np.isinf(now), LAYER_START_N, now))
        _check_excitation(samples, len(parameters))
        values, errors, at_bound, converged = fit_nonlinear(
            params, samples, parameters, np.array(start)
        )
        method = 'bounded nonlinear least squares on the batch solver'
    names = [p.name for p in parameters]
    fitted = with_values(params, names, values)
    return FitResult(
        parameters=parameters,
        before=current_values(params, names),
        value=values,
        standard_error=errors,
        at_bound=at_bound,
        params=fitted,
        rmse_before=before_rmse,
        rmse_after=rmse(GloveModel(fitted), samples),
        method=method,
        converged=converged,
    )


def report(result: FitResult, samples: Samples) -> list[str]:
    """Lines describing a fit for the terminal."""
    free = int(np.count_nonzero(samples.free))
    lines = [
        f'{result.method}: {samples.free.size} samples ({free} free, '
        f'{samples.free.size - free} on the finger)'
    ]
    poorly, bounded = [], []
    for parameter, before, value, error, bound in zip(
        result.parameters,
        result.before,
        result.value,
        result.standard_error,
        result.at_bound,
        strict=True,
    ):
        scale = parameter.scale
        shown = 0.0 if abs(value / scale) < 1e-9 else value / scale
        lines.append(
            f'  {parameter.name:6s} {before / scale:10.5g} -> {shown:10.5g} '
            f'± {error / scale:.3g} {parameter.unit}'
        )
        if bound:
            side = 'lower' if bound < 0 else 'upper'
            bounded.append(f'{parameter.name} = {shown:g} {parameter.unit} ({side} bound)')
        elif error > abs(value):
            poorly.append(f'{parameter.name} (add {parameter.missing})')
    if any(p.name == 'scale' for p in result.parameters):
        material = result.params.material
        lines.append(
            f'  material: c1 = {material.c1 / 1e3:.5g} kPa, c2 = {material.c2 / 1e3:.5g} kPa, '
            f'c3 = {material.c3 / 1e3:.5g} kPa'
        )
    if bounded:
        lines.append(
            f'note: on a bound of its range (the best fit lies beyond it; the standard error is '
            f'from the slope there): {"; ".join(bounded)}'
        )
    if poorly:
        lines.append(f'note: standard error larger than the value: {"; ".join(poorly)}')
    if not result.converged:
        lines.append(f'note: stopped after {MAX_ITERATIONS} iterations; the fit may not be done')
    units = (('angle', 'deg'), ('force', 'N'), ('length', 'mm'))
    for (what, unit), before, after in zip(
        units, result.rmse_before, result.rmse_after, strict=True
    ):
        if not math.isnan(before):
            lines.append(f'{what} RMSE: {before:.3g} {unit} before, {after:.3g} {unit} after')
    return lines


def _figure_row(
    title: str, unit: str, measured: NDArray, before: NDArray, after: NDArray
) -> list[tuple]:
    """One fit-figure row: a panel per joint (``title`` after the joint's label)."""
    return [
        (f'{name.upper()} {title}', unit, measured[:, k], before[:, k], after[:, k])
        for k, name in enumerate(JOINT_NAMES)
    ]


def write_fit_figure(
    samples: Samples, before: Prediction, after: Prediction, path: Path
) -> Figure:
    """The measured-against-model figure of a fit, written to ``path`` (PNG) and returned.

    One row of panels (one per joint) for each quantity any sample measured: angles (deg),
    forces (N), lengths (mm); each panel the samples' measured values against ``before`` and
    ``after`` (:func:`predict` of the model before and after the fit).
    """
    from .figures import fit_figure

    rows = []
    if not np.all(np.isnan(samples.angles)):
        angles = (samples.angles, before.angles, after.angles)
        rows.append(_figure_row('angle', 'deg', *(np.degrees(a) for a in angles)))
    if not np.all(np.isnan(samples.forces)):
        rows.append(_figure_row('force', 'N', samples.forces, before.forces, after.forces))
    if not np.all(np.isnan(samples.lengths)):
        lengths = (samples.lengths, before.lengths, after.lengths)
        rows.append(_figure_row('length', 'mm', *(1e3 * a for a in lengths)))
    return fit_figure(rows, path)


def calibrate_command(data: str, params_path: str | None, mode: str, out: Path) -> None:
    """``exodigit calibrate``: fit, print the report, write the parameter file and the plot."""
    if out.suffix.lower() not in ('.yaml', '.yml'):
        raise ToolError(f'--out {out}: the parameter file is YAML, name it *.yaml')
    if not out.parent.is_dir():
        raise ToolError(f'--out {out}: folder {out.parent} does not exist')
    samples = read_samples(data)
    params = load_params(params_path)
    result = fit(params, samples, mode)
    for line in report(result, samples):
        print(line)
    dump_params(result.params, out)
    before = predict(GloveModel(params), samples)
    after = predict(GloveModel(result.params), samples)
    if not np.all(after.converged):
        count = np.count_nonzero(~after.converged)
        print(f'warning: {count} samples did not converge after the fit', file=sys.stderr)
    plot = out.with_name(f'{out.stem}_fit.png')
    write_fit_figure(samples, before, after, plot)
    print(f'wrote {out} and {plot}')
