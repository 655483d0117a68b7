"""The plant's run-time settings from its checked parameter values (no ROS)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from exodigit_model import SimulationSettings

from .pacing import TIME_SETTING_NAMES, TimeSettings
from .parameters import describe_files


@dataclass(frozen=True)
class PlantSettings:
    """The plant's run-time settings (SI), from its parameters of the same names.

    ``simulation`` and ``time`` gather those named as the fields of their classes.
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
    simulation_names = (field.name for field in fields(SimulationSettings))
    return PlantSettings(
        simulation=SimulationSettings(**{name: values[name] for name in simulation_names}),
        command_timeout=values['command_timeout'],
        effort_timeout=values['effort_timeout'],
        frame_id=values['frame_id'],
        marker_rate_hz=values['marker_rate_hz'],
        time=TimeSettings(**{name: values[name] for name in TIME_SETTING_NAMES}),
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
