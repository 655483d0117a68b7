"""Recordings of a glove behind valves: the excitation to play, and reading what it recorded.

A recording (:class:`AirRecording`) is one row per plant step: the six openings the step applied
(u_in MCP, PIP, DIP, then u_out, docs/spec/model.md §14) and the chamber pressures measured at
its end, with the joint angles when they were measured. It comes from

- an air-recording CSV (:data:`CSV_COLUMNS`: ``time_s``, the openings ``u_in_mcp`` …
  ``u_out_dip``, ``p_mcp_kpa`` …, optionally ``q_mcp_deg`` …), the format
  ``exodigit air-excitation`` writes and the simplest for a user's own rig to log;
- a rosbag2 bag of a plant with ``actuation:=valves`` (docs/spec/ros.md): each
  ``chamber_pressure`` message with the ``applied_command`` (else ``valve_command``) logged last
  before it, which is the opening its step applied, and the ``joint_states`` of the same step
  (:func:`exodigit_model.stepping.joining.join_indices`).

:func:`excitation` is the sequence of openings that makes a recording identify every
parameter ``exodigit calibrate-air`` fits (docs/calibrate_air.md): fills with the inlets fully
open (choked where the supply allows it), holds (the leak), vents through each outlet, partial
openings and short pulses at several pressures, each chamber in turn and then together.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..extras import ToolError, require
from ..physics.model import GloveModel
from ..physics.params import JOINT_NAMES, load_params
from ..stepping.settings import SimulationSettings
from ..stepping.simulation import GloveSimulation

OPENING_COLUMNS = tuple(f'u_{side}_{name}' for side in ('in', 'out') for name in JOINT_NAMES)
PRESSURE_COLUMNS = tuple(f'p_{name}_kpa' for name in JOINT_NAMES)
ANGLE_COLUMNS = tuple(f'q_{name}_deg' for name in JOINT_NAMES)
CSV_COLUMNS = ('time_s', *OPENING_COLUMNS, *PRESSURE_COLUMNS)
"""Columns every air-recording CSV has (``ANGLE_COLUMNS`` may follow)."""
BAG_TOPICS = ('chamber_pressure', 'applied_command', 'valve_command', 'joint_states')
"""Topics read from a bag (last name component)."""
RATE_TOLERANCE = 0.01
"""Steps of a CSV recording may differ from their median by this share (a constant rate)."""


@dataclass(frozen=True)
class AirRecording:
    """One row per plant step of a glove behind valves (SI).

    Attributes
    ----------
    rate_hz : float
        The plant's step rate.
    openings : ndarray, shape (T, 6)
        The openings step t applied, u_in (MCP, PIP, DIP) then u_out, each in [0, 1].
    pressure : ndarray, shape (T, 3)
        The gauge pressures measured at the end of step t, Pa.
    angles : ndarray, shape (T, 3), or None
        The joint angles measured at the end of step t, rad; NaN for a step whose angles were
        not recorded (None: none were).
    source : str
        Where it came from, for messages.
    """

    rate_hz: float
    openings: NDArray[np.float64]
    pressure: NDArray[np.float64]
    angles: NDArray[np.float64] | None
    source: str

    def __post_init__(self) -> None:
        steps = self.openings.shape[0]
        if self.openings.shape != (steps, 6) or self.pressure.shape != (steps, 3):
            raise ToolError(f'{self.source}: openings (T, 6) and pressures (T, 3) per step')
        if steps < 2:
            raise ToolError(f'{self.source}: {steps} steps recorded, a fit needs a recording')
        if not (np.all(np.isfinite(self.openings)) and np.all(np.isfinite(self.pressure))):
            raise ToolError(f'{self.source}: an opening or pressure is not a finite number')
        if self.openings.min() < 0.0 or self.openings.max() > 1.0:
            raise ToolError(f'{self.source}: openings must lie in [0, 1]')
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0.0):
            raise ToolError(f'{self.source}: step rate {self.rate_hz!r} Hz: must be > 0')

    @property
    def duration(self) -> float:
        """Recorded time, s."""
        return self.openings.shape[0] / self.rate_hz


# -- the excitation --------------------------------------------------------------------------


def _held(openings, seconds: float, rate_hz: float) -> NDArray[np.float64]:
    return np.tile(np.asarray(openings, dtype=float), (max(1, round(seconds * rate_hz)), 1))


def chamber_block(joints, rate_hz: float) -> list[NDArray[np.float64]]:
    """Fill, hold, vent, partial openings and pulses for the chambers ``joints`` at once."""

    def opening(inlet: float, outlet: float) -> NDArray[np.float64]:
        u = np.zeros(6)
        for k in joints:
            u[k], u[3 + k] = inlet, outlet
        return u

    closed = opening(0.0, 0.0)
    blocks = [
        _held(opening(1.0, 0.0), 1.0, rate_hz),  # fill, choked while P ≤ b·P_s
        _held(closed, 2.0, rate_hz),  # hold at the supply: the leak
        _held(opening(0.0, 1.0), 1.5, rate_hz),  # vent, choked while P_atm ≤ b·P
        _held(opening(0.3, 0.0), 1.0, rate_hz),  # partial fill
        _held(closed, 0.5, rate_hz),
        _held(opening(0.0, 0.3), 1.5, rate_hz),  # partial vent
    ]
    for _ in range(4):  # a staircase of pulses: the flow at several pressure ratios
        blocks += [_held(opening(1.0, 0.0), 0.05, rate_hz), _held(closed, 0.3, rate_hz)]
    for _ in range(5):
        blocks += [_held(opening(0.0, 1.0), 0.04, rate_hz), _held(closed, 0.3, rate_hz)]
    blocks.append(_held(opening(0.0, 1.0), 1.0, rate_hz))
    return blocks


def excitation(rate_hz: float = 100.0) -> NDArray[np.float64]:
    """The openings (T, 6) of the identifying sequence at ``rate_hz``, about a minute.

    Vented first (every outlet open, 1 s); then each chamber alone (the others closed, so that
    its flows are seen apart from the others' through the pose) and then all three together:
    a full fill (choked at the start when b·P_s ≥ P_atm), a hold of 2 s at the supply (the
    leak), a full vent (choked at the start when b·P ≥ P_atm), a partial fill and a partial
    vent (u = 0.3), four 50 ms fill pulses and five 40 ms vent pulses with holds between (the
    flows at many pressure ratios), and a last vent.
    """
    if not (math.isfinite(rate_hz) and rate_hz > 0.0):
        raise ToolError(f'rate {rate_hz!r} Hz: must be > 0')
    blocks = [_held([0, 0, 0, 1, 1, 1], 1.0, rate_hz)]
    for joints in ((0,), (1,), (2,), (0, 1, 2)):
        blocks += chamber_block(joints, rate_hz)
    return np.vstack(blocks)


# -- reading and writing ---------------------------------------------------------------------


def write_recording_csv(recording: AirRecording, path: Path) -> None:
    """Write ``recording`` as an air-recording CSV (kPa, degrees; one row per step)."""
    header = list(CSV_COLUMNS)
    if recording.angles is not None:
        header += ANGLE_COLUMNS
    times = np.arange(1, recording.openings.shape[0] + 1) / recording.rate_hz
    with open(path, 'w', newline='', encoding='utf-8') as file:
        writer = csv.writer(file)
        writer.writerow(header)
        for t in range(times.size):
            row = [f'{times[t]:.6f}', *(f'{u:.6g}' for u in recording.openings[t])]
            row += [f'{p / 1e3:.6f}' for p in recording.pressure[t]]
            if recording.angles is not None:
                row += [f'{math.degrees(q):.6f}' for q in recording.angles[t]]
            writer.writerow(row)


def read_recording(path: str | Path, rate_hz: float | None = None) -> AirRecording:
    """An :class:`AirRecording` from an air-recording CSV or a rosbag2 bag folder.

    ``rate_hz``: the plant's step rate for a bag (its messages carry no step time); a CSV's
    comes from its ``time_s`` column.

    Raises
    ------
    ToolError
        One line saying what is wrong: no such file, not a recording, a missing column or
        topic, a number that is not one.
    """
    path = Path(path)
    if path.is_dir():
        return _read_bag(path, 100.0 if rate_hz is None else rate_hz)
    if not path.is_file():
        raise ToolError(f'{path}: no such file or bag folder')
    return _read_csv(path)


def _read_csv(path: Path) -> AirRecording:
    try:
        with open(path, newline='', encoding='utf-8') as file:
            rows = list(csv.reader(file))
    except UnicodeDecodeError:
        raise ToolError(
            f'{path}: not a text CSV file (an air recording, or a bag folder)'
        ) from None
    if not rows:
        raise ToolError(f'{path}: empty file')
    header = [name.strip() for name in rows[0]]
    missing = [name for name in CSV_COLUMNS if name not in header]
    if missing:
        raise ToolError(f'{path}: not an air recording, missing column(s) {", ".join(missing)}')
    with_angles = all(name in header for name in ANGLE_COLUMNS)
    wanted = list(CSV_COLUMNS) + (list(ANGLE_COLUMNS) if with_angles else [])
    index = [header.index(name) for name in wanted]
    values = np.empty((len(rows) - 1, len(wanted)))
    for line, row in enumerate(rows[1:], start=2):
        for j, (column, i) in enumerate(zip(wanted, index, strict=True)):
            try:
                values[line - 2, j] = float(row[i])
                if not math.isfinite(values[line - 2, j]) and column not in ANGLE_COLUMNS:
                    raise ValueError(column)  # only a step's angles may be missing (nan)
            except (ValueError, IndexError):
                cell = row[i] if i < len(row) else ''
                raise ToolError(
                    f'{path}, line {line}, {column}: {cell!r} is not a number'
                ) from None
    if values.shape[0] < 2:
        raise ToolError(f'{path}: {values.shape[0]} steps recorded, a fit needs a recording')
    steps = np.diff(values[:, 0])
    period = float(np.median(steps))
    if period <= 0.0 or np.abs(steps - period).max() > RATE_TOLERANCE * period:
        raise ToolError(f'{path}: time_s must grow by one constant step per row')
    angles = np.radians(values[:, 10:13]) if with_angles else None
    return AirRecording(1.0 / period, values[:, 1:7], values[:, 7:10] * 1e3, angles, str(path))


def _read_bag(path: Path, rate_hz: float) -> AirRecording:
    rosbag2 = require('rosbags.rosbag2')
    typesys = require('rosbags.typesys')
    if not (path / 'metadata.yaml').is_file():
        raise ToolError(f'{path}: not a rosbag2 bag folder (no metadata.yaml in it)')
    typestore = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    found: dict[str, tuple[list, list]] = {}
    try:
        with rosbag2.Reader(path) as reader:
            chosen = [c for c in reader.connections if c.topic.rsplit('/', 1)[-1] in BAG_TOPICS]
            names = {c.topic.rsplit('/', 1)[-1] for c in chosen}
            if 'chamber_pressure' not in names or not names & {'applied_command', 'valve_command'}:
                topics = ', '.join(sorted({c.topic for c in reader.connections})) or 'none'
                raise ToolError(
                    f'{path}: a recording of a glove behind valves needs chamber_pressure and '
                    f'applied_command (or valve_command); the bag has {topics}'
                )
            for connection, stamp, raw in reader.messages(connections=chosen):
                signal = connection.topic.rsplit('/', 1)[-1]
                message = typestore.deserialize_cdr(raw, connection.msgtype)
                values = message.position if signal == 'joint_states' else message.data
                times, rows = found.setdefault(signal, ([], []))
                times.append(stamp)
                rows.append(np.asarray(values, dtype=float))
    except rosbag2.ReaderError as error:
        reason = ' '.join(str(error).split())
        raise ToolError(f'{path}: cannot read the bag ({reason})') from None
    return _paired(found, rate_hz, str(path))


def _series(found, signal: str, width: int, source: str) -> tuple[NDArray, NDArray]:
    times, rows = found[signal]
    keep = [k for k, row in enumerate(rows) if row.shape == (width,) and np.all(np.isfinite(row))]
    if not keep:
        raise ToolError(f'{source}: no {signal} message with {width} finite values')
    return np.asarray(times, dtype=np.int64)[keep], np.array([rows[k] for k in keep])


def _paired(found, rate_hz: float, source: str) -> AirRecording:
    """Each chamber_pressure with the openings applied last before it and its joint state."""
    from ..stepping.joining import STALL_TOLERANCE, join_indices

    command = 'applied_command' if 'applied_command' in found else 'valve_command'
    pressure_time, pressure = _series(found, 'chamber_pressure', 3, source)
    command_time, commands = _series(found, command, 6, source)
    before = np.searchsorted(command_time, pressure_time, side='right') - 1
    if np.all(before < 0):
        raise ToolError(f'{source}: no {command} logged before a chamber_pressure')
    # Before the first command the plant applies its start openings: every outlet open.
    vented = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    openings = np.where(before[:, None] >= 0, commands[np.maximum(before, 0)], vented)
    angles = None
    if 'joint_states' in found:
        angle_time, positions = _series(found, 'joint_states', 3, source)
        partner = join_indices(pressure_time * 1e-9, angle_time * 1e-9, tolerance=STALL_TOLERANCE)
        if np.any(partner >= 0):
            angles = np.where(partner[:, None] >= 0, positions[np.maximum(partner, 0)], np.nan)
    return AirRecording(rate_hz, openings, pressure, angles, source)


RECORDING_OVERSAMPLE = 8
"""Steps per recorded step of a simulated recording: finer than calibrate-air's forward model
(:data:`.air_calibration.OVERSAMPLE`), so that it is not the fit's own model that made it."""


def simulated_recording(
    params,
    openings: NDArray[np.float64],
    rate_hz: float,
    *,
    oversample: int = RECORDING_OVERSAMPLE,
    supply: float = 100e3,
    pressure_noise: float = 0.0,
    angle_noise: float = 0.0,
    seed: int = 0,
) -> AirRecording:
    """The recording the simulated glove of ``params`` makes of ``openings`` (T, 6), from rest.

    Each row is held over 1/``rate_hz`` s, stepped ``oversample`` times at ``oversample`` times
    the rate (finer than the recording: the stepper's own error and the jumps of its whole
    numbers of split steps shrink with the step, docs/valves.md). At each row's end, the
    pressures and angles the sensors of :class:`~exodigit_model.SimulationSettings` measure
    (Gaussian noise of ``pressure_noise`` Pa and ``angle_noise`` rad, seeded by ``seed``;
    without noise the glove's own). ``supply``: the supply's gauge pressure where ``params``
    leaves it open, Pa.
    """
    settings = SimulationSettings(
        rate_hz=rate_hz * oversample,
        max_supply_pressure=supply,
        pressure_noise_std=pressure_noise,
        angle_noise_std=angle_noise,
        seed=seed,
    )
    simulation = GloveSimulation(GloveModel(params), settings, actuation='valves')
    openings = np.asarray(openings, dtype=float)
    run = simulation.run(np.repeat(openings, oversample, axis=0))
    ends = slice(oversample - 1, None, oversample)
    source = f'simulated ({pressure_noise / 1e3:g} kPa noise, seed {seed})'
    return AirRecording(
        rate_hz, openings, run.pressure_measured[ends], run.q_measured[ends], source
    )


def write_openings_csv(openings: NDArray[np.float64], rate_hz: float, path: Path) -> None:
    """Write the openings (T, 6) to play, one row per step: ``time_s`` (its end), u_in, u_out."""
    with open(path, 'w', newline='', encoding='utf-8') as file:
        writer = csv.writer(file)
        writer.writerow(['time_s', *OPENING_COLUMNS])
        for t, row in enumerate(openings, start=1):
            writer.writerow([f'{t / rate_hz:.6f}', *(f'{u:.6g}' for u in row)])


def excitation_command(
    out: Path,
    rate_hz: float,
    *,
    params_path: str | None,
    simulate: bool,
    supply: float,
    pressure_noise: float,
    angle_noise: float,
    seed: int,
) -> None:
    """``exodigit air-excitation``: write the openings, or the simulated recording of them."""
    if out.suffix.lower() != '.csv':
        raise ToolError(f'--out {out}: the sequence is a CSV file, name it *.csv')
    if not out.parent.is_dir():
        raise ToolError(f'--out {out}: folder {out.parent} does not exist')
    for name, value in (('--pressure-noise', pressure_noise), ('--angle-noise', angle_noise)):
        if not (math.isfinite(value) and value >= 0.0):
            raise ToolError(f'{name} {value!r}: must be finite and >= 0')
    if not (math.isfinite(supply) and supply > 0.0):
        raise ToolError(f'--supply {supply / 1e3!r} kPa: must be a finite pressure > 0')
    openings = excitation(rate_hz)
    if not simulate:
        write_openings_csv(openings, rate_hz, out)
        print(
            f'wrote {out}: {len(openings)} steps at {rate_hz:g} Hz '
            f'({len(openings) / rate_hz:.1f} s)'
        )
        return
    recording = simulated_recording(
        load_params(params_path),
        openings,
        rate_hz,
        supply=supply,
        pressure_noise=pressure_noise,
        angle_noise=angle_noise,
        seed=seed,
    )
    write_recording_csv(recording, out)
    print(
        f'wrote {out}: the simulated recording, {len(openings)} steps at {rate_hz:g} Hz, '
        f'pressure noise {pressure_noise / 1e3:g} kPa, seed {seed}'
    )
