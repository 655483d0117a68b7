"""``exodigit plot``: plots from a rosbag2 (MCAP or SQLite) bag of a glove session.

Reads the bag written by ``python -m exodigit_nodes.nodes.recorder`` (or ``ros2 bag record``) with
the ``rosbags`` library, whatever the namespace: topics are matched by their last name component
(``joint_states``, ``chamber_pressure``, ``pressure_command``, ``contact_forces``,
``estimated_contact_forces``). Writes two figures: angles, pressures and forces against time,
and joint angle against chamber pressure (the ``exodigit curves`` view of a session), where each
chamber pressure is paired with the joint state of its plant step by the times the bag logged
them (:mod:`exodigit_model.stepping.joining`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..extras import ToolError, progress, require
from ..stepping.joining import STALL_TOLERANCE, join_indices

SIGNALS = (
    'joint_states',
    'chamber_pressure',
    'pressure_command',
    'contact_forces',
    'estimated_contact_forces',
)
"""Topics (last name component) read from a bag; each carries one value per joint."""


@dataclass(frozen=True)
class Series:
    """One topic's samples.

    Attributes
    ----------
    topic : str
        Full topic name in the bag.
    time : ndarray, shape (N,)
        Receive time since the start of the bag, s.
    values : ndarray, shape (N, 3)
        Joint values in SI (rad for joint_states positions, Pa, N).
    skipped : int
        Messages without three finite values, left out.
    """

    topic: str
    time: NDArray[np.float64]
    values: NDArray[np.float64]
    skipped: int


def _values(message, signal: str) -> list[float]:
    """The joint values of a message: a state's angles, an estimate's efforts, an array's data.

    Estimates are JointStates stamped with their state (docs/spec/ros.md); older bags hold them
    as arrays.
    """
    if signal == 'joint_states':
        return list(message.position)
    return list(message.effort if hasattr(message, 'effort') else message.data)


def read_bag(path: Path) -> dict[str, Series]:
    """The :data:`SIGNALS` found in the bag at ``path``, keyed by signal name.

    Raises
    ------
    ToolError
        If ``path`` is not a readable rosbag2 folder or holds none of the signals.
    """
    rosbag2 = require('rosbags.rosbag2')
    typesys = require('rosbags.typesys')
    if not (path / 'metadata.yaml').is_file():
        raise ToolError(f'{path}: not a rosbag2 bag folder (no metadata.yaml in it)')
    typestore = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    samples: dict[str, tuple[str, list, list, list]] = {}
    try:
        with rosbag2.Reader(path) as reader:
            chosen = [c for c in reader.connections if c.topic.rsplit('/', 1)[-1] in SIGNALS]
            if not chosen:
                topics = ', '.join(sorted({c.topic for c in reader.connections})) or 'none'
                raise ToolError(
                    f'{path}: none of the glove topics {", ".join(SIGNALS)} (bag has {topics})'
                )
            start = reader.start_time
            total = sum(c.msgcount for c in chosen)
            for connection, stamp, raw in progress(
                reader.messages(connections=chosen), total=total, desc='reading', unit='msg'
            ):
                signal = connection.topic.rsplit('/', 1)[-1]
                _, times, rows, bad = samples.setdefault(signal, (connection.topic, [], [], []))
                values = _values(typestore.deserialize_cdr(raw, connection.msgtype), signal)
                if len(values) == 3 and np.all(np.isfinite(values)):
                    times.append((stamp - start) * 1e-9)
                    rows.append(values)
                else:
                    bad.append(stamp)
    except rosbag2.ReaderError as error:
        reason = ' '.join(str(error).split())
        raise ToolError(f'{path}: cannot read the bag ({reason})') from None
    return {
        signal: Series(topic, np.array(times), np.array(rows).reshape(-1, 3), len(bad))
        for signal, (topic, times, rows, bad) in samples.items()
    }


def step_pairs(series: dict[str, Series]) -> tuple[NDArray, NDArray]:
    """Chamber pressures (Pa) and joint angles (rad) of the same plant steps, shape (K, 3) each.

    Paired by log time with :func:`exodigit_model.stepping.joining.join_indices`: each pressure
    with the first joint state logged after it and before the next pressure (the plant publishes a
    step's pressure first), however long the plant stalled between the two. A sample without its
    partner (the recorder started or stopped between the two, or lost one) is left out, never
    paired with a neighbouring step's.
    """
    pressure, angles = series['chamber_pressure'], series['joint_states']
    partner = join_indices(pressure.time, angles.time, tolerance=STALL_TOLERANCE)
    paired = partner >= 0
    return pressure.values[paired], angles.values[partner[paired]]


def plot_command(path: Path, out: Path) -> None:
    """``exodigit plot``: read the bag, write the figures, print what was found."""
    from .figures import curve_figure, timeseries_figure

    series = read_bag(path)
    lines = {
        'angles': [('joint_states', 'joint_states', '-', np.degrees(1.0))],
        'pressures': [
            ('chamber_pressure', 'chamber_pressure', '-', 1e-3),
            ('pressure_command', 'pressure_command', '--', 1e-3),
        ],
        'forces': [
            ('contact_forces', 'contact_forces', '-', 1.0),
            ('estimated_contact_forces', 'estimated', '--', 1.0),
        ],
    }
    drawn = {
        quantity: [
            (label, series[signal].time, series[signal].values * factor, style)
            for signal, label, style, factor in entries
            if signal in series
        ]
        for quantity, entries in lines.items()
    }
    name = path.resolve().name
    timeseries = out / f'{name}_timeseries.png'
    timeseries_figure(drawn, f'{path}: glove session', timeseries)
    written = [timeseries]
    pressure = angles = np.empty((0, 3))
    if {'joint_states', 'chamber_pressure'} <= series.keys():
        pressure, angles = step_pairs(series)
    if len(pressure):
        curves = out / f'{name}_angle_pressure.png'
        title = f'{path}: joint angle against chamber pressure'
        curve_figure(pressure / 1e3, np.degrees(angles), title, curves)
        written.append(curves)
    for signal in SIGNALS:
        if signal in series:
            found = series[signal]
            note = f', {found.skipped} malformed skipped' if found.skipped else ''
            print(f'{found.topic}: {found.time.size} messages{note}')
        else:
            print(f'{signal}: no messages in the bag')
    print(f'{len(pressure)} plant steps pair chamber_pressure with joint_states')
    print('wrote ' + ', '.join(str(p) for p in written))
