"""``exodigit calibrate-air``: fit each chamber's valves, dead volume and leak to a recording.

The forward model is the stepper itself (docs/spec/model.md §14, (14.5)): the glove of the
parameters behind valves, run from rest under the recorded openings at :data:`OVERSAMPLE` times
the recording's rate, its chamber pressures compared with the measured ones. Per chamber it
fits C and b of the inlet and of the outlet, the dead volume V_d and the leak G
(:data:`QUANTITIES`, 18 in all) by :func:`scipy.optimize.least_squares` (its own two-point
Jacobian) in the fit variables log10 C, b, log10(V_d + V_c) and G/:data:`LEAK_UNIT`, V_c the
cavity's volume at rest: with the chamber's whole volume as the variable, the valley of the
misfit along which C and the volume trade (the ratio that sets how fast a chamber fills) is
straight. The supply, the temperature, the glove's statics and every start value come from the
parameters (``--params``).

Intervals: the residuals are taken as independent with one variance s² (the sensor's noise),
so cov = s²·(JᵀJ)⁻¹ in the fit variables at the solution, and a 95 % interval is the variable
± 1.96 standard errors, mapped to the value (so not symmetric for C and V_d).

What the recording cannot say is reported (:attr:`AirFit.notes`): C and b of a valve that
never opened are held at their start values (the pressures do not depend on them); a fitted
quantity whose 95 % interval spans the whole range the valve mode is checked in
(:data:`~exodigit_model.physics.pneumatics.VALIDATED_AIR`, docs/valves.md) is unidentified,
with the likely reason where there is one: b of a valve that never came within
:data:`CHOKE_MARGIN` of choking at its fitted b (the flow law then sees b only through the
shape of the subsonic flow), G of a chamber that never held pressure with its valves closed.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..extras import ToolError, progress
from ..physics.model import GloveModel
from ..physics.params import GloveParams, dump_params, load_params
from ..physics.pneumatics import ATMOSPHERIC_PRESSURE, VALIDATED_AIR, volume_coefficients
from ..physics.validity import OutsideModelWarning
from .air_recording import AirRecording, simulated_recording

if TYPE_CHECKING:
    from matplotlib.figure import Figure

QUANTITIES = (
    'inlet_conductance',
    'inlet_critical_ratio',
    'outlet_conductance',
    'outlet_critical_ratio',
    'dead_volume',
    'leak_conductance',
)
"""What is fitted per chamber (keys of its ``pneumatics.chambers`` entry)."""
VALVE_QUANTITIES = tuple(q for q in QUANTITIES if q.startswith(('inlet', 'outlet')))
"""What a valve that never opens leaves unseen (held at the start values)."""
LOGARITHMIC = ('inlet_conductance', 'outlet_conductance', 'dead_volume')
"""Quantities fitted as a log10 (positive, spanning decades)."""
BOUNDS = {
    'inlet_conductance': (1e-12, 1e-7),
    'outlet_conductance': (1e-12, 1e-7),
    'inlet_critical_ratio': (0.0, 0.95),
    'outlet_critical_ratio': (0.0, 0.95),
    'dead_volume': (1e-9, 1e-4),
    'leak_conductance': (0.0, 1e-8),
}
"""Where each quantity is searched (SI): physical limits, far outside any glove's values."""
LEAK_UNIT = 1e-12
"""The leak's fit variable is G in this unit, kg/(s·Pa)."""
UNITS = {
    'inlet_conductance': (1e-8, 'dm^3/(s bar)'),
    'outlet_conductance': (1e-8, 'dm^3/(s bar)'),
    'inlet_critical_ratio': (1.0, ''),
    'outlet_critical_ratio': (1.0, ''),
    'dead_volume': (1e-6, 'cm^3'),
    'leak_conductance': (1e-12, '1e-12 kg/(s Pa)'),
}
"""How each quantity is printed: (SI value of one shown unit, the unit)."""
Z95 = 1.959963984540054
"""The two-sided 95 % quantile of the normal distribution."""
CHOKE_MARGIN = 0.02
"""A valve whose pressure ratio, open, never came within this of its b never choked."""
HOLD_TIME = 0.5
"""A chamber held pressure closed when it held at least :data:`HOLD_PRESSURE` with both
valves closed for this long in all, s."""
HOLD_PRESSURE = 5e3
"""See :data:`HOLD_TIME`, Pa."""
START_PRESSURE = 2e3
"""The forward model starts vented: the first measured pressures must lie within this, Pa."""
OVERSAMPLE = 4
"""Steps of the forward model per recorded step. At the recording's own rate a fast chamber
splits its steps into whole numbers of shorter ones (docs/valves.md, "Where the bound
holds"), numbers that change with the parameters: the pressures jump by up to ~50 Pa where
they do (100 Hz, a small chamber), which finite differences take for slopes. Four times finer
the jumps are below 10 Pa and the stepper's own error about 5 Pa, for four times the cost."""
FIRST = ('inlet_conductance', 'outlet_conductance', 'dead_volume', 'leak_conductance')
"""Fitted first, the critical ratios held at their start values, and then everything from
there: the sizes of valves and chambers and the leaks set most of the pressures' course, and a
fit of all at once from a start far from them can wander off where a critical ratio's slope is
nearly flat (a chamber's outlet b to 0, its misfit a hundred times the noise's)."""
FIRST_TOLERANCE = 1e-4
"""least_squares' ftol and xtol of the first fit (a start for the second)."""
TOLERANCE = 1e-6
"""least_squares' ftol and xtol of the second: the misfit, some 10⁴ times the noise's variance
for a minute's recording, then changes by less than one such variance per iteration, and the
variables by far less than their standard errors."""
LEAK_START = 1e-12
"""A leak starts the fit at least this large, kg/(s·Pa) (the default is 0): least_squares'
trust region moves a variable that sits on its bound only by steps scaled by its distance
from it, and a leak started at 0 stayed there while the other quantities of its chamber bent
to make up for it."""
DIFF_STEP = 1e-4
"""Relative step of least_squares' finite differences."""
MAX_EVALUATIONS = 60
"""Iterations of least_squares at most (forward runs beyond those of its Jacobians)."""


