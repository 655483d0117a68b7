"""The three pneumatic chambers: first-order lag toward the command, saturation, sensor noise."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class ChamberSettings:
    """Chamber dynamics of the plant.

    Attributes
    ----------
    time_constant : float
        T of the first-order lag T·dp/dt = u − p, s; 0 = ideal (p follows u at once).
    max_supply_pressure : float
        Highest pressure the supply can give, Pa; commands are saturated to [0, this].
    noise_std : float
        Standard deviation of the pressure sensor noise on the reported pressure, Pa.
    """

    time_constant: float = 0.0
    max_supply_pressure: float = 100e3
    noise_std: float = 0.0

    def __post_init__(self) -> None:
        """Refuse negative or non-finite values, naming the field."""
        for name in ('time_constant', 'noise_std'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be finite and >= 0, got {value!r}')
        if not (math.isfinite(self.max_supply_pressure) and self.max_supply_pressure > 0.0):
            raise ValueError(
                f'max_supply_pressure must be finite and > 0, got {self.max_supply_pressure!r}'
            )


@dataclass(frozen=True)
class Saturation:
    """How a command was saturated to the supply range: counts of steps, per side."""

    below_zero: int = 0
    above_supply: int = 0


class Chambers:
    """Pressure in the three chambers, advanced step by step.

    T·dp/dt = u − p with u the command saturated to [0, max_supply_pressure] and held constant
    over a step (zero-order hold), discretised exactly: p ← u + (p − u)·exp(−dt/T).

    Parameters
    ----------
    settings : ChamberSettings
        Lag, saturation and noise.
    rng : numpy.random.Generator
        Source of the sensor noise (seeded by the caller, so runs repeat).
    """

    def __init__(self, settings: ChamberSettings, rng: np.random.Generator) -> None:
        self.settings = settings
        self.pressure = np.zeros(3)
        self.saturation = Saturation()
        self.saturated_now = False
        self._rng = rng
        self._decay_for: tuple[float, float] = (-1.0, 0.0)

    def reset(self) -> None:
        """Vent every chamber to zero at once."""
        self.pressure[:] = 0.0

    def _decay(self, dt: float) -> float:
        """exp(−dt/T), cached for the last dt (the plant steps at a fixed rate)."""
        cached_dt, value = self._decay_for
        if dt != cached_dt:
            constant = self.settings.time_constant
            value = math.exp(-dt / constant) if constant > 0.0 else 0.0
            self._decay_for = (dt, value)
        return value

    def advance(self, command: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """Move the pressures toward ``command`` (Pa) over ``dt`` s; return them (Pa, no noise)."""
        supply = self.settings.max_supply_pressure
        low = command.min() < 0.0
        high = command.max() > supply
        target = np.clip(command, 0.0, supply) if low or high else command
        self.saturated_now = bool(low or high)
        if self.saturated_now:
            self.saturation = Saturation(
                self.saturation.below_zero + int(low), self.saturation.above_supply + int(high)
            )
        decay = self._decay(dt)
        self.pressure = target + (self.pressure - target) * decay
        return self.pressure

    def configure(self, settings: ChamberSettings) -> None:
        """Apply new settings from the next step on (the state is kept)."""
        self.settings = settings
        self._decay_for = (-1.0, 0.0)

    def noise(self, std: float) -> NDArray[np.float64]:
        """Three samples of zero-mean Gaussian sensor noise of deviation ``std`` (0: zeros)."""
        if std == 0.0:
            return np.zeros(3)
        return self._rng.normal(0.0, std, 3)

    def measured(self) -> NDArray[np.float64]:
        """The pressures as the sensors report them (with noise if configured), Pa."""
        return self.pressure + self.noise(self.settings.noise_std)
