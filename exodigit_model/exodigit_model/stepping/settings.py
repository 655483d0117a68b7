"""How the glove is stepped, driven and sensed: settings, time grid, actuations (§13, §14).

The settings and time grid of docs/spec/model.md §13, and what drives the chambers: pressure
regulators, or valves and the layout of their command (§14). Plain data, apart from the model
and its compiled kernels: the ROS nodes' parameter tables and the command node read these
without loading the stepper (:mod:`.simulation`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from ..checks import check_integer
from .chambers import ChamberSettings

NANOSECONDS = 10**9
ACTUATIONS = ('regulator', 'valves')
"""How the chambers are driven: pressure regulators (a pressure command, §13) or valves (six
openings, docs/spec/model.md §14)."""
OPENINGS = 6
"""Openings of a valve command: u_in, then u_out, of MCP, PIP and DIP."""
VENT = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
"""The openings of a vent: inlets closed, outlets open (the plant's watchdog, a stopping
``pressure_command``, a target of zero). Read-only."""
CLOSED = np.zeros(OPENINGS)
"""Every valve closed: the chambers hold their air. Read-only."""
VENT.flags.writeable = CLOSED.flags.writeable = False


def step_time_ns(step: int | NDArray[np.integer], rate_hz: float) -> int | NDArray[np.int64]:
    """t_k = round(k·10⁹/rate_hz) ns: the time of step k, without drift at any rate.

    ``step`` may also be an integer array: then an int64 array of the same values (rounded half
    to even, as :func:`round`).
    """
    if isinstance(step, np.ndarray):
        return np.rint(step * 1e9 / rate_hz).astype(np.int64)
    return round(step * 1e9 / rate_hz)


@dataclass(frozen=True)
class SimulationSettings:
    """How the glove is stepped and sensed (SI). The defaults are the ROS plant's.

    Attributes
    ----------
    rate_hz : float
        Steps per simulated second, Hz (Δt = 1/rate_hz).
    pressure_time_constant : float
        T of the chambers' first-order lag, s; 0 = ideal.
    max_supply_pressure : float
        Supply saturation: commands are clipped to [0, this], Pa.
    angle_noise_std : float
        Standard deviation of the joint-angle sensor noise, rad.
    pressure_noise_std : float
        Standard deviation of the chamber-pressure sensor noise, Pa.
    seed : int
        Seed of the sensor noise (the same seed gives the same noise, bit for bit).
    """

    rate_hz: float = 100.0
    pressure_time_constant: float = 0.05
    max_supply_pressure: float = 100e3
    angle_noise_std: float = 0.0
    pressure_noise_std: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        """Refuse values that break a rule, naming the field, the value and the rule.

        The quantities are kept as floats, whichever number was given: the kernels compile
        once per argument type, and the warm-up compiles the float ones.
        """
        for item in fields(self):
            value = getattr(self, item.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f'{item.name} = {value!r}: must be a number')
            if not math.isfinite(value) or value < 0:
                raise ValueError(f'{item.name} = {value!r}: must be finite and >= 0')
            if item.name != 'seed':
                object.__setattr__(self, item.name, float(value))
        if self.rate_hz <= 0.0:
            raise ValueError(f'rate_hz = {self.rate_hz!r}: must be > 0')
        check_integer('seed', self.seed)
        ChamberSettings(self.pressure_time_constant, self.max_supply_pressure)

    @property
    def period(self) -> float:
        """Δt, s."""
        return 1.0 / self.rate_hz

    @property
    def chambers(self) -> ChamberSettings:
        """The chamber part of these settings."""
        return ChamberSettings(self.pressure_time_constant, self.max_supply_pressure)


FIXED_SETTINGS = ('rate_hz', 'seed')
"""Settings a running simulation cannot change (they define its time grid and noise streams)."""
