"""The worked example of docs/extensible.md: the Fig. 12 calibration against constant length.

Run from the repository root (about a minute: the sensitivity table refits six times)::

    .venv/bin/python docs/extensible/compare.py

It prints the Markdown tables of docs/extensible.md and writes docs/extensible/comparison.png.
Models compared (docs/spec/model.md §12):

- constant length: the built-in defaults (E_L = .inf, the paper's model);
- E_L = 0 alone: the default material with no layer in the MCP segment (the most elongation
  E_L alone can give);
- calibrated: docs/extensible/fig12_calibrated.yaml, written by
  ``exodigit calibrate docs/fig12_mcp.csv --fit layer+scale``;
- calibrated, all E_L = 0: the same with the PIP and DIP layers also at 0 (the modules are
  moulded alike; the Fig. 12 data say nothing about them).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
from exodigit_model.tools import calibration
from exodigit_model.tools.curves import module_markers
from exodigit_model.tools.figures import PAPER_FIG12

from exodigit_model import GloveModel, load_params, params_from_dict

HERE = Path(__file__).resolve().parent
CALIBRATED = HERE / 'fig12_calibrated.yaml'
SAMPLES = HERE.parent / 'fig12_mcp.csv'
PRESSURES_KPA = np.arange(0.0, 51.0, 10.0)
"""The paper's bench steps, kPa (MCP chamber alone)."""
ASSUMED_FREE_ANGLES_DEG = (55.0, 58.0, 61.0, 64.0, 70.0, 80.0)
"""Free MCP angles at 50 kPa tried in place of the 61° of docs/fig12_mcp.csv."""
TABLE2_SIX_RIDGE_MM = {'free': (2.55, 5.65, 12.11, 10.93), 'finger': (8.79, 9.92, 13.35, 7.56)}
"""The paper's Table 2, six-ridge row: RMSE of markers 3x, 3y, 4x, 4y, model vs experiment."""


def all_layers_zero(path: Path):
    """The parameters of ``path`` with E_L = 0 in every segment."""
    data = load_params(path).to_dict()
    for segment in data['exo_digit']['segments']:
        segment['layer_axial_stiffness'] = 0.0
    return params_from_dict(data)


def models() -> dict[str, GloveModel]:
    """The four models compared, by label."""
    mcp_only = {'exo_digit': {'segments': [{'layer_axial_stiffness': 0.0}, {}, {}]}}
    return {
        'constant length': GloveModel(load_params()),
        'E_L = 0 alone': GloveModel(params_from_dict(mcp_only)),
        'calibrated': GloveModel(load_params(CALIBRATED)),
        'calibrated, all E_L = 0': GloveModel(all_layers_zero(CALIBRATED)),
    }


def mcp_sweep(model: GloveModel) -> dict[str, object]:
    """The MCP chamber alone over PRESSURES_KPA, free and on the finger."""
    pressure = np.zeros((PRESSURES_KPA.size, 3))
    pressure[:, 0] = PRESSURES_KPA * 1e3
    return {
        'free': model.solve_batch(pressure, free=True),
        'finger': model.solve_batch(pressure),
    }


