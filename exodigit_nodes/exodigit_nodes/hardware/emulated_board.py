"""The emulated board without I/O: the glove behind valves and the board's protocol, stepped.

:class:`EmulatedBoard` is what ``mcu_emulator`` (:mod:`.emulator`) serves on a pseudo-terminal:
the glove behind valves (``exodigit_model.GloveSimulation(actuation='valves')``,
docs/spec/model.md §14), one step a sample, behind the board's side of the link
(:class:`.board.BoardProtocol`); each step applies the openings the board holds (a vent before a
Hello, on its watchdog and above its vent pressure), after the faults (supply loss, stuck
valves), and reads the sensors (the simulation's seeded noise, then quantised to the sensor's
resolution and clipped to its range). :class:`EmulatorSettings` are the board's and its line's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from exodigit_model.checks import check_flag, check_number, check_range

from .board import BoardProtocol, default_capabilities
from .messages import ANGLE_UNIT, CHAMBERS, PROTOCOL_VERSION, openings_of

FIRMWARE = (1, 0, 0)
"""The emulator's firmware version, in its Capabilities."""


@dataclass(frozen=True)
class EmulatorSettings:
    """The emulated board and its line (SI units).

    Attributes
    ----------
    rate_hz : float
        Samples (and simulation steps) per second, Hz; a whole number up to 2000.
    latency : float
        One-way delay of every byte, both ways, s.
    pressure_noise_std : float
        Pressure sensor noise (std), Pa.
    angle_noise_std : float
        Bend sensor noise (std), rad.
    pressure_quantum : int
        Pressure sensor resolution, Pa (≥ 1).
    angle_quantum : int
        Bend sensor resolution, in 1/10,000 rad (≥ 1).
    bend_sensors : bool
        Whether the board has a bend sensor per joint.
    drop_probability, corrupt_probability : float
        Chance that a byte is lost, or has one bit flipped, each way, in [0, 1).
    watchdog : float
        The board's watchdog time, s (whole ms, 0.001-60).
    vent_pressure : float
        The board's vent pressure, Pa.
    supply_pressure : float
        Supply pressure (gauge), Pa, unless the model's pneumatics sets one.
    pressure_max : float
        Top of the pressure sensors' range (gauge), Pa; readings are clipped to [0, this].
    version : int
        Protocol version the board speaks (another than the host's to test the refusal).
    seed : int
        Seed of the sensor noise and of the line faults.
    """

    rate_hz: float = 100.0
    latency: float = 0.0
    pressure_noise_std: float = 0.0
    angle_noise_std: float = 0.0
    pressure_quantum: int = 50
    angle_quantum: int = 10
    bend_sensors: bool = True
    drop_probability: float = 0.0
    corrupt_probability: float = 0.0
    watchdog: float = 0.2
    vent_pressure: float = 150e3
    supply_pressure: float = 100e3
    pressure_max: float = 200e3
    version: int = PROTOCOL_VERSION
    seed: int = 0

    def __post_init__(self) -> None:
        """Refuse values that break a rule, naming the field, the value and the rule."""
        check_flag('bend_sensors', self.bend_sensors)
        for item in fields(self):
            if item.name != 'bend_sensors':
                value = getattr(self, item.name)
                check_range(item.name, check_number(item.name, value), 0.0, None)
        rules = (
            ('rate_hz', 1 <= self.rate_hz <= 2000 and self.rate_hz == int(self.rate_hz),
             'a whole number in [1, 2000]'),
            ('pressure_quantum', isinstance(self.pressure_quantum, int)
             and self.pressure_quantum >= 1, 'an integer >= 1'),
            ('angle_quantum', isinstance(self.angle_quantum, int) and self.angle_quantum >= 1,
             'an integer >= 1'),
            ('drop_probability', self.drop_probability < 1, 'below 1'),
            ('corrupt_probability', self.corrupt_probability < 1, 'below 1'),
            ('watchdog', 1e-3 <= self.watchdog <= 60, 'in [0.001, 60]'),
            ('supply_pressure', self.supply_pressure >= 1e3, '>= 1000'),
            ('pressure_max', self.pressure_max >= 1e3, '>= 1000'),
            ('version', isinstance(self.version, int) and self.version <= 255,
             'an integer in [0, 255]'),
            ('seed', isinstance(self.seed, int), 'an integer'),
        )  # fmt: skip
        for name, good, rule in rules:
            if not good:
                raise ValueError(f'{name} = {getattr(self, name)!r}: must be {rule}')


