"""The plant's run-time settings from its parameter values: plain Python, unit-testable."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from exodigit_model import SimulationSettings

from .pacing import TimeSettings
from .parameters import describe_files


@dataclass(frozen=True)
class PlantSettings:
    """The plant's run-time settings (SI), from its parameters of the same names.

    ``simulation`` and ``time`` gather the parameters of :class:`exodigit_model.SimulationSettings`
    and :class:`~exodigit_nodes.logic.pacing.TimeSettings`.
    """

    simulation: SimulationSettings
    command_timeout: float
    effort_timeout: float
    frame_id: str
    marker_rate_hz: float
    time: TimeSettings


def plant_settings(values: Mapping[str, Any]) -> PlantSettings:
    """The plant's settings from its checked parameter values (by name).

    Raises
    ------
    ValueError
        Naming the parameter, for values each valid alone but not together: ``lockstep`` or
        ``start_paused`` without ``clock`` sim.
    """
    if values['clock'] != 'sim':
        for name in ('lockstep', 'start_paused'):
            if values[name]:
                raise ValueError(f'{name} needs clock sim (only simulated time can wait)')
    return PlantSettings(
        simulation=SimulationSettings(
            rate_hz=values['rate_hz'],
            pressure_time_constant=values['pressure_time_constant'],
            max_supply_pressure=values['max_supply_pressure'],
            angle_noise_std=values['angle_noise_std'],
            pressure_noise_std=values['pressure_noise_std'],
            seed=values['seed'],
        ),
        command_timeout=values['command_timeout'],
        effort_timeout=values['effort_timeout'],
        frame_id=values['frame_id'],
        marker_rate_hz=values['marker_rate_hz'],
        time=TimeSettings(
            real_time_factor=values['real_time_factor'],
            lockstep=values['lockstep'],
            lockstep_timeout=values['lockstep_timeout'],
            start_paused=values['start_paused'],
            pause_at=values['pause_at'],
            run_until=values['run_until'],
        ),
    )


def start_line(values: Mapping[str, Any], settings: PlantSettings) -> str:
    """What the plant logs as it starts: rate, time source, model files, actuation, timeout."""
    time = settings.time
    if values['clock'] == 'sim':
        timeout = f'{time.lockstep_timeout:g} s' if time.lockstep_timeout > 0.0 else 'none'
        lockstep = f'on, answer timeout {timeout}' if time.lockstep else 'off'
        time_source = (
            f'simulated time (real-time factor {time.real_time_factor:g}, lockstep {lockstep})'
        )
    else:
        time_source = 'the wall clock'
    if values['actuation'] == 'valves':
        actuation = 'valves on valve_command'
    else:
        actuation = f'chamber lag {settings.simulation.pressure_time_constant:g} s'
    return (
        f'plant running at {values["rate_hz"]:g} Hz on {time_source}, model from '
        f'{describe_files(values["params_file"])}, {actuation}, command timeout '
        f'{settings.command_timeout:g} s'
    )
