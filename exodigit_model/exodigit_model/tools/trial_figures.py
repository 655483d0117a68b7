"""The figures of a trial's report (matplotlib on Agg, from the ``tools`` extra).

Axes are in the tools' interface units: degrees, kPa, N, s (docs/trials.md, "Report").
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..physics.params import JOINT_NAMES
from ..trials.trial import PatientRecord, TrialResult
from .figures import figure_panels, save_figure

JOINT_LABELS = tuple(name.upper() for name in JOINT_NAMES)
DEGREES = math.degrees(1.0)

DISTRIBUTIONS = (
    ('peak_force_n', 'peak contact force, worst joint (N)', 1.0),
    ('time_over_force_s', 'time above the force limit (s)', 1.0),
    ('overall_tracking_rmse_rad', 'tracking RMSE, all joints (deg)', DEGREES),
    ('rom_fraction', "range of motion / the target's, worst joint", 1.0),
    ('functional_rom_fraction', 'share of the functional range, worst joint', 1.0),
    ('peak_pressure_pa', 'peak chamber pressure, highest (kPa)', 1e-3),
)
"""The histograms: column, axis label (interface units), factor from SI to them."""


def _title(result: TrialResult) -> str:
    spec = result.spec
    return (
        f'{spec.patients:,} patients of {spec.population}, {spec.protocol} '
        f'{result.metrics.duration:g} s, {spec.controller.kind} {spec.controller.name}'
    )


def distribution_figure(result: TrialResult, path: Path) -> None:
    """Histograms over the patients of the main metrics; the force limit marked."""
    figure, axes = figure_panels(f'Metric distributions: {_title(result)}', 3, 2, (12.0, 6.5))
    limit = result.metrics.settings.force_limit
    for ax, (column, label, factor) in zip(axes.ravel(), DISTRIBUTIONS, strict=True):
        values = result.metrics.column(column) * factor
        ax.hist(values, bins=min(40, max(5, len(values) // 5)), color='tab:blue', alpha=0.8)
        if column == 'peak_force_n':
            ax.axvline(limit, color='tab:red', linestyle='--', label=f'force limit {limit:g} N')
            ax.legend(fontsize='small')
        ax.set_xlabel(label)
        ax.set_ylabel('patients')
    save_figure(figure, path)


def time_series_figure(record: PatientRecord, result: TrialResult, path: Path) -> None:
    """One patient's session: angles and targets, pressures and commands, contact forces."""
    figure, axes = figure_panels(f'Patient {record.patient}: {_title(result)}', 3, 3, (12.0, 8.0))
    limit = result.metrics.settings.force_limit
    for joint, label in enumerate(JOINT_LABELS):
        top, middle, bottom = axes[:, joint]
        top.plot(record.t, record.q[:, joint] * DEGREES, color='tab:blue', label='angle')
        top.plot(record.t, record.target[:, joint] * DEGREES, 'k--', linewidth=1, label='target')
        top.set_title(label)
        top.set_ylabel('joint angle (deg)')
        middle.plot(record.t, record.pressure[:, joint] / 1e3, color='tab:orange', label='chamber')
        middle.plot(
            record.t, record.command[:, joint] / 1e3, color='gray', linewidth=1, label='command'
        )
        middle.set_ylabel('pressure (kPa)')
        bottom.plot(record.t, record.forces[:, joint], color='tab:green', label='contact force')
        bottom.axhline(limit, color='tab:red', linestyle='--', label='force limit')
        bottom.axhline(-limit, color='tab:red', linestyle='--')
        bottom.set_ylabel('contact force (N)')
        bottom.set_xlabel('time (s)')
    for ax in axes[:, 0]:
        ax.legend(fontsize='small')
    save_figure(figure, path)


def rom_figure(result: TrialResult, path: Path) -> None:
    """Range of motion reached per joint (box plots) against the target's and the functional."""
    figure, axes = figure_panels(f'Range of motion reached\n{_title(result)}', 1, 1, (8.0, 5.0))
    ax = axes[0, 0]
    values = result.metrics.values
    positions = np.arange(1, 4)
    ax.boxplot(values['rom_rad'] * DEGREES, positions=positions, widths=0.5)
    low, high = (np.array(ends) for ends in result.metrics.settings.functional_rom)
    target = values['target_rom_rad'].max(axis=0) * DEGREES
    ax.scatter(positions, target, marker='_', s=900, color='k', label="target's range")
    ax.scatter(
        positions,
        (high - low) * DEGREES,
        marker='_',
        s=900,
        color='tab:green',
        label='functional range (Bain et al. 2015)',
    )
    ax.set_xticks(positions, JOINT_LABELS)
    ax.set_ylabel('range of motion reached (deg)')
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize='small', loc='center')
    save_figure(figure, path)