class EmulatedBoard:
    """The glove behind valves and the board's protocol, stepped by :meth:`tick`; no I/O.

    Parameters
    ----------
    settings : EmulatorSettings
    model : exodigit_model.GloveModel, optional
        The glove and finger (the defaults when omitted).

    Attributes
    ----------
    protocol : BoardProtocol
    simulation : exodigit_model.GloveSimulation
    supply_lost : bool
        No air comes through the inlets (and the board flags SUPPLY_LOW).
    stuck : dict
        Valve index (0-5) -> the opening it is stuck at.
    openings : ndarray
        The openings of the latest step, after the faults.
    readings : tuple of int
        The pressures the latest step read (as sent), Pa.
    """

    def __init__(self, settings: EmulatorSettings, model=None) -> None:
        from exodigit_model import GloveSimulation, SimulationSettings

        self.settings = settings
        self.capabilities = default_capabilities(
            version=settings.version,
            firmware=FIRMWARE,
            bend_sensors=CHAMBERS if settings.bend_sensors else 0,
            sample_rate_hz=int(settings.rate_hz),
            watchdog_ms=round(settings.watchdog * 1e3),
            pressure_quantum_pa=settings.pressure_quantum,
            pressure_max_pa=round(settings.pressure_max),
            vent_pressure_pa=round(settings.vent_pressure),
            angle_quantum=settings.angle_quantum if settings.bend_sensors else 0,
        )
        self.protocol = BoardProtocol(self.capabilities)
        self.simulation = GloveSimulation(
            model,
            SimulationSettings(
                rate_hz=settings.rate_hz,
                max_supply_pressure=settings.supply_pressure,
                pressure_noise_std=settings.pressure_noise_std,
                angle_noise_std=settings.angle_noise_std,
                seed=settings.seed,
            ),
            actuation='valves',
        )
        self.supply_lost = False
        self.stuck: dict[int, float] = {}
        self.openings = openings_of(self.protocol.duties(0.0))
        self.readings = (0,) * CHAMBERS
        self.simulation.step(self.openings)  # loads the compiled kernels before serving
        self.simulation.reset()

    def receive(self, data: bytes, now: float) -> bytes:
        """Bytes from the host at ``now`` (s); the answer's bytes."""
        return self.protocol.receive(data, now)

    def tick(self, now: float) -> bytes:
        """One step of the glove with the board's openings at ``now``; the sample's frame."""
        openings = openings_of(self.protocol.duties(now))
        for valve, opening in self.stuck.items():
            openings[valve] = opening
        if self.supply_lost:
            openings[:CHAMBERS] = 0.0
        self.openings = openings
        state = self.simulation.step(openings)
        self.readings = self.pressures(state.pressure_measured)
        return self.protocol.sample(
            now,
            self.readings,
            self.angles(state.q_measured),
            supply_low=self.supply_lost,
        )

    def pressures(self, measured) -> tuple[int, ...]:
        """Sensor readings of pressures (Pa): quantised, clipped to the sensor's range, Pa."""
        quantum = self.settings.pressure_quantum
        counts = np.rint(np.asarray(measured) / quantum)
        top = math.floor(self.settings.pressure_max / quantum)
        return tuple(int(c) * quantum for c in np.clip(counts, 0, top))

    def angles(self, measured) -> tuple[int, ...]:
        """Bend sensor readings (1/10,000 rad, quantised), or () without bend sensors."""
        if not self.settings.bend_sensors:
            return ()
        quantum = self.settings.angle_quantum
        counts = np.rint(np.asarray(measured) / (ANGLE_UNIT * quantum))
        limit = 32767 // quantum
        return tuple(int(c) * quantum for c in np.clip(counts, -limit, limit))

    def power_cycle(self) -> None:
        """The board loses power and boots: silent and vented until a Hello."""
        self.protocol.reset()