@dataclass(frozen=True)
class AirParameter:
    """One fitted quantity of one chamber: its key and how it is fitted."""

    chamber: int
    name: str
    quantity: str
    offset: float = 0.0
    """Added to the value before its logarithm: the cavity's volume at rest for the dead
    volume (module docstring), else 0."""

    @property
    def key(self) -> str:
        return f'{self.name}.{self.quantity}'

    def variable(self, value: float) -> float:
        """The fit variable of an SI ``value``."""
        if self.quantity in LOGARITHMIC:
            return math.log10(value + self.offset)
        if self.quantity == 'leak_conductance':
            return value / LEAK_UNIT
        return value

    def value(self, variable: float) -> float:
        """The SI value of a fit ``variable``."""
        if self.quantity in LOGARITHMIC:
            return 10.0**variable - self.offset
        if self.quantity == 'leak_conductance':
            return variable * LEAK_UNIT
        return variable

    def bounds(self) -> tuple[float, float]:
        """The fit variable's search bounds (:data:`BOUNDS`)."""
        low, high = BOUNDS[self.quantity]
        return self.variable(low), self.variable(high)


@dataclass(frozen=True)
class AirFit:
    """Outcome of :func:`fit_air` (scipy's convention: ``status``, ``message``).

    Attributes
    ----------
    status : int
        0: least_squares converged; 1: it stopped at its iteration limit (see ``message``).
    message : str
    params : GloveParams
        The start parameters with the identified values in place (what the parameter file
        holds: a quantity held or unidentified keeps its start value), and the supply the fit
        assumed where they left it null.
    parameters : list of AirParameter
        Every quantity of every chamber.
    start, value, lower, upper : ndarray
        Start value, fitted value (the start value for what was held) and 95 % interval (NaN
        for what was held), SI.
    standard_error : ndarray
        The standard error of each fit variable (NaN for what was held): the interval is the
        variable ± 1.96 of it, within the search bounds.
    fitted : ndarray of bool
        Whether the quantity was fitted (else held at its start: a valve that never opened).
    identified : ndarray of bool
        Fitted, and its interval narrower than its checked range.
    notes : list of str
        Why each quantity held or unidentified is so.
    noise : float
        s, the residuals' standard deviation, Pa: the sensor noise if the model fits.
    before, after : ndarray, shape (T, 3)
        The forward model's pressures with the start parameters and with ``params``, Pa.
    angles_after : ndarray, shape (T, 3)
        Its joint angles with ``params``, rad.
    """

    status: int
    message: str
    params: GloveParams
    parameters: list[AirParameter]
    start: NDArray[np.float64]
    value: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    fitted: NDArray[np.bool_]
    identified: NDArray[np.bool_]
    notes: list[str]
    noise: float
    before: NDArray[np.float64]
    after: NDArray[np.float64]
    angles_after: NDArray[np.float64]


