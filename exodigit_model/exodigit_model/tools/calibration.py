"""``exodigit calibrate``: fit the Yeoh coefficients and/or the finger stiffness to measurements.

Samples come from a CSV file (header row; pressures kPa, angles deg, forces N; see
:data:`REQUIRED_COLUMNS`). Three fits:

- ``stiffness``: the finger's k_H from the ``finger`` samples by the exact linear identification
  :meth:`GloveModel.fit_stiffness` (eq 34 is linear in K_H; the estimator node uses the same
  function), with its standard errors.
- ``material``: Yeoh C1, C2, C3 by bounded nonlinear least squares
  (:func:`scipy.optimize.least_squares`) of the model's angles (and contact forces, where
  measured) against the samples, the model rebuilt for every trial material.
- ``both``: C1, C2, C3 and k_H together in the same way, started from the linear stiffness.

Standard errors of nonlinear fits come from the Jacobian J at the solution,
cov = s² (JᵀJ)⁻¹ with s² the residual variance. Residuals are angles in degrees and forces in
units of :data:`FORCE_PER_DEGREE`. Ill-posed fits (too few samples, no excitation, a singular
Jacobian) are refused with a message saying what data is missing.
"""

from __future__ import annotations

import csv
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from .. import JOINT_NAMES, GloveModel, GloveParams, dump_params, load_params, params_from_dict
from ._deps import ToolError, progress

PRESSURE_COLUMNS = tuple(f'p_{name}_kpa' for name in JOINT_NAMES)
ANGLE_COLUMNS = tuple(f'q_{name}_deg' for name in JOINT_NAMES)
FORCE_COLUMNS = tuple(f'f_{name}_n' for name in JOINT_NAMES)
REQUIRED_COLUMNS = PRESSURE_COLUMNS + ANGLE_COLUMNS
OPTIONAL_COLUMNS = (*FORCE_COLUMNS, 'condition')

FORCE_PER_DEGREE = 0.05
"""Force misfit (N) that weighs as much as 1 degree of angle misfit in the nonlinear fits."""

MATERIAL_BOUNDS_KPA = (1.0, 1.0e4)
"""Bounds of C1, kPa; C2 and C3 lie in [0, upper] (a Yeoh solid that stiffens monotonically)."""

STIFFNESS_BOUND = 10.0
"""Upper bound of k_H in a nonlinear fit, N·m/rad (lower bound 0)."""

MAX_CONDITION = 1e8
"""Largest condition number of the column-normalised Jacobian accepted as a well-posed fit."""

RELATIVE_STEP = 1e-6
"""Relative finite-difference step of the fit's Jacobian (the solver converges to 1e-13 N·m)."""

MAX_ITERATIONS = 30
"""Largest number of least-squares iterations (each costs one model per fitted parameter)."""


@dataclass(frozen=True)
class Samples:
    """Measured samples, SI.

    Attributes
    ----------
    pressure, angles : ndarray, shape (N, 3)
        Chamber pressures (Pa) and joint angles (rad).
    forces : ndarray, shape (N, 3)
        Contact forces, N; NaN where not measured (always NaN on free rows).
    free : ndarray of bool, shape (N,)
        True for ``free`` samples (no finger), False for ``finger`` samples.
    """

    pressure: NDArray[np.float64]
    angles: NDArray[np.float64]
    forces: NDArray[np.float64]
    free: NDArray[np.bool_]