def table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table."""
    lines = [
        '| ' + ' | '.join(header) + ' |',
        '|' + '|'.join('---' for _ in header) + '|',
        *('| ' + ' | '.join(row) + ' |' for row in rows),
    ]
    return '\n'.join(lines)


def mcp_table(sweeps: dict) -> str:
    """Angles, lengths and the MCP contact force per pressure for every model."""
    rows = []
    for label, sweep in sweeps.items():
        free, finger = sweep['free'], sweep['finger']
        for i, kpa in enumerate(PRESSURES_KPA):
            if kpa == 0.0:
                continue
            outside = '' if free.in_valid_range[i] else ' ⚠'
            rows.append(
                [
                    label,
                    f'{kpa:g}',
                    f'{math.degrees(free.q[i, 0]):.1f}{outside}',
                    f'{free.lengths[i, 0] * 1e3:.1f}',
                    f'{math.degrees(finger.q[i, 0]):.1f}',
                    f'{finger.lengths[i, 0] * 1e3:.1f}',
                    f'{finger.forces[i, 0]:.3f}',
                ]
            )
    header = ['model', 'p (kPa)', 'q free (°)', 'ℓ free (mm)', 'q finger (°)']
    return table([*header, 'ℓ finger (mm)', 'f MCP (N)'], rows)


def all_chambers_table(glove: dict[str, GloveModel]) -> str:
    """Every chamber at 50 kPa: free angles, angles and forces on the finger, lengths."""
    rows = []
    for label, model in glove.items():
        free = model.solve(np.full(3, 50e3), free=True)
        finger = model.solve(np.full(3, 50e3))
        outside = '' if free.in_valid_range else ' ⚠'
        rows.append(
            [
                label,
                '/'.join(f'{v:.1f}' for v in np.degrees(free.q)) + outside,
                '/'.join(f'{v:.1f}' for v in np.degrees(finger.q)),
                '/'.join(f'{v:.2f}' for v in finger.forces),
                '/'.join(f'{v * 1e3:.1f}' for v in finger.lengths),
            ]
        )
    header = ['model', 'q free (°)', 'q finger (°)', 'f finger (N)', 'ℓ finger (mm)']
    return table(header, rows)


def marker_table(glove: dict[str, GloveModel], sweeps: dict) -> str:
    """RMS over the sweep of calibrated minus constant-length markers 3, 4, beside Table 2."""
    rows = []
    for condition in ('free', 'finger'):
        markers = {}
        for label in ('constant length', 'calibrated'):
            solution = sweeps[label][condition]
            markers[label] = np.array(
                [
                    module_markers(glove[label], q, 0, lengths)
                    for q, lengths in zip(solution.q, solution.lengths, strict=True)
                ]
            )
        difference = (markers['calibrated'] - markers['constant length']) * 1e3
        rms = np.sqrt(np.mean(difference**2, axis=0))[2:].ravel()
        rows.append([condition, 'calibrated − constant length', *(f'{v:.1f}' for v in rms)])
        rows.append(
            [condition, 'paper Table 2 (model − experiment)']
            + [f'{v:.2f}' for v in TABLE2_SIX_RIDGE_MM[condition]]
        )
    header = ['condition', 'RMS over 0–50 kPa (mm)', 'marker 3 x', 'marker 3 y']
    return table([*header, 'marker 4 x', 'marker 4 y'], rows)


def sensitivity_table() -> str:
    """The layer+scale fit with other assumed free angles in place of 61°."""
    samples = calibration.read_samples(SAMPLES)
    free = int(np.flatnonzero(samples.free)[0])
    rows = []
    for angle in ASSUMED_FREE_ANGLES_DEG:
        angles = samples.angles.copy()
        angles[free, 0] = math.radians(angle)
        trial = dataclasses.replace(samples, angles=angles)
        result = calibration.fit(load_params(), trial, 'layer+scale')
        scale, layer = result.value
        model = GloveModel(result.params)
        finger = model.solve([50e3, 0.0, 0.0])
        rows.append(
            [
                f'{angle:g}',
                f'{scale:.3f}',
                f'{result.params.material.c1 / 1e3:.1f}',
                f'{layer:.2f}' + (' (bound)' if result.at_bound[1] else ''),
                f'{finger.lengths[0] * 1e3:.1f}',
                f'{math.degrees(finger.q[0]):.1f}',
                f'{finger.forces[0]:.3f}',
            ]
        )
    header = ['assumed q free (°)', 'scale', 'C1 (kPa)', 'E_L (N)', 'ℓ finger (mm)']
    return table([*header, 'q finger (°)', 'f MCP (N)'], rows)


def figure(sweeps: dict, path: Path) -> None:
    """MCP angle, length and contact force against pressure for the models, side by side."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    styles = {
        'constant length': {'color': 'tab:gray', 'marker': 'o'},
        'E_L = 0 alone': {'color': 'tab:green', 'marker': 'v', 'alpha': 0.6},
        'calibrated': {'color': 'tab:red', 'marker': 's'},
    }
    figure, axes = plt.subplots(1, 3, figsize=(13.0, 4.2))
    figure.suptitle('MCP module alone: constant length against the Fig. 12 calibration')
    for label, style in styles.items():
        for condition, line in (('free', '--'), ('finger', '-')):
            solution = sweeps[label][condition]
            kw = {**style, 'linestyle': line, 'label': f'{label}, {condition}'}
            axes[0].plot(PRESSURES_KPA, np.degrees(solution.q[:, 0]), **kw)
            axes[1].plot(PRESSURES_KPA, solution.lengths[:, 0] * 1e3, **kw)
        finger = sweeps[label]['finger']
        axes[2].plot(PRESSURES_KPA, finger.forces[:, 0], **style, label=label)
    pressure, length = zip(*PAPER_FIG12, strict=True)
    axes[1].plot(pressure, length, 'k*', markersize=12, label='paper Fig. 12 (finger)')
    axes[0].plot([50.0], [61.0], 'kx', markersize=10, mew=2, label='assumed free angle')
    titles = ('bending angle', 'bottom-face length ℓ', 'contact force on the finger')
    units = ('q MCP (deg)', 'ℓ MCP (mm)', 'f MCP (N)')
    for ax, title, unit in zip(axes, titles, units, strict=True):
        ax.set_title(title)
        ax.set_xlabel('MCP pressure (kPa)')
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize='x-small')
    axes[1].legend(fontsize='x-small')
    axes[2].legend(fontsize='small')
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def main() -> None:
    """Print the tables and write the figure."""
    glove = models()
    sweeps = {label: mcp_sweep(model) for label, model in glove.items()}
    print('## MCP chamber alone (⚠: outside the validated stretch range)\n')
    print(mcp_table({k: v for k, v in sweeps.items() if k != 'calibrated, all E_L = 0'}))
    print('\n## All chambers at 50 kPa (MCP/PIP/DIP)\n')
    print(all_chambers_table(glove))
    print('\n## Markers of the MCP module, calibrated against constant length\n')
    print(marker_table(glove, sweeps))
    print('\n## The fit with other assumed free angles\n')
    print(sensitivity_table())
    figure(sweeps, HERE / 'comparison.png')
    print(f'\nwrote {HERE / "comparison.png"}')


if __name__ == '__main__':
    main()
