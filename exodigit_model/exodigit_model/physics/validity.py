"""Whether an answer of the model lies inside what the model is validated for.

The model is validated for fibre stretches 0.95 ≤ λ ≤ 1.5 (:data:`VALID_STRETCH`;
docs/spec/model.md §12) and joints inside the finger's range of motion [rom_min, rom_max]
(§11); a pressure it asks for is one the supply can give only in [0, ``max_supply_pressure``]
(§13). Outside, everything still computes: the forward solve says so on its
:class:`~exodigit_model.physics.model.Solution`, the inverse and the robot-side estimator on the results
here, with a ``status`` and a ``message`` in scipy's manner. The status is :data:`INSIDE` (0), or
the sum of the code of every way the answer leaves the model (:data:`OUTSIDE_STRETCH`,
:data:`OUTSIDE_RANGE_OF_MOTION`, :data:`BEYOND_SUPPLY`); the message says each in words, the
sentences :func:`state_warnings` gives for a forward solve.

>>> from exodigit_model.physics.validity import INSIDE, OUTSIDE_STRETCH, BEYOND_SUPPLY, validity_message
>>> validity_message(INSIDE)
'inside the validated model'
>>> validity_message(OUTSIDE_STRETCH + BEYOND_SUPPLY, supply=100e3)
'a fibre stretch is outside the validated range 0.95 <= lambda <= 1.5; a pressure is outside the supply range 0 <= p <= 100000 Pa'
"""  # noqa: E501 (a doctest's output is one line)

from __future__ import annotations

import math
import warnings

import numpy as np
from numpy.typing import NDArray

SUPPLY_PRESSURE = 100e3
"""The default supply's highest pressure, Pa (docs/spec/model.md §13): what the inverse checks
the pressures it asks for against, and the chambers' default ``max_supply_pressure``."""
VALID_STRETCH = (0.95, 1.5)
"""Fibre stretches the model is validated for (paper §2.1.3; docs/spec/model.md §12: a bottom face
slightly compressed by the finger, λ ≥ 0.95, is harmless)."""

INSIDE = 0
"""Status of an answer inside the validated model."""
OUTSIDE_STRETCH = 1
"""Status bit: a fibre's stretch (12.1) lies outside :data:`VALID_STRETCH`."""
OUTSIDE_RANGE_OF_MOTION = 2
"""Status bit: a joint lies outside the finger's range of motion."""
BEYOND_SUPPLY = 4
"""Status bit: a pressure the inverse asks for lies outside [0, supply] (suction, or more than
the supply gives); the chambers would clip it (docs/spec/model.md §13)."""

SUPPLY_ROUNDING = 1e-9
"""A pressure counts as within the supply up to this share of the supply past either end (the
inverse of a state at rest gives ±rounding, not suction)."""


class OutsideModelWarning(UserWarning):
    """An answer of the model lies outside its validated range.

    The array-returning shortcuts
    :meth:`~exodigit_model.physics.model.GloveModel.pressure_for` and
    :meth:`~exodigit_model.physics.model.GloveModel.estimate_forces` warn it; the results say
    which way.
    """


def state_warnings(converged: bool, in_valid_range: bool, in_range_of_motion: bool) -> list[str]:
    """One sentence per way a state leaves the model (the tools and nodes say them)."""
    messages = [] if converged else ['the solve did not converge']
    return messages + validity_sentences(validity_status(in_valid_range, in_range_of_motion))


def validity_status(
    in_valid_range: bool | NDArray[np.bool_],
    in_range_of_motion: bool | NDArray[np.bool_],
    within_supply: bool | NDArray[np.bool_] = True,
) -> int | NDArray[np.int_]:
    """The status of an answer with these flags: :data:`INSIDE` or the sum of its codes.

    One answer (bools: an int) or one per row (arrays of bools: an int array).
    """
    status = (
        OUTSIDE_STRETCH * np.logical_not(in_valid_range)
        + OUTSIDE_RANGE_OF_MOTION * np.logical_not(in_range_of_motion)
        + BEYOND_SUPPLY * np.logical_not(within_supply)
    )
    return int(status) if np.ndim(status) == 0 else status


def validity_message(status: int, supply: float | None = None) -> str:
    """``status`` in words: 'inside the validated model', or each way out, joined by '; '.

    ``supply`` (Pa) names the supply range when :data:`BEYOND_SUPPLY` is set.
    """
    sentences = validity_sentences(int(status), supply)
    return '; '.join(sentences) if sentences else 'inside the validated model'


def validity_sentences(status: int, supply: float | None = None) -> list[str]:
    """One sentence per way out of the model that ``status`` names (empty for INSIDE)."""
    low, high = VALID_STRETCH
    sentences = []
    if status & OUTSIDE_STRETCH:
        sentences.append(
            f'a fibre stretch is outside the validated range {low:g} <= lambda <= {high:g}'
        )
    if status & OUTSIDE_RANGE_OF_MOTION:
        sentences.append("a joint is outside the finger's range of motion")
    if status & BEYOND_SUPPLY:
        upper = 'the supply' if supply is None else f'{supply:g} Pa'
        sentences.append(f'a pressure is outside the supply range 0 <= p <= {upper}')
    return sentences


def within_supply(pressure: NDArray[np.float64], supply: float) -> bool | NDArray[np.bool_]:
    """Whether every pressure (Pa; of one state, or per row) lies in [0, supply], rounding aside.

    Raises
    ------
    ValueError
        If ``supply`` is not a finite number > 0.
    """
    if not (isinstance(supply, int | float) and math.isfinite(supply) and supply > 0.0):
        raise ValueError(f'supply = {supply!r}: must be a finite pressure > 0 Pa')
    margin = SUPPLY_ROUNDING * supply
    if pressure.ndim == 1:  # one state (the hot path): plain floats beat ufuncs on three
        values = pressure.tolist()
        return min(values) >= -margin and max(values) <= supply + margin
    return ((pressure >= -margin) & (pressure <= supply + margin)).all(axis=1)


def warn_outside(what: str, status: int, supply: float | None = None) -> None:
    """Warn :class:`OutsideModelWarning` from the caller of ``what`` unless ``status`` is INSIDE.

    The text names the way out, never the numbers, so that a loop calling ``what`` warns once
    per way out and place (the warnings module's default), not at every call.
    """
    if status != INSIDE:
        message = f'{what}: {validity_message(status, supply)} (its result object says more)'
        warnings.warn(message, OutsideModelWarning, stacklevel=3)
