"""The pneumatic chambers: first-order lag toward the saturated command (docs/spec/model.md §13).

T·dp/dt = u − p with u the command clipped to [0, max_supply_pressure] and held constant over a
step (zero-order hold), discretised exactly: p ← u + (p − u)·exp(−Δt/T); T = 0 gives p = u.
Pressures are arrays of shape (3,) for one glove or (N, 3) for N gloves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..physics.validity import SUPPLY_PRESSURE


@dataclass(frozen=True)
class ChamberSettings:
    """Chamber dynamics.

    Attributes
    ----------
    time_constant : float
        T of the first-order lag, s; 0 = ideal (p follows the command at once).
    max_supply_pressure : float
        Highest pressure the supply can give, Pa; commands are saturated to [0, this].
    """

    time_constant: float = 0.05
    max_supply_pressure: float = SUPPLY_PRESSURE

    def __post_init__(self) -> None:
        """Refuse negative or non-finite values, naming the field."""
        if not (math.isfinite(self.time_constant) and self.time_constant >= 0.0):
            raise ValueError(
                f'time_constant must be finite and >= 0 s, got {self.time_constant!r}'
            )
        if not (math.isfinite(self.max_supply_pressure) and self.max_supply_pressure > 0.0):
            raise ValueError(
                f'max_supply_pressure must be finite and > 0 Pa, got {self.max_supply_pressure!r}'
            )

    def decay(self, dt: float) -> float:
        """exp(−Δt/T): the share of the old pressure left after a step of ``dt`` s."""
        return math.exp(-dt / self.time_constant) if self.time_constant > 0.0 else 0.0


@dataclass(frozen=True)
class Saturation:
    """How often a command was saturated to the supply range: counts of steps, per side."""

    below_zero: int = 0
    above_supply: int = 0


class Chambers:
    """Pressure in the chambers of one glove or of many, stepped by fixed lengths.

    The step itself is compiled (:func:`.kernels.stepping.advance_chambers`, inside the
    simulation's step); this object holds the pressures, the last command, the decay per step
    and the saturation counts between steps.

    Parameters
    ----------
    settings : ChamberSettings
        Lag and saturation.
    dt : float
        Step length, s.
    shape : tuple
        (3,) for one glove, (N, 3) for N gloves.
    """

    def __init__(self, settings: ChamberSettings, dt: float, shape: tuple = (3,)) -> None:
        self.dt = dt
        self.pressure = np.zeros(shape)
        self.command = np.zeros(shape)
        """The command of the latest step after saturation, Pa."""
        self.saturation = Saturation()
        self.saturated_now = False
        self.configure(settings)

    def configure(self, settings: ChamberSettings) -> None:
        """Use new settings from the next step on (the pressures are kept)."""
        self.settings = settings
        self.decay = settings.decay(self.dt)
        """exp(−Δt/T): the share of the old pressure left after a step."""

    def reset(self) -> None:
        """Vent every chamber to zero at once."""
        self.pressure = np.zeros_like(self.pressure)
        self.command = np.zeros_like(self.command)

    def record(self, below: bool, above: bool) -> None:
        """Count a step whose command was clipped at zero (``below``) or at the supply."""
        self.saturated_now = bool(below or above)
        if self.saturated_now:
            self.saturation = Saturation(
                self.saturation.below_zero + bool(below),
                self.saturation.above_supply + bool(above),
            )