def all_parameters(params: GloveParams) -> list[AirParameter]:
    """Every fitted quantity of every chamber, chamber by chamber."""
    cavities = volume_coefficients(GloveModel(params))[:, 1]  # A_c·ℓ̂ of (14.1), m³
    return [
        AirParameter(k, chamber.name, quantity, cavities[k] if quantity == 'dead_volume' else 0.0)
        for k, chamber in enumerate(params.pneumatics.chambers)
        for quantity in QUANTITIES
    ]


def values_of(params: GloveParams, parameters: list[AirParameter]) -> NDArray[np.float64]:
    """The SI values ``params`` give ``parameters``."""
    chambers = params.pneumatics.chambers
    return np.array([getattr(chambers[p.chamber], p.quantity) for p in parameters])


def with_air(params: GloveParams, parameters: list[AirParameter], values) -> GloveParams:
    """``params`` with each parameter's SI value in place (a ParameterError if one is bad)."""
    chambers = list(params.pneumatics.chambers)
    for parameter, value in zip(parameters, values, strict=True):
        chamber = chambers[parameter.chamber]
        chambers[parameter.chamber] = dataclasses.replace(
            chamber, **{parameter.quantity: float(value)}
        )
    pneumatics = dataclasses.replace(params.pneumatics, chambers=tuple(chambers))
    return dataclasses.replace(params, pneumatics=pneumatics)


def simulate(
    params: GloveParams, openings: NDArray, rate_hz: float, supply: float
) -> tuple[NDArray, NDArray]:
    """The forward model's (pressures Pa, angles rad), (T, 3) each, from rest under ``openings``.

    The stepper at :data:`OVERSAMPLE` times the recording's rate, without sensor noise
    (:func:`.air_recording.simulated_recording`). ``supply``: the supply's gauge pressure
    where the parameters leave it open (null), Pa.
    """
    with warnings.catch_warnings():  # trial values may leave the checked box: the fit says so
        warnings.simplefilter('ignore', OutsideModelWarning)
        run = simulated_recording(params, openings, rate_hz, oversample=OVERSAMPLE, supply=supply)
    return run.pressure, run.angles


def _check(recording: AirRecording) -> None:
    if np.abs(recording.pressure[0]).max() > START_PRESSURE:
        first = ', '.join(f'{p / 1e3:.1f}' for p in recording.pressure[0])
        raise ToolError(
            f'{recording.source}: the recording must start vented (first pressures {first} kPa, '
            f'more than {START_PRESSURE / 1e3:g} kPa): the fit steps the glove from rest'
        )


def never_opened(params: GloveParams, recording: AirRecording) -> dict[str, str]:
    """Per key, C and b of each valve the recording never opens: its pressures say nothing."""
    reasons = {}
    for k, chamber in enumerate(params.pneumatics.chambers):
        for side, column in (('inlet', k), ('outlet', 3 + k)):
            if not np.any(recording.openings[:, column] > 0.0):
                for quantity in ('conductance', 'critical_ratio'):
                    reasons[f'{chamber.name}.{side}_{quantity}'] = f'the {side} never opened'
    return reasons


