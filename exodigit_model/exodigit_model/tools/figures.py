"""Figures of the tools, styled like the paper's Figs 8-11 (matplotlib, headless).

Axes are labelled in the interface units: kPa, degrees, mm, N. Each function writes its figure
to a PNG and returns it, closed (its axes, lines and labels stay readable).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..extras import pyplot
from ..physics.params import JOINT_NAMES
from .curves import Sweep

if TYPE_CHECKING:
    from matplotlib.figure import Figure

DPI = 100
"""Resolution of every figure written by the tools."""

JOINT_LABELS = tuple(name.upper() for name in JOINT_NAMES)
CONDITION_STYLE = {
    'free': {'marker': 'o', 'color': 'tab:blue', 'label': 'free (module alone)'},
    'finger': {'marker': 's', 'color': 'tab:red', 'label': 'on finger (module alone)'},
}
ALL_STYLE = {'marker': '^', 'color': 'tab:gray', 'linestyle': '--', 'label': 'on finger (all)'}

PAPER_FIG12 = ((0.0, 46.0), (50.0, 62.2))
"""The paper's Fig. 12: the six-ridge (MCP) module's length on the finger, (kPa, mm)."""


def figure_panels(title: str, ncols: int = 3, nrows: int = 1, size=(12.0, 3.8)):
    """A titled figure of ``nrows`` x ``ncols`` panels (inches ``size``); (figure, axes 2-D)."""
    plt = pyplot()
    figure, axes = plt.subplots(nrows, ncols, figsize=size, squeeze=False)
    figure.suptitle(title)
    for ax in axes.ravel():
        ax.grid(True, alpha=0.3)
    return figure, axes


def save_figure(figure: Figure, path: Path) -> Figure:
    """Lay ``figure`` out, write it to ``path`` as a PNG, close it and return it."""
    figure.tight_layout()
    figure.savefig(path, dpi=DPI)
    pyplot().close(figure)
    return figure


def _find(sweeps: list[Sweep], experiment: str, condition: str) -> Sweep:
    return next(s for s in sweeps if s.experiment == experiment and s.condition == condition)


def angle_figure(sweeps: list[Sweep], path: Path) -> Figure:
    """Joint angle against pressure, one panel per joint (Figs 10A-C and 11A-C)."""
    figure, axes = figure_panels('Bending angle against pressure: free and on the finger')
    for joint, ax in enumerate(axes[0]):
        name = JOINT_NAMES[joint]
        for condition, style in CONDITION_STYLE.items():
            sweep = _find(sweeps, name, condition)
            ax.plot(sweep.pressure / 1e3, np.degrees(sweep.solution.q[:, joint]), **style)
        together = _find(sweeps, 'all', 'finger')
        ax.plot(together.pressure / 1e3, np.degrees(together.solution.q[:, joint]), **ALL_STYLE)
        ax.set_title(f'{JOINT_LABELS[joint]} module')
        ax.set_xlabel('pressure (kPa)')
        ax.set_ylabel(f'q {JOINT_LABELS[joint]} (deg)')
    axes[0, 0].legend(fontsize='small')
    return save_figure(figure, path)


def force_figure(sweeps: list[Sweep], path: Path) -> Figure:
    """Contact force against pressure, one panel per joint (Figs 9 and 11D-F)."""
    figure, axes = figure_panels('Contact force on the finger against pressure')
    for joint, ax in enumerate(axes[0]):
        alone = _find(sweeps, JOINT_NAMES[joint], 'finger')
        together = _find(sweeps, 'all', 'finger')
        ax.plot(alone.pressure / 1e3, alone.solution.forces[:, joint], **CONDITION_STYLE['finger'])
        ax.plot(together.pressure / 1e3, together.solution.forces[:, joint], **ALL_STYLE)
        ax.set_title(f'{JOINT_LABELS[joint]} contact')
        ax.set_xlabel('pressure (kPa)')
        ax.set_ylabel(f'f {JOINT_LABELS[joint]} (N)')
    axes[0, 0].legend(fontsize='small')
    return save_figure(figure, path)


def length_figure(sweeps: list[Sweep], rest_lengths, path: Path) -> Figure:
    """Bottom-face arc length against pressure, one panel per segment (docs/spec/model.md §12).

    Free and on the finger (that module alone) and all chambers on the finger, the rest length
    ``rest_lengths`` (m) dotted, and on the MCP panel the paper's Fig. 12 observation.
    """
    figure, axes = figure_panels('Bottom-face arc length against pressure: free and on the finger')
    for joint, ax in enumerate(axes[0]):
        name = JOINT_NAMES[joint]
        for condition, style in CONDITION_STYLE.items():
            sweep = _find(sweeps, name, condition)
            ax.plot(sweep.pressure / 1e3, sweep.solution.lengths[:, joint] * 1e3, **style)
        together = _find(sweeps, 'all', 'finger')
        ax.plot(together.pressure / 1e3, together.solution.lengths[:, joint] * 1e3, **ALL_STYLE)
        ax.axhline(rest_lengths[joint] * 1e3, color='k', linestyle=':', linewidth=1)
        if joint == 0:
            pressure, length = zip(*PAPER_FIG12, strict=True)
            ax.plot(pressure, length, 'k*', markersize=10, label='paper Fig. 12 (on finger)')
        ax.set_title(f'{JOINT_LABELS[joint]} segment (rest {rest_lengths[joint] * 1e3:g} mm)')
        ax.set_xlabel('pressure (kPa)')
        ax.set_ylabel(f'l {JOINT_LABELS[joint]} (mm)')
    axes[0, 0].legend(fontsize='small')
    return save_figure(figure, path)


def marker_figure(markers: dict, pressure, path: Path) -> Figure:
    """Paths of markers 3 and 4 as the pressure rises, per module (Fig. 8)."""
    figure, axes = figure_panels(
        'Tip markers 3 (circles) and 4 (squares), module frame', size=(12, 4.2)
    )
    for joint, ax in enumerate(axes[0]):
        for condition, style in CONDITION_STYLE.items():
            points = markers[(JOINT_NAMES[joint], condition)] * 1e3
            ax.plot(points[:, 2, 0], points[:, 2, 1], '-o', color=style['color'], label=condition)
            ax.plot(points[:, 3, 0], points[:, 3, 1], '-s', color=style['color'])
            ax.plot(points[0, :2, 0], points[0, :2, 1], 'k-', linewidth=3)
        ax.set_aspect('equal', adjustable='datalim')
        ax.set_title(f'{JOINT_LABELS[joint]} module, {pressure[-1] / 1e3:g} kPa max')
        ax.set_xlabel('x (mm)')
        ax.set_ylabel('y (mm)')
    axes[0, 0].legend(fontsize='small')
    return save_figure(figure, path)


def fit_figure(rows: list, path: Path) -> Figure:
    """Measured against model values, before and after a fit.

    ``rows`` is a list of figure rows, each a list of panels
    ``(title, unit, measured, before, after)`` with 1-D arrays in display units (NaN = skip).
    """
    figure, axes = figure_panels(
        'Calibration: measured against model',
        ncols=max(len(row) for row in rows),
        nrows=len(rows),
        size=(12, 3.8 * len(rows)),
    )
    for row, row_axes in zip(rows, axes, strict=True):
        for (title, unit, measured, before, after), ax in zip(row, row_axes, strict=False):
            shown = ~np.isnan(measured)
            ax.set_title(title)
            if not np.any(shown):
                ax.text(0.5, 0.5, 'not measured', ha='center', transform=ax.transAxes)
                continue
            values = np.concatenate([measured[shown], before[shown], after[shown]])
            low, high = values.min(), values.max()
            ax.plot([low, high], [low, high], 'k-', linewidth=0.8)
            ax.plot(measured[shown], before[shown], 'x', color='tab:gray', label='before')
            ax.plot(measured[shown], after[shown], 'o', color='tab:red', label='fitted')
            ax.set_xlabel(f'measured ({unit})')
            ax.set_ylabel(f'model ({unit})')
    axes[0, 0].legend(fontsize='small')
    return save_figure(figure, path)


def timeseries_figure(series: dict, title: str, path: Path) -> Figure:
    """Angles, pressures and forces against time from a recorded bag.

    ``series`` maps a quantity (``angles``, ``pressures``, ``forces``) to a list of
    ``(label, t_s, values (N, 3), linestyle)`` to draw, values already in deg, kPa or N.
    """
    rows = [
        ('angles', 'joint angle (deg)'),
        ('pressures', 'pressure (kPa)'),
        ('forces', 'contact force (N)'),
    ]
    figure, axes = figure_panels(title, ncols=3, nrows=len(rows), size=(13, 9))
    colors = ('tab:blue', 'tab:orange', 'tab:green')
    for (quantity, ylabel), row in zip(rows, axes, strict=True):
        for joint, ax in enumerate(row):
            for label, time, values, linestyle in series.get(quantity, []):
                ax.plot(time, values[:, joint], linestyle, color=colors[joint], label=label)
            ax.set_title(f'{JOINT_LABELS[joint]}: {quantity}')
            ax.set_xlabel('time (s)')
            ax.set_ylabel(ylabel)
            if series.get(quantity):
                ax.legend(fontsize='small')
            else:
                ax.text(0.5, 0.5, 'not recorded', ha='center', transform=ax.transAxes)
    return save_figure(figure, path)


def curve_figure(pressure_kpa, angle_deg, title: str, path: Path) -> Figure:
    """Joint angle against chamber pressure per joint, from recorded samples (like Fig. 11A-C)."""
    figure, axes = figure_panels(title)
    for joint, ax in enumerate(axes[0]):
        ax.plot(pressure_kpa[:, joint], angle_deg[:, joint], '.', markersize=3, color='tab:red')
        ax.set_title(f'{JOINT_LABELS[joint]}')
        ax.set_xlabel('chamber pressure (kPa)')
        ax.set_ylabel(f'q {JOINT_LABELS[joint]} (deg)')
    return save_figure(figure, path)
