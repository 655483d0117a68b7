"""The run record of a glove session: a CSV of the published signals and a PNG plot of them.

The CSV is written row by row while the glove runs (nothing is held in memory, nothing is lost
when a run is long); the plot is drawn from the CSV at the end. Columns are named after
`exodigit_nodes.runner.summary.SIGNALS` with their unit (``time_s``, ``p_cmd_mcp_kpa``,
``q_pip_deg``, ``f_est_dip_n`` …); a value not received yet is an empty cell.
"""

import csv
from datetime import datetime
from pathlib import Path

import numpy as np

from exodigit_nodes.runner.summary import JOINT_LABELS, SIGNALS, Sample

CSV_NAME = 'signals.csv'
PLOT_NAME = 'signals.png'
LOG_DIR_NAME = 'logs'
BAG_DIR_NAME = 'bag'
#: Rows kept for the plot of a long run (evenly spaced); the CSV keeps them all.
MAX_PLOT_POINTS = 20_000
#: Significant digits written to the CSV (well below the model's solver tolerance).
CSV_DIGITS = 12
#: Line styles of the constant references (nominal, patient) beside an identified signal.
REFERENCE_STYLES = (':', '-.')


def csv_columns() -> list[str]:
    """The CSV header: ``time_s`` then three columns per signal."""
    return ['time_s'] + [column for signal in SIGNALS.values() for column in signal.columns()]


def new_run_directory(base: Path, now: datetime | None = None) -> Path:
    """A fresh ``base/<YYYYmmdd-HHMMSS>`` directory (a suffix is added if that exists)."""
    stamp = (now or datetime.now()).strftime('%Y%m%d-%H%M%S')
    for attempt in range(1000):
        candidate = base / (stamp if attempt == 0 else f'{stamp}-{attempt}')
        try:
            candidate.mkdir(parents=True)
        except FileExistsError:
            continue
        return candidate
    raise FileExistsError(f'{base}: no free run directory name for {stamp}')


class RunRecord:
    """Writes a session's samples to ``directory/signals.csv``; `plot` draws them.

    Parameters
    ----------
    directory : pathlib.Path
        Run directory; created if missing. Existing record files in it are replaced.
    """

    def __init__(self, directory: Path) -> None:
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        self.csv_path = directory / CSV_NAME
        self.plot_path = directory / PLOT_NAME
        self.rows = 0
        self._file = open(self.csv_path, 'w', newline='')  # noqa: SIM115 (closed in close())
        self._writer = csv.writer(self._file)
        self._writer.writerow(csv_columns())

    def write(self, sample: Sample) -> None:
        """Append one sample as a CSV row (display units)."""
        row = [_number(sample.time)]
        for topic, signal in SIGNALS.items():
            values = sample.values[topic]
            if values is None:
                row.extend([''] * len(JOINT_LABELS))
            else:
                row.extend(_number(signal.scale * v) for v in values)
        self._writer.writerow(row)
        self.rows += 1

    def flush(self) -> None:
        """Push written rows to disk (call about once a second)."""
        self._file.flush()

    def close(self) -> None:
        """Close the CSV file."""
        self._file.close()

    def plot(self, references=None) -> Path | None:
        """Draw the recorded signals to ``signals.png``; None when there is no row to draw."""
        table = read_csv(self.csv_path)
        if len(table['time_s']) == 0:
            return None
        save_plot(table, self.plot_path, references)
        return self.plot_path


def _number(value: float) -> str:
    return f'{value:.{CSV_DIGITS}g}'


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a run-record CSV into one float array per column (empty cells become NaN)."""
    with open(path, newline='') as file:
        reader = csv.reader(file)
        header = next(reader)
        rows = [[float(cell) if cell else np.nan for cell in row] for row in reader]
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    return {name: data[:, i] for i, name in enumerate(header)}


def save_plot(table: dict[str, np.ndarray], path: Path, references=None) -> None:
    """Plot pressures, angles, forces and the identified patient against time to ``path``.

    One panel per quantity, one colour per joint; commanded pressure and estimated force are
    dashed beside the chamber pressure and simulated force they are compared with; the
    identified stiffness and rest angle beside constant ``references`` (per topic: label ->
    SI values, as `GloveSignals.references`), so the plot shows the identification converging.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    keep = slice(None, None, max(1, len(table['time_s']) // MAX_PLOT_POINTS))
    time = table['time_s'][keep]
    panels = [
        ('pressure (kPa)', [('chamber_pressure', '-'), ('pressure_command', '--')]),
        ('joint angle (deg)', [('joint_states', '-')]),
        ('contact force (N)', [('contact_forces', '-'), ('estimated_contact_forces', '--')]),
        ('finger stiffness (N·m/rad)', [('estimated_finger_stiffness', '-')]),
        ('finger rest angle (deg)', [('estimated_rest_angle', '-')]),
    ]
    figure = Figure(figsize=(9, 12), layout='constrained')
    FigureCanvasAgg(figure)
    axes = figure.subplots(len(panels), 1, sharex=True)
    for ax, (ylabel, curves) in zip(axes, panels, strict=True):
        for topic, style in curves:
            signal = SIGNALS[topic]
            for colour, joint, column in zip('bgr', JOINT_LABELS, signal.columns(), strict=True):
                ax.plot(
                    time, table[column][keep], style, color=colour, label=f'{joint} {signal.label}'
                )
            if np.isnan(table[signal.columns()[0]]).all():
                ax.text(0.5, 0.5, f'no {topic} received', transform=ax.transAxes, ha='center')
            rows = (references or {}).get(topic, {})
            for style_ref, (label, values) in zip(REFERENCE_STYLES, rows.items(), strict=False):
                for colour, joint, value in zip('bgr', JOINT_LABELS, values, strict=True):
                    ax.axhline(
                        signal.scale * value,
                        linestyle=style_ref,
                        color=colour,
                        linewidth=1,
                        label=f'{joint} {label}',
                    )
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(loc='upper right', fontsize='small', ncols=3)
    axes[-1].set_xlabel('time (s)')
    figure.suptitle('exodigit glove run')
    figure.savefig(path, dpi=100)