def likely_reasons(params: GloveParams, recording: AirRecording, supply: float) -> dict[str, str]:
    """Per key, what in the recording would leave a quantity unidentified, at ``params``' b.

    b of a valve whose pressure ratio, open, never came within :data:`CHOKE_MARGIN` of b (the
    measured pressures at the start and end of each step it was open); G of a chamber that
    never held pressure closed (:data:`HOLD_TIME`).
    """
    reasons = {}
    absolute = recording.pressure + ATMOSPHERIC_PRESSURE
    pneumatics = params.pneumatics
    gauge = supply if pneumatics.supply_pressure is None else pneumatics.supply_pressure
    closed = np.all(recording.openings == 0.0, axis=1)
    for k, chamber in enumerate(pneumatics.chambers):
        before = np.concatenate([[ATMOSPHERIC_PRESSURE], absolute[:-1, k]])
        for side, column in (('inlet', k), ('outlet', 3 + k)):
            open_rows = recording.openings[:, column] > 0.0
            if not open_rows.any():
                continue
            if side == 'inlet':
                low = np.minimum(before, absolute[:, k])[open_rows]
                ratio = low / (gauge + ATMOSPHERIC_PRESSURE)
            else:
                ratio = ATMOSPHERIC_PRESSURE / np.maximum(before, absolute[:, k])[open_rows]
            critical = getattr(chamber, f'{side}_critical_ratio')
            if ratio.min() > critical + CHOKE_MARGIN:
                reasons[f'{chamber.name}.{side}_critical_ratio'] = (
                    f'the {side} never choked (its lowest pressure ratio open, '
                    f'{ratio.min():.3f}, stayed above b + {CHOKE_MARGIN:g})'
                )
        holding = closed & (recording.pressure[:, k] > HOLD_PRESSURE)
        if np.count_nonzero(holding) / recording.rate_hz < HOLD_TIME:
            reasons[f'{chamber.name}.leak_conductance'] = (
                f'the chamber never held {HOLD_PRESSURE / 1e3:g} kPa with its valves closed for '
                f'{HOLD_TIME:g} s'
            )
    return reasons


def _least_squares(params, parameters, recording, supply, tolerance):
    """least_squares over ``parameters`` from their values in ``params``, to ``tolerance``."""
    measured = recording.pressure
    bar = progress(desc='calibrate-air', unit='run')

    def misfit(variables: NDArray) -> NDArray:
        bar.update()
        values = [p.value(v) for p, v in zip(parameters, variables, strict=True)]
        trial = with_air(params, parameters, values)
        pressure, _ = simulate(trial, recording.openings, recording.rate_hz, supply)
        return ((pressure - measured) / 1e3).ravel()

    values = values_of(params, parameters)
    start = np.array(
        [
            p.variable(max(v, LEAK_START if p.quantity == 'leak_conductance' else v))
            for p, v in zip(parameters, values, strict=True)
        ]
    )
    low, high = np.array([p.bounds() for p in parameters]).T
    try:
        return least_squares(
            misfit,
            np.clip(start, low, high),
            bounds=(low, high),
            diff_step=DIFF_STEP,
            x_scale='jac',
            ftol=tolerance,
            xtol=tolerance,
            max_nfev=MAX_EVALUATIONS,
        )
    finally:
        bar.close()


def _standard_errors(result) -> tuple[NDArray, float]:
    """Standard errors of the fit variables and the residuals' variance s², kPa².

    A variable the residuals do not depend on gets an infinite one; the normal matrix of the
    columns scaled to unit length is inverted by its pseudo-inverse (singular directions: no
    information, not a failure).
    """
    residual, jacobian = result.fun, result.jac
    variance = float(residual @ residual) / max(residual.size - jacobian.shape[1], 1)
    norms = np.linalg.norm(jacobian, axis=0)
    errors = np.full(jacobian.shape[1], math.inf)
    seen = norms > 0.0
    scaled = jacobian[:, seen] / norms[seen]
    inverse = np.linalg.pinv(scaled.T @ scaled, rcond=1e-12, hermitian=True)
    errors[seen] = np.sqrt(variance * np.maximum(np.diag(inverse), 0.0)) / norms[seen]
    return errors, variance


