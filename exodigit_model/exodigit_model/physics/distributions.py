"""How one patient parameter is spread over a population: four kinds, truncated to bounds.

Every random kind is truncated, not clipped, to its bounds [low, high]: it is the distribution
conditioned on lying between them, so no patient is moved onto a bound. A value is made from a
latent standard normal draw z (docs/populations.md, "Correlation") by the inverse cumulative
distribution of the truncated kind,

    x = F⁻¹(F(low) + Φ(z)·(F(high) − F(low)))

where F is the untruncated kind's cumulative distribution and Φ the standard normal one. The map
rises with z, so the rank correlations of the latent draws carry over to the values unchanged.
The final ``np.clip`` only absorbs rounding at the bounds (and z above about 8, where Φ(z) rounds
to 1); it never moves a value that lies inside them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import special

from ..checks import ParameterError, check_number, check_positive, set_field


def _check_bounds(dist: Normal | LogNormal | Uniform, centre: str | None) -> None:
    """Validate ``low < high`` and, unless ``centre`` is None, low <= that attribute <= high."""
    low = check_number('low', dist.low)
    high = check_number('high', dist.high)
    if not low < high:
        raise ParameterError(f'low = {low!r}: must be below high = {high!r}')
    set_field(dist, 'low', low)
    set_field(dist, 'high', high)
    if centre is not None:
        value = getattr(dist, centre)
        if not low <= value <= high:
            raise ParameterError(
                f'{centre} = {value!r}: must lie within [low, high] = [{low!r}, {high!r}]'
            )


def _standard_truncated(latent: NDArray, lower: float, upper: float) -> NDArray:
    """Standard normal values truncated to [lower, upper], made from the latent draws."""
    low, high = special.ndtr(lower), special.ndtr(upper)
    return special.ndtri(low + special.ndtr(latent) * (high - low))


@dataclass(frozen=True)
class Fixed:
    """The same value for every patient (a bare number in a population file).

    Attributes
    ----------
    value : float
        The value, in the parameter's SI unit.
    """

    value: float

    def __post_init__(self) -> None:
        set_field(self, 'value', check_number('value', self.value))

    @property
    def low(self) -> float:
        """The smallest value drawn: ``value``."""
        return self.value

    @property
    def high(self) -> float:
        """The largest value drawn: ``value``."""
        return self.value

    def values(self, latent: NDArray) -> NDArray[np.float64]:
        """``value`` once per latent draw."""
        return np.full(np.shape(latent), self.value)


@dataclass(frozen=True)
class Normal:
    """Normal distribution N(mean, sd²) truncated to [low, high], in the parameter's unit.

    Attributes
    ----------
    mean : float
        Mean before truncation; within [low, high].
    sd : float
        Standard deviation before truncation, > 0.
    low, high : float
        Truncation bounds, low < high.
    """

    mean: float
    sd: float
    low: float
    high: float

    def __post_init__(self) -> None:
        set_field(self, 'mean', check_number('mean', self.mean))
        set_field(self, 'sd', check_positive('sd', self.sd, 'same unit as the parameter'))
        _check_bounds(self, 'mean')

    def values(self, latent: NDArray) -> NDArray[np.float64]:
        """One value per latent standard normal draw (module docstring)."""
        lower, upper = (self.low - self.mean) / self.sd, (self.high - self.mean) / self.sd
        values = self.mean + self.sd * _standard_truncated(latent, lower, upper)
        return np.clip(values, self.low, self.high)


@dataclass(frozen=True)
class LogNormal:
    """Log-normal distribution truncated to [low, high]: ln x is normal.

    Attributes
    ----------
    median : float
        Median before truncation, exp of the mean of ln x; within [low, high].
    gsd : float
        Geometric standard deviation, exp of the standard deviation of ln x, > 1
        (dimensionless): about 68 % of the untruncated values lie within median ÷/× gsd.
    low, high : float
        Truncation bounds, 0 < low < high.
    """

    median: float
    gsd: float
    low: float
    high: float

    def __post_init__(self) -> None:
        set_field(
            self, 'median', check_positive('median', self.median, 'same unit as the parameter')
        )
        gsd = check_number('gsd', self.gsd)
        if not gsd > 1.0:
            raise ParameterError(f'gsd = {gsd!r}: must be > 1 (a fixed value is a bare number)')
        set_field(self, 'gsd', gsd)
        check_positive('low', self.low, 'a log-normal value is > 0')
        _check_bounds(self, 'median')

    def values(self, latent: NDArray) -> NDArray[np.float64]:
        """One value per latent standard normal draw (module docstring)."""
        sigma = math.log(self.gsd)
        lower, upper = math.log(self.low / self.median), math.log(self.high / self.median)
        values = self.median * np.exp(
            sigma * _standard_truncated(latent, lower / sigma, upper / sigma)
        )
        return np.clip(values, self.low, self.high)


@dataclass(frozen=True)
class Uniform:
    """Uniform distribution on [low, high].

    Attributes
    ----------
    low, high : float
        The interval, low < high, in the parameter's unit.
    """

    low: float
    high: float

    def __post_init__(self) -> None:
        _check_bounds(self, None)

    def values(self, latent: NDArray) -> NDArray[np.float64]:
        """One value per latent standard normal draw: low + (high − low)·Φ(z)."""
        values = self.low + (self.high - self.low) * special.ndtr(latent)
        return np.clip(values, self.low, self.high)


Distribution = Fixed | Normal | LogNormal | Uniform
"""Any of the four kinds."""

KINDS: dict[str, type[Normal | LogNormal | Uniform]] = {
    'normal': Normal,
    'lognormal': LogNormal,
    'uniform': Uniform,
}
"""The random kinds by their ``kind`` in a population file (a bare number is :class:`Fixed`)."""
