"""The shapes of the control arrays: one glove, (3,), or a batch of gloves, (N, 3).

Every array of a controller or the safety limiter (commands, feedback, integrators, the
limiter's memory) has a glove's joints on its last axis, MCP, PIP, DIP; a batch adds one leading
axis, one row per glove. What one glove keeps as a number (is it backing off?) a batch keeps
per row, shape (N,).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def glove_shape(count: int | None) -> tuple[int, ...]:
    """(3,) for one glove (``count`` None), (count, 3) for a batch of ``count`` gloves.

    Raises
    ------
    ValueError
        If ``count`` is neither None nor a positive integer.
    """
    if count is None:
        return (3,)
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
        raise ValueError(f'count = {count!r}: must be a positive integer (or None: one glove)')
    return (int(count), 3)


def check_shape(name: str, value: NDArray | None, shape: tuple[int, ...]) -> None:
    """A ValueError naming ``name`` unless ``value`` is None or an array of ``shape``."""
    if value is not None and np.shape(value) != shape:
        raise ValueError(
            f'{name} must have shape {shape} (one row per glove: MCP, PIP, DIP), '
            f'got {np.shape(value)}'
        )


def any_joint(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Per glove, whether ``mask`` holds for any joint (its last axis, of three).

    Written out over the three joints: numpy's ``any(axis=-1)`` over an axis of three is about
    ten times slower on a batch of 10,000 gloves (measured: 0.12 ms against 0.01 ms).
    """
    return mask[..., 0] | mask[..., 1] | mask[..., 2]


def every_joint(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Per glove, whether ``mask`` holds for every joint (its last axis), as :func:`any_joint`."""
    return mask[..., 0] & mask[..., 1] & mask[..., 2]