def fit_air(params: GloveParams, recording: AirRecording, supply: float = 100e3) -> AirFit:
    """Fit C, b, V_d and G of each chamber of ``params`` to ``recording`` (module docstring).

    Parameters
    ----------
    params : GloveParams
        The glove, its finger, its supply and temperature, and the start values.
    recording : AirRecording
        Openings applied and pressures measured, from rest (vented).
    supply : float
        The supply's gauge pressure where ``params`` leaves it open (null), Pa.

    Raises
    ------
    ToolError
        If the recording does not start vented, or opens no valve.
    """
    _check(recording)
    everything = all_parameters(params)
    start = values_of(params, everything)
    held = never_opened(params, recording)
    if all(p.key in held for p in everything if p.quantity in VALVE_QUANTITIES):
        raise ToolError(f'{recording.source}: no valve ever opens: the recording says nothing')
    free = [p for p in everything if p.key not in held]
    first = [p for p in free if p.quantity in FIRST]
    result = _least_squares(params, first, recording, supply, FIRST_TOLERANCE)
    values = [p.value(v) for p, v in zip(first, result.x, strict=True)]
    result = _least_squares(with_air(params, first, values), free, recording, supply, TOLERANCE)
    values = [p.value(v) for p, v in zip(free, result.x, strict=True)]
    fitted_params = with_air(params, free, values)
    errors, variance = _standard_errors(result)
    value, standard_error = start.copy(), np.full(start.size, math.nan)
    lower, upper = np.full(start.size, math.nan), np.full(start.size, math.nan)
    for parameter, variable, error in zip(free, result.x, errors, strict=True):
        i = everything.index(parameter)
        low, high = parameter.bounds()
        value[i], standard_error[i] = parameter.value(variable), error
        lower[i] = parameter.value(max(variable - Z95 * error, low))
        upper[i] = parameter.value(min(variable + Z95 * error, high))
    fitted = np.array([p.key not in held for p in everything])
    checked = np.array([VALIDATED_AIR[p.quantity][:2] for p in everything])
    spans = fitted & (lower <= checked[:, 0]) & (upper >= checked[:, 1])
    likely = likely_reasons(fitted_params, recording, supply)
    notes = [f'{key}: held at its start value: {why}' for key, why in held.items()]
    for parameter, unidentified in zip(everything, spans, strict=True):
        if unidentified:
            low, high = VALIDATED_AIR[parameter.quantity][:2]
            why = likely.get(parameter.key, 'the recording constrains it too little')
            notes.append(
                f'{parameter.key}: unidentified, its 95 % interval spans the whole checked '
                f'range {low:g}..{high:g}, kept at its start value: {why}'
            )
    identified = fitted & ~spans
    kept = [p for p, known in zip(everything, identified, strict=True) if known]
    fitted_params = with_air(params, kept, [value[everything.index(p)] for p in kept])
    if params.pneumatics.supply_pressure is None:  # the fit holds for the supply it assumed
        pneumatics = dataclasses.replace(fitted_params.pneumatics, supply_pressure=supply)
        fitted_params = dataclasses.replace(fitted_params, pneumatics=pneumatics)
    after, angles = simulate(fitted_params, recording.openings, recording.rate_hz, supply)
    before, _ = simulate(params, recording.openings, recording.rate_hz, supply)
    return AirFit(
        status=0 if result.status > 0 else 1,
        message=result.message,
        params=fitted_params,
        parameters=everything,
        start=start,
        value=value,
        lower=lower,
        upper=upper,
        standard_error=standard_error,
        fitted=fitted,
        identified=identified,
        notes=notes,
        noise=math.sqrt(variance) * 1e3,
        before=before,
        after=after,
        angles_after=angles,
    )