def _number(text: str, line: int, column: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ToolError(f'line {line}, column {column}: {text!r} is not a number') from None
    if not math.isfinite(value):
        raise ToolError(f'line {line}, column {column}: {text!r} is not finite')
    return value


def read_samples(path: str | Path) -> Samples:
    """Read a samples CSV (see :data:`REQUIRED_COLUMNS`, :data:`OPTIONAL_COLUMNS`).

    Raises
    ------
    ToolError
        Naming the line and column of the first bad value, a missing or unknown column.
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
        pressure, angles, forces, free = [], [], [], []
        for line, row in enumerate(reader, start=2):
            pressure.append([_number(row[c], line, c) * 1e3 for c in PRESSURE_COLUMNS])
            angles.append([math.radians(_number(row[c], line, c)) for c in ANGLE_COLUMNS])
            condition = (row.get('condition') or 'finger').strip()
            if condition not in ('free', 'finger'):
                raise ToolError(
                    f'line {line}, column condition: {condition!r}, expected free or finger'
                )
            free.append(condition == 'free')
            forces.append(
                [
                    _number(row[c], line, c)
                    if condition == 'finger' and (row.get(c) or '').strip()
                    else math.nan
                    for c in FORCE_COLUMNS
                ]
            )
    if not pressure:
        raise ToolError(f'{path}: no samples (only a header)')
    samples = Samples(np.array(pressure), np.array(angles), np.array(forces), np.array(free))
    if np.any(samples.pressure < 0):
        raise ToolError(f'{path}: pressures must be >= 0 kPa (gauge)')
    return samples


# -- predictions ------------------------------------------------------------------------------


def predict(model: GloveModel, samples: Samples) -> tuple[NDArray, NDArray, NDArray]:
    """Model angles (rad), contact forces (N) and convergence per sample (free or on finger)."""
    angles = np.zeros_like(samples.angles)
    forces = np.zeros_like(samples.angles)
    converged = np.ones(samples.free.size, bool)
    for free in (True, False):
        rows = samples.free == free
        if np.any(rows):
            batch = model.solve_batch(samples.pressure[rows], samples.angles[rows], free=free)
            angles[rows], forces[rows], converged[rows] = batch.q, batch.forces, batch.converged
    return angles, forces, converged


def residuals(model: GloveModel, samples: Samples) -> NDArray[np.float64]:
    """Weighted misfit: angles (deg) then measured forces (in :data:`FORCE_PER_DEGREE`)."""
    angles, forces, _ = predict(model, samples)
    measured = ~np.isnan(samples.forces)
    return np.concatenate(
        [
            np.degrees(angles - samples.angles).ravel(),
            (forces - samples.forces)[measured] / FORCE_PER_DEGREE,
        ]
    )


def rmse(model: GloveModel, samples: Samples) -> tuple[float, float]:
    """Angle RMSE (deg) over all samples and force RMSE (N) over measured forces (NaN if none)."""
    angles, forces, _ = predict(model, samples)
    angle_rmse = float(np.sqrt(np.mean(np.degrees(angles - samples.angles) ** 2)))
    measured = ~np.isnan(samples.forces)
    force_rmse = (
        float(np.sqrt(np.mean((forces - samples.forces)[measured] ** 2)))
        if np.any(measured)
        else math.nan
    )
    return angle_rmse, force_rmse


# -- parameters -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Parameter:
    """One fitted parameter: its name, how to show it and where it lives in the parameter file."""

    name: str
    unit: str
    scale: float  # SI value = scale * displayed value
    lower: float  # displayed units
    upper: float
    missing: str  # what data would excite it


def material_parameters() -> list[Parameter]:
    """Yeoh C1, C2, C3 in kPa."""
    low, high = MATERIAL_BOUNDS_KPA
    hint = 'samples at several pressures > 0'
    return [
        Parameter('c1', 'kPa', 1e3, low, high, hint),
        Parameter('c2', 'kPa', 1e3, 0.0, high, f'{hint} reaching large bending'),
        Parameter('c3', 'kPa', 1e3, 0.0, high, f'{hint} reaching large bending'),
    ]


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
        )
        for name in JOINT_NAMES
    ]


def with_values(params: GloveParams, names: list[str], values_si) -> GloveParams:
    """``params`` with the named fit parameters (``c1``.., ``k_mcp``..) set to SI values."""
    data = params.to_dict()
    for name, value in zip(names, values_si, strict=True):
        if name.startswith('k_'):
            data['finger']['joints'][JOINT_NAMES.index(name[2:])]['stiffness'] = float(value)
        else:
            data['material'][name] = float(value)
    return params_from_dict(data)


def current_values(params: GloveParams, names: list[str]) -> NDArray[np.float64]:
    """SI values of the named fit parameters in ``params``."""
    data = params.to_dict()
    return np.array(
        [
            data['finger']['joints'][JOINT_NAMES.index(n[2:])]['stiffness']
            if n.startswith('k_')
            else data['material'][n]
            for n in names
        ]
    )


# -- fits -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FitResult:
    """Outcome of a calibration.

    Attributes
    ----------
    parameters : list of Parameter
        What was fitted.
    before, value, standard_error : ndarray
        Start values, fitted values and their standard errors, SI.
    params : GloveParams
        The parameters with the fitted values in place.
    rmse_before, rmse_after : tuple of float
        (angle RMSE deg, force RMSE N) with the start and the fitted parameters.
    method : str
        How the fit was made.
    """

    parameters: list[Parameter]
    before: NDArray[np.float64]
    value: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    params: GloveParams
    rmse_before: tuple[float, float]
    rmse_after: tuple[float, float]
    method: str


def fit_finger_stiffness(model: GloveModel, samples: Samples) -> tuple[NDArray, NDArray]:
    """k_H and standard errors from the finger samples, by :meth:`GloveModel.fit_stiffness`."""
    finger = ~samples.free
    if np.count_nonzero(finger) < 2:
        raise ToolError(
            f'stiffness fit needs at least 2 finger samples (condition finger), '
            f'got {np.count_nonzero(finger)}'
        )
    try:
        result = model.fit_stiffness(samples.angles[finger], samples.pressure[finger])
    except ValueError as error:
        raise ToolError(f'stiffness fit: {error}; add finger samples that bend it') from None
    return result.stiffness, result.standard_error


def _check_material_excitation(samples: Samples, count: int) -> None:
    excited = np.count_nonzero(np.any(samples.pressure > 0, axis=1))
    if excited < count + 1:
        raise ToolError(
            f'fitting {count} parameters needs at least {count + 1} samples with a pressure '
            f'> 0, got {excited}: add samples at several pressures'
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


def fit_nonlinear(
    params: GloveParams, samples: Samples, parameters: list[Parameter], start: NDArray
) -> tuple[NDArray, NDArray]:
    """Bounded least squares of :func:`residuals` over ``parameters`` (SI start values).

    Returns the fitted SI values and their standard errors.
    """
    names = [p.name for p in parameters]
    scales = np.array([p.scale for p in parameters])
    lower = np.array([p.lower for p in parameters])
    upper = np.array([p.upper for p in parameters])
    cache: dict[bytes, NDArray] = {}
    bar = progress(desc='calibrate', unit='model')

    def misfit(x: NDArray) -> NDArray:
        key = x.tobytes()
        if key not in cache:
            model = GloveModel(with_values(params, names, x * scales))
            cache[key] = residuals(model, samples)
            bar.update()
        return cache[key]

    def jacobian(x: NDArray) -> NDArray:
        base = misfit(x)
        columns = []
        for k in range(x.size):
            step = RELATIVE_STEP * max(abs(x[k]), 1e-3 * (upper[k] - lower[k]))
            shifted = x.copy()
            shifted[k] = x[k] + step if x[k] + step <= upper[k] else x[k] - step
            columns.append((misfit(shifted) - base) / (shifted[k] - x[k]))
        return np.column_stack(columns)

    try:
        result = least_squares(
            misfit,
            np.clip(start / scales, lower, upper),
            jac=jacobian,
            bounds=(lower, upper),
            x_scale='jac',
            max_nfev=MAX_ITERATIONS,
        )
    finally:
        bar.close()
    errors = _standard_errors(jacobian(result.x), misfit(result.x), parameters)
    return result.x * scales, errors * scales


def fit(params: GloveParams, samples: Samples, mode: str) -> FitResult:
    """Calibrate ``params`` to ``samples``; ``mode`` is material, stiffness or both."""
    model = GloveModel(params)
    before_rmse = rmse(model, samples)
    if mode == 'stiffness':
        parameters = stiffness_parameters()
        values, errors = fit_finger_stiffness(model, samples)
        method = 'linear identification of k_H (eq 34) from the finger samples'
    else:
        parameters = material_parameters()
        start = current_values(params, [p.name for p in parameters])
        if mode == 'both':
            stiffness, _ = fit_finger_stiffness(model, samples)
            parameters += stiffness_parameters()
            start = np.concatenate([start, stiffness])
        _check_material_excitation(samples, len(parameters))
        values, errors = fit_nonlinear(params, samples, parameters, start)
        method = 'bounded nonlinear least squares on the batch solver'
    names = [p.name for p in parameters]
    fitted = with_values(params, names, values)
    return FitResult(
        parameters=parameters,
        before=current_values(params, names),
        value=values,
        standard_error=errors,
        params=fitted,
        rmse_before=before_rmse,
        rmse_after=rmse(GloveModel(fitted), samples),
        method=method,
    )


def report(result: FitResult, samples: Samples) -> list[str]:
    """Lines describing a fit for the terminal."""
    free = int(np.count_nonzero(samples.free))
    lines = [
        f'{result.method}: {samples.free.size} samples ({free} free, '
        f'{samples.free.size - free} on the finger)'
    ]
    poorly = []
    for parameter, before, value, error in zip(
        result.parameters, result.before, result.value, result.standard_error, strict=True
    ):
        scale = parameter.scale
        shown = 0.0 if abs(value / scale) < 1e-9 else value / scale
        lines.append(
            f'  {parameter.name:6s} {before / scale:10.5g} -> {shown:10.5g} '
            f'± {error / scale:.3g} {parameter.unit}'
        )
        if error > abs(value):
            poorly.append(f'{parameter.name} (add {parameter.missing})')
    (angle_before, force_before), (angle_after, force_after) = (
        result.rmse_before,
        result.rmse_after,
    )
    if poorly:
        lines.append(f'note: standard error larger than the value: {"; ".join(poorly)}')
    lines.append(f'angle RMSE: {angle_before:.3g} deg before, {angle_after:.3g} deg after')
    if not math.isnan(force_before):
        lines.append(f'force RMSE: {force_before:.3g} N before, {force_after:.3g} N after')
    return lines


def calibrate_command(data: str, params_path: str | None, mode: str, out: Path) -> None:
    """``exodigit calibrate``: fit, print the report, write the parameter file and the plot."""
    from .figures import fit_figure

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
    before_angles, before_forces, _ = predict(GloveModel(params), samples)
    after_angles, after_forces, converged = predict(GloveModel(result.params), samples)
    if not np.all(converged):
        count = np.count_nonzero(~converged)
        print(f'warning: {count} samples did not converge after the fit', file=sys.stderr)
    labels = [name.upper() for name in JOINT_NAMES]
    measured, before, after = (
        np.degrees(a) for a in (samples.angles, before_angles, after_angles)
    )
    rows = [
        [
            (f'{label} angle', 'deg', measured[:, k], before[:, k], after[:, k])
            for k, label in enumerate(labels)
        ]
    ]
    if not np.all(np.isnan(samples.forces)):
        rows.append(
            [
                (
                    f'{label} force',
                    'N',
                    samples.forces[:, k],
                    before_forces[:, k],
                    after_forces[:, k],
                )
                for k, label in enumerate(labels)
            ]
        )
    plot = out.with_name(f'{out.stem}_fit.png')
    fit_figure(rows, plot)
    print(f'wrote {out} and {plot}')
