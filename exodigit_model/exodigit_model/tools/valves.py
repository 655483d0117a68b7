"""``exodigit valves``: one glove behind regulators and behind valves, for the same targets.

The built-in ``staircase`` mode's pressure targets (``pressure_command``'s defaults: 10 kPa
stairs of 2 s up to 50 kPa and down; no limiter, so both gloves get exactly the same targets)
drive two noise-free gloves at 100 Hz: one behind pressure regulators (docs/spec/model.md §13:
each chamber lags its target with T = 50 ms), one behind valves (§14) whose openings the
:class:`~exodigit_model.control.ValveLoop` makes from the targets and the measured pressures,
as ``pressure_command`` does with ``output:=valves``. docs/valves.md shows the figure and what
it means for a controller.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..control import MODE_DEFAULTS, Staircase, ValveLoop, ValveLoopSettings
from ..physics.model import GloveModel
from ..stepping.settings import SimulationSettings
from ..stepping.simulation import GloveSimulation
from .figures import JOINT_LABELS, figure_panels, save_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

STAIRCASE = MODE_DEFAULTS['staircase']
"""The staircase mode's parameters (``pressure_command``'s defaults)."""


@dataclass(frozen=True)
class Comparison:
    """Both gloves' runs, step by step (SI; arrays with a leading axis of steps).

    Attributes
    ----------
    t : ndarray, (T,)
        t_k, s (the state after each step).
    target : ndarray, (T, 3)
        The pressure targets that drove each step, Pa.
    regulator_pressure, valve_pressure : ndarray, (T, 3)
        Chamber pressures behind regulators and behind valves, Pa.
    regulator_q, valve_q : ndarray, (T, 3)
        Joint angles, rad.
    openings : ndarray, (T, 6)
        The valve glove's openings: inlets MCP, PIP, DIP, then outlets.
    mass, volume : ndarray, (T, 3)
        The valve glove's air masses (kg) and chamber volumes (m³).
    inflow : ndarray, (3,)
        Air the valve glove's chambers took from the supply, kg: the rises of their air mass
        while an inlet was open (the outlets are closed then, by the loop's rule).
    """

    t: NDArray[np.float64]
    target: NDArray[np.float64]
    regulator_pressure: NDArray[np.float64]
    valve_pressure: NDArray[np.float64]
    regulator_q: NDArray[np.float64]
    valve_q: NDArray[np.float64]
    openings: NDArray[np.float64]
    mass: NDArray[np.float64]
    volume: NDArray[np.float64]
    inflow: NDArray[np.float64]


def staircase_targets(steps: int, settings: SimulationSettings) -> NDArray[np.float64]:
    """The staircase mode's targets of ``steps`` steps, Pa, (steps, 3): step k's at t_k."""
    staircase = Staircase(
        STAIRCASE['staircase_step'], STAIRCASE['staircase_peak'], STAIRCASE['step_duration']
    )
    period = settings.period
    return np.array([staircase.desired(k * period, None, period) for k in range(steps)])


def compare(
    model: GloveModel,
    targets: NDArray[np.float64],
    settings: SimulationSettings | None = None,
    loop: ValveLoopSettings | None = None,
) -> Comparison:
    """Run ``targets`` (Pa, (T, 3)) on a regulator glove and on a valve glove of ``model``."""
    settings = SimulationSettings() if settings is None else settings
    regulator = GloveSimulation(model, settings).run(targets)
    valves = GloveSimulation(model, settings, actuation='valves')
    controller = ValveLoop(ValveLoopSettings() if loop is None else loop)
    state, rows = valves.state, []
    for target in targets:
        opened = controller.openings(target, state.pressure_measured, valves.period)
        before = state.mass
        state = valves.step(opened)
        rows.append(
            (state.t, state.pressure, state.q, state.command, state.mass, state.volume, before)
        )
    t, pressure, q, openings, mass, volume, before = (
        np.array(column) for column in zip(*rows, strict=True)
    )
    inflow = np.where(openings[:, :3] > 0.0, mass - before, 0.0).sum(axis=0)
    return Comparison(
        t, targets, regulator.pressure, pressure, regulator.q, q, openings, mass, volume, inflow
    )


def figure(comparison: Comparison, path: Path) -> Figure:
    """Pressures, angles and openings against time, one column per joint, written to ``path``."""
    c = comparison
    figure, axes = figure_panels(
        'The same staircase of pressure targets behind regulators and behind valves',
        3,
        3,
        (12.0, 8.0),
    )
    for joint, label in enumerate(JOINT_LABELS):
        top, middle, bottom = axes[:, joint]
        top.plot(c.t, c.target[:, joint] / 1e3, 'k--', linewidth=1, label='target')
        top.plot(c.t, c.regulator_pressure[:, joint] / 1e3, color='tab:blue', label='regulator')
        top.plot(c.t, c.valve_pressure[:, joint] / 1e3, color='tab:orange', label='valves')
        top.set_title(label)
        top.set_ylabel('chamber pressure (kPa)')
        middle.plot(c.t, np.degrees(c.regulator_q[:, joint]), color='tab:blue', label='regulator')
        middle.plot(c.t, np.degrees(c.valve_q[:, joint]), color='tab:orange', label='valves')
        middle.set_ylabel('joint angle (deg)')
        bottom.plot(c.t, c.openings[:, joint], color='tab:red', linewidth=1, label='inlet')
        bottom.plot(c.t, -c.openings[:, 3 + joint], color='tab:green', linewidth=1, label='outlet')
        bottom.set_ylabel('opening (inlet +, outlet −)')
        bottom.set_ylim(-1.05, 1.05)
        bottom.set_xlabel('time (s)')
    for ax in axes[:, 0]:
        ax.legend(fontsize='small')
    return save_figure(figure, path)


def stair_overshoot(pressure: NDArray[np.float64], target: NDArray[np.float64]) -> float:
    """The largest overshoot past a stair, Pa (0 when never past).

    Past a new level in the direction of the change: above it after a rise, below it after a
    fall. ``pressure`` and ``target`` (T, k) per step.
    """
    changes = np.flatnonzero(np.any(target[1:] != target[:-1], axis=-1)) + 1
    bounds = [*changes, len(target)]
    worst = 0.0
    for start, stop in itertools.pairwise(bounds):
        direction = np.sign(target[start] - target[start - 1])
        past = direction * (pressure[start:stop] - target[start:stop])
        worst = max(worst, float(past.max()))
    return worst


def summary(comparison: Comparison, tolerance: float = 1e3) -> list[str]:
    """Per joint, as printed lines: settling, overshoot, the valves' switches and air.

    Settling: steps until a glove first comes within ``tolerance`` Pa of the first stair.
    Overshoot: :func:`stair_overshoot`. Switches: a valve opening or closing.
    """
    c, lines = comparison, []
    first = np.flatnonzero(c.target[:, 0] > 0.0)[0]
    level = c.target[first]
    gloves = (c.regulator_pressure, c.valve_pressure)
    for joint, label in enumerate(JOINT_LABELS):
        settle = []
        for pressure in gloves:
            near = np.abs(pressure[first:, joint] - level[joint]) <= tolerance
            settle.append((np.argmax(near) + 1) * (c.t[1] - c.t[0]) * 1e3)
        overshoot = [
            stair_overshoot(pressure[:, [joint]], c.target[:, [joint]]) / 1e3
            for pressure in gloves
        ]
        opened = c.openings[:, [joint, 3 + joint]] > 0.0
        switches = int(np.count_nonzero(opened[1:] != opened[:-1]))
        lines.append(
            f'{label}: within {tolerance / 1e3:g} kPa of the first stair after '
            f'{settle[0]:.0f} ms (regulator) / {settle[1]:.0f} ms (valves); largest '
            f'overshoot {overshoot[0]:.2f} / {overshoot[1]:.2f} kPa; valve switches '
            f'{switches}; supply air {c.inflow[joint] * 1e6:.1f} mg'
        )
    return lines