def report(fit: AirFit, recording: AirRecording) -> list[str]:
    """Lines for the terminal: every value with its 95 % interval, then the notes."""
    lines = [
        f'{recording.source}: {recording.openings.shape[0]} steps at {recording.rate_hz:g} Hz '
        f'({recording.duration:.1f} s); least squares on the valve stepper',
    ]
    for k, parameter in enumerate(fit.parameters):
        scale, unit = UNITS[parameter.quantity]
        shown = f'  {parameter.key:28s} {fit.value[k] / scale:10.4g} {unit:16s}'
        if not fit.fitted[k]:
            lines.append(f'{shown} held (start value)')
            continue
        interval = f'95 % [{fit.lower[k] / scale:.4g}, {fit.upper[k] / scale:.4g}]'
        if not fit.identified[k]:
            interval += f' unidentified: kept at {fit.start[k] / scale:.4g}'
        lines.append(f'{shown} {interval}')
    lines += [f'note: {note}' for note in fit.notes]
    rmse_before = math.sqrt(np.mean((fit.before - recording.pressure) ** 2)) / 1e3
    rmse_after = math.sqrt(np.mean((fit.after - recording.pressure) ** 2)) / 1e3
    lines.append(f'pressure RMSE: {rmse_before:.3g} kPa before, {rmse_after:.3g} kPa after')
    if recording.angles is not None:
        error = fit.angles_after - recording.angles  # NaN at the steps without angles
        angle_rmse = math.degrees(math.sqrt(np.nanmean(error**2)))
        lines.append(
            f'angle RMSE after: {angle_rmse:.3g} deg (the statics are not fitted here: '
            'exodigit calibrate fits them)'
        )
    if fit.status:
        lines.append(f'note: {fit.message}; the fit may not be done')
    return lines


def figure(fit: AirFit, recording: AirRecording, path: Path) -> Figure:
    """Measured against fitted pressures per chamber: pressures, residuals, openings.

    Top: measured (dots), start (dashed) and fitted pressures; middle: measured − fitted,
    which is the sensor's noise where the model fits; bottom: the openings (inlet up, outlet
    down).
    """
    from .figures import JOINT_LABELS, figure_panels, save_figure

    t = np.arange(1, recording.openings.shape[0] + 1) / recording.rate_hz
    panels, axes = figure_panels(
        f'{recording.source}: measured and fitted chamber pressures', 3, 3, (13.0, 8.5)
    )
    for k, label in enumerate(JOINT_LABELS):
        top, middle, bottom = axes[:, k]
        measured = recording.pressure[:, k] / 1e3
        top.plot(t, measured, '.', color='0.6', markersize=2, label='measured')
        top.plot(t, fit.before[:, k] / 1e3, '--', color='tab:blue', linewidth=1, label='start')
        top.plot(t, fit.after[:, k] / 1e3, color='tab:red', linewidth=1, label='fitted')
        top.set_title(label)
        top.set_ylabel('chamber pressure (kPa)')
        middle.plot(t, measured - fit.after[:, k] / 1e3, '.', color='tab:red', markersize=1)
        middle.set_ylabel('measured − fitted (kPa)')
        bottom.plot(t, recording.openings[:, k], color='tab:red', linewidth=1, label='inlet')
        bottom.plot(
            t, -recording.openings[:, 3 + k], color='tab:green', linewidth=1, label='outlet'
        )
        bottom.set_ylabel('opening (inlet +, outlet −)')
        bottom.set_xlabel('time (s)')
    axes[0, 0].legend(fontsize='small')
    axes[2, 0].legend(fontsize='small')
    return save_figure(panels, path)


def calibrate_air_command(
    data: str, params_path: str | None, out: Path, rate_hz: float | None, supply: float
) -> None:
    """``exodigit calibrate-air``: read, fit, print, write the parameter file and the figure."""
    from .air_recording import read_recording

    if out.suffix.lower() not in ('.yaml', '.yml'):
        raise ToolError(f'--out {out}: the parameter file is YAML, name it *.yaml')
    if not (math.isfinite(supply) and supply > 0.0):
        raise ToolError(f'--supply {supply / 1e3!r} kPa: must be a finite pressure > 0')
    if not out.parent.is_dir():
        raise ToolError(f'--out {out}: folder {out.parent} does not exist')
    recording = read_recording(data, rate_hz)
    params = load_params(params_path)
    fit = fit_air(params, recording, supply)
    for line in report(fit, recording):
        print(line)
    dump_params(fit.params, out)
    plot = out.with_name(f'{out.stem}_fit.png')
    figure(fit, recording, plot)
    if fit.status:
        print(f'warning: {fit.message}', file=sys.stderr)
    print(f'wrote {out} (its pneumatics section is the fit) and {plot}')
