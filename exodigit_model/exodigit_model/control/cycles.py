"""The smooth flex-extend cycle: the target of a continuous passive motion and of GloveEnv.

The cycle's phase :func:`rise` and the cycle between two postures :func:`flex_extend`
(docs/trials.md, "Protocols"): the targets of
:class:`~exodigit_model.trials.protocols.ContinuousPassiveMotion` and of
:class:`~exodigit_model.gym.env.GloveEnv`'s default task.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def rise(t: NDArray[np.float64], period: float) -> NDArray[np.float64]:
    r"""The smooth cycle's phase s(t) = (1 − cos(2πt/period))/2, in [0, 1].

    s = 0 at t = 0 and t = period, s = 1 at t = period/2, with zero slope at all three: its
    first half is a smooth rise from 0 to 1 in period/2 (used so by :class:`GraspRelease`).
    """
    return 0.5 * (1.0 - np.cos(2.0 * np.pi * t / period))


def flex_extend(
    t: ArrayLike, low: NDArray[np.float64], high: NDArray[np.float64], period: float
) -> NDArray[np.float64]:
    r"""The smooth flex-extend cycle q*(t) = low + (high − low)·s(t), s of :func:`rise`.

    Starts at ``low`` at t = 0, reaches ``high`` at t = period/2 and is back at ``low`` at
    t = period; every point lies on the straight line between the two postures.

    Parameters
    ----------
    t : array_like
        Times, s, any shape.
    low, high : ndarray, shape (3,)
        The two postures, rad.
    period : float
        Duration of one cycle, s (> 0).

    Returns
    -------
    ndarray, shape ``t.shape + (3,)``
        q*(t), rad.
    """
    phase = rise(np.asarray(t, dtype=float), period)
    return low + (high - low) * phase[..., np.newaxis]
