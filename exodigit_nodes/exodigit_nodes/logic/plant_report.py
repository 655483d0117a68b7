"""The plant's /diagnostics report of its latest step (docs/spec/ros.md, "Nodes and topics")."""

from __future__ import annotations

from dataclasses import dataclass

from exodigit_model.physics.model import state_warnings
from exodigit_model.stepping.chambers import Saturation

from exodigit_model import JOINT_NAMES, GloveState

from .watchdog import Watchdog


@dataclass(frozen=True)
class PlantReport:
    """:func:`plant_report`'s result.

    ``problems`` (each a reason for WARN), ``notes`` (no reason for WARN) and the ``values``
    shown beside them (the plant node adds its simulated time's).
    """

    problems: list[str]
    notes: list[str]
    values: dict[str, str]


def plant_report(
    state: GloveState,
    watchdog: Watchdog,
    now: float,
    *,
    cycles: int,
    late_cycles: int,
    failures: int,
    new_failures: int,
    failure_residual: float,
    saturation: Saturation,
) -> PlantReport:
    """The report of ``state`` at ``now`` (s, the plant's time) with the watchdog's view.

    The plant's counters since it started: ``cycles`` steps, ``late_cycles`` wall-clock steps
    that came late (its ``LATE_FACTOR``), ``failures`` solves that did not converge (of them
    ``new_failures`` since the last report, the latest with residual ``failure_residual``, N·m),
    and the commands clipped to the supply range (``saturation``).
    """
    problems = []
    if watchdog.tripped:
        problems.append(f'watchdog: no command for {watchdog.age(now):.2f} s, vented')
    if new_failures:
        problems.append(
            f'solver did not converge {new_failures} times '
            f'(last residual {failure_residual:.3g} N·m), kept the last good state'
        )
    problems += state_warnings(True, state.in_valid_range, state.in_range_of_motion)
    if state.saturated:
        problems.append('command saturated to the supply range')
    tension = [name for name, f in zip(JOINT_NAMES, state.forces, strict=True) if f < 0.0]
    notes = [f'contact in tension at {", ".join(tension)} (the strap pulls)'] if tension else []
    if watchdog.tripped:
        command = 'venting'
    else:
        command = 'waiting for a command' if watchdog.last_feed is None else 'ok'
    values = {
        'joint angles (rad)': str(state.q.tolist()),
        'chamber pressure (Pa)': str(state.pressure.tolist()),
        'solver iterations': str(state.iterations),
        'solver residual (N·m)': f'{state.residual:.3g}',
        'solver failures': str(failures),
        'in valid range': str(bool(state.in_valid_range)),
        'in range of motion': str(bool(state.in_range_of_motion)),
        'contact forces (N)': str(state.forces.tolist()),
        'contacts in tension': ', '.join(tension) or 'none',
        'patient effort (N·m)': str(state.effort.tolist()),
        'watchdog': command,
        'command age (s)': f'{watchdog.age(now):.3f}',
        'watchdog trips': str(watchdog.trips),
        'saturated below 0': str(saturation.below_zero),
        'saturated above supply': str(saturation.above_supply),
        'cycles': str(cycles),
        'late cycles': str(late_cycles),
    }
    if state.mass is not None:  # valves (docs/spec/model.md §14): the air in each chamber
        values['valve openings (in, then out)'] = str(state.command.tolist())
        values['air mass (kg)'] = str(state.mass.tolist())
        values['chamber volume (m³)'] = str(state.volume.tolist())
    return PlantReport(problems, notes, values)
