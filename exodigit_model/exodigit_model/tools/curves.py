"""``exodigit curves``: the paper's bench experiments (§2.4.2-2.4.4) as simulations.

Each experiment sweeps a pressure and solves the model in two conditions: ``free`` (the
exo-digit alone, no finger, paper §2.4.2 and §3.3) and ``finger`` (strapped to the finger,
§2.4.3). Experiments ``mcp``, ``pip`` and ``dip`` pressurise that module's chamber alone, the
others at 0, as on the paper's bench; ``all`` pressurises the three chambers together.

Markers (paper §3.1, Fig. 8): markers 1 and 2 sit at the proximal and distal ends of the block
before a module's soft segment (the fixed link), markers 3 and 4 at the proximal and distal
ends of the block after it (the moving link). Positions are given in the fixed block's frame:
origin at the start of the soft segment, x along the fixed block, y towards the bending side.

Lengths (docs/spec/model.md §12, the paper's Fig. 12): the bottom-face arc length ℓ of each soft
segment as solved; constant (the rest length) for an inextensible segment, the paper's model.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..extras import ToolError
from ..physics.model import VALID_STRETCH, BatchSolution, GloveModel
from ..physics.params import JOINT_NAMES

EXPERIMENTS = (*JOINT_NAMES, 'all')
"""One experiment per module (that chamber alone) and one with all chambers."""

CONDITIONS = ('free', 'finger')
"""Free bending (no finger) and constrained bending on the finger."""

MAX_PRESSURES = 100_000
"""Longest pressure sweep accepted (a guard against typos such as a step of 0.00001 kPa)."""


@dataclass(frozen=True)
class Sweep:
    """One experiment in one condition.

    Attributes
    ----------
    experiment : str
        ``mcp``, ``pip``, ``dip`` (that chamber alone) or ``all``.
    condition : str
        ``free`` or ``finger``.
    pressure : ndarray, shape (M,)
        The swept pressure, Pa.
    solution : BatchSolution
        Solver output per pressure (angles rad, contact forces N, bottom-face lengths m).
    """

    experiment: str
    condition: str
    pressure: NDArray[np.float64]
    solution: BatchSolution


def parse_pressures(spec: str) -> NDArray[np.float64]:
    """Pressures in Pa from ``START:STOP:STEP`` in kPa (STOP included).

    Raises
    ------
    ToolError
        If the text is not three numbers with 0 <= START <= STOP and STEP > 0.
    """
    parts = spec.split(':')
    try:
        start, stop, step = (float(part) for part in parts)
    except ValueError:
        raise ToolError(
            f'--pressures {spec!r}: expected START:STOP:STEP in kPa, e.g. 0:50:10'
        ) from None
    if not all(math.isfinite(v) for v in (start, stop, step)):
        raise ToolError(f'--pressures {spec!r}: values must be finite')
    if start < 0 or stop < start or step <= 0:
        raise ToolError(f'--pressures {spec!r}: need 0 <= START <= STOP and STEP > 0 (kPa)')
    count = math.floor((stop - start) / step + 1e-9) + 1
    if count > MAX_PRESSURES:
        raise ToolError(f'--pressures {spec!r}: {count} values, more than {MAX_PRESSURES}')
    return (start + step * np.arange(count)) * 1e3


def pressure_rows(experiment: str, pressure: NDArray) -> NDArray[np.float64]:
    """Chamber pressures (M, 3) for ``experiment`` at the swept pressures."""
    rows = np.zeros((pressure.size, 3))
    if experiment == 'all':
        rows[:] = pressure[:, None]
    else:
        rows[:, JOINT_NAMES.index(experiment)] = pressure
    return rows


def simulate(model: GloveModel, pressure: NDArray) -> list[Sweep]:
    """Every experiment in both conditions, with :meth:`GloveModel.solve_batch`."""
    return [
        Sweep(
            experiment,
            condition,
            pressure,
            model.solve_batch(pressure_rows(experiment, pressure), free=condition == 'free'),
        )
        for experiment in EXPERIMENTS
        for condition in CONDITIONS
    ]


def module_markers(
    model: GloveModel, q: NDArray, module: int, lengths: NDArray | None = None
) -> NDArray[np.float64]:
    """Markers 1-4 of module ``module`` (0 = MCP) at angles ``q``, m, shape (4, 2).

    ``lengths`` are the segments' bottom-face lengths ℓ (m; the rest lengths when omitted). In
    the frame of the block before the module's soft segment (see the module docstring).
    """
    pose = model.pose(q, lengths)
    fixed_start, fixed_end = pose.block_origins[module], pose.block_ends[module]
    axis = (fixed_end - fixed_start) / np.linalg.norm(fixed_end - fixed_start)
    normal = np.array([-axis[1], axis[0]])
    points = np.array(
        [fixed_start, fixed_end, pose.block_origins[module + 1], pose.block_ends[module + 1]]
    )
    relative = points - fixed_end
    return np.column_stack([relative @ axis, relative @ normal])


def sweep_markers(model: GloveModel, sweep: Sweep) -> NDArray[np.float64]:
    """Markers of the module of a single-chamber sweep, m, shape (M, 4, 2)."""
    module = JOINT_NAMES.index(sweep.experiment)
    solution = sweep.solution
    return np.array(
        [
            module_markers(model, q, module, lengths)
            for q, lengths in zip(solution.q, solution.lengths, strict=True)
        ]
    )


ANGLE_HEADER = (
    'experiment',
    'condition',
    'pressure_kpa',
    *(f'q_{name}_deg' for name in JOINT_NAMES),
    *(f'f_{name}_n' for name in JOINT_NAMES),
    'converged',
    'in_valid_range',
)
LENGTH_HEADER = (
    'experiment',
    'condition',
    'pressure_kpa',
    *(f'l_{name}_mm' for name in JOINT_NAMES),
    'converged',
)
MARKER_HEADER = (
    'module',
    'condition',
    'pressure_kpa',
    *(f'marker{m}_{axis}_mm' for m in range(1, 5) for axis in 'xy'),
)


def write_angles_csv(sweeps: list[Sweep], path: Path) -> None:
    """Angles (deg) and contact forces (N) of every sweep, one row per pressure."""
    _write_sweeps(
        sweeps,
        path,
        ANGLE_HEADER,
        lambda solution, row: [
            *(f'{v:.9g}' for v in np.degrees(solution.q[row])),
            *(f'{v:.9g}' for v in solution.forces[row]),
            int(solution.converged[row]),
            int(solution.in_valid_range[row]),
        ],
    )


def write_lengths_csv(sweeps: list[Sweep], path: Path) -> None:
    """Bottom-face arc lengths ℓ (mm) of each sweep, a row a pressure (docs/spec/model.md §12)."""
    _write_sweeps(
        sweeps,
        path,
        LENGTH_HEADER,
        lambda solution, row: [
            *(f'{v:.9g}' for v in solution.lengths[row] * 1e3),
            int(solution.converged[row]),
        ],
    )


def _write_sweeps(sweeps: list[Sweep], path: Path, header: tuple, values) -> None:
    """One CSV row per pressure of each sweep: experiment, condition, kPa, then ``values``."""
    with open(path, 'w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        for sweep in sweeps:
            for row in range(sweep.pressure.size):
                writer.writerow(
                    [
                        sweep.experiment,
                        sweep.condition,
                        f'{sweep.pressure[row] / 1e3:.6g}',
                        *values(sweep.solution, row),
                    ]
                )


def write_markers_csv(markers: dict[tuple[str, str], NDArray], pressure, path: Path) -> None:
    """Marker positions (mm) per single-module sweep, one row per pressure."""
    with open(path, 'w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(MARKER_HEADER)
        for (module, condition), points in markers.items():
            for row in range(pressure.size):
                writer.writerow(
                    [
                        module,
                        condition,
                        f'{pressure[row] / 1e3:.6g}',
                        *(f'{v:.9g}' for v in points[row].ravel() * 1e3),
                    ]
                )


def summary(sweeps: list[Sweep]) -> list[str]:
    """Warnings about rows that did not converge or left the model (stretch, range of motion)."""
    lines = []
    low, high = VALID_STRETCH
    for sweep in sweeps:
        failed = int(np.count_nonzero(~sweep.solution.converged))
        outside = int(np.count_nonzero(~sweep.solution.in_valid_range))
        where = f'{sweep.experiment}/{sweep.condition}'
        if failed:
            lines.append(f'warning: {where}: {failed} pressures did not converge')
        if outside:
            lines.append(
                f'warning: {where}: {outside} pressures outside {low:g} <= stretch <= {high:g} '
                '(a joint overstretched or bent backwards)'
            )
        beyond = int(np.count_nonzero(~sweep.solution.in_range_of_motion))
        if beyond and sweep.condition != 'free':
            lines.append(
                f"warning: {where}: {beyond} pressures outside the finger's range of motion"
            )
    return lines
