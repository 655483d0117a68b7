"""Results of the inverse and of the robot-side estimator, with where they lie (scipy style).

:meth:`GloveModel.hold <exodigit_model.physics.model.GloveModel.hold>` answers with a
:class:`Hold`, :meth:`~exodigit_model.physics.model.GloveModel.estimate` with an
:class:`Estimate` and :meth:`~exodigit_model.physics.model.GloveModel.estimate_batch` with a
:class:`BatchEstimate`. Each says whether its answer lies inside the validated model as the
forward solve's :class:`~exodigit_model.physics.model.Solution` does (``in_valid_range``,
``in_range_of_motion``), and with a ``status`` and ``message`` of
:mod:`exodigit_model.physics.validity` (0 and 'inside the validated model' when it does). Where
no answer exists (no bottom-face strain balances the
segments) the methods raise instead: these results are always balances found.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .validity import validity_message


@dataclass(frozen=True)
class Hold:
    """The inverse at angles ``q``: pressures and bottom-face lengths that hold them.

    Attributes
    ----------
    q : ndarray, shape (3,)
        The angles held, rad.
    pressure : ndarray, shape (3,)
        Chamber pressures that hold ``q``, Pa (eq 11.4 for p; (12.4)-(12.5) with extensible
        segments); negative where holding ``q`` would need suction.
    lengths : ndarray, shape (3,)
        ℓ_i, the bottom-face arc lengths at that balance, m.
    status : int
        :data:`~exodigit_model.physics.validity.INSIDE` (0), or the sum of the codes of
        :mod:`exodigit_model.physics.validity` of each way the answer leaves the model.
    message : str
        The status in words.
    in_valid_range : bool
        Whether every fibre's stretch lies in 0.95 ≤ λ ≤ 1.5 (as :class:`Solution`'s).
    in_range_of_motion : bool
        Whether every joint of ``q`` lies within the finger's range of motion.
    within_supply : bool
        Whether every pressure lies in [0, ``supply``], rounding aside: what the chambers can
        give (docs/spec/model.md §13).
    supply : float
        The supply pressure checked against, Pa.
    """

    q: NDArray[np.float64]
    pressure: NDArray[np.float64]
    lengths: NDArray[np.float64]
    status: int
    message: str
    in_valid_range: bool
    in_range_of_motion: bool
    within_supply: bool
    supply: float


@dataclass(frozen=True)
class Estimate:
    """The robot-side estimate at measured angles ``q`` and pressures ``pressure``.

    The pressures are measurements, not asked for, so there is no supply check.

    Attributes
    ----------
    q : ndarray, shape (3,)
        The measured angles, rad.
    pressure : ndarray, shape (3,)
        The measured pressures, Pa.
    forces : ndarray, shape (3,)
        Contact forces f = (J_R*)^{-T}(τ_s(q) + B_R p), N (docs/spec/model.md §7, §12).
    lengths : ndarray, shape (3,)
        ℓ_i, the bottom-face arc lengths solved for, m.
    status : int
        As :class:`Hold`'s.
    message : str
        The status in words.
    in_valid_range : bool
        Whether every fibre's stretch lies in 0.95 ≤ λ ≤ 1.5.
    in_range_of_motion : bool
        Whether every joint lies within the (nominal) finger's range of motion.
    """

    q: NDArray[np.float64]
    pressure: NDArray[np.float64]
    forces: NDArray[np.float64]
    lengths: NDArray[np.float64]
    status: int
    message: str
    in_valid_range: bool
    in_range_of_motion: bool


@dataclass(frozen=True)
class BatchEstimate:
    """:class:`Estimate`'s fields per row (N rows); ``status`` an int array, ``message`` a list.

    Attributes
    ----------
    forces, lengths : ndarray, shape (N, 3)
        As :class:`Estimate`'s, per row.
    status : ndarray of int, shape (N,)
        As :class:`Estimate`'s, per row.
    in_valid_range, in_range_of_motion : ndarray of bool, shape (N,)
        Per-row masks.
    """

    forces: NDArray[np.float64]
    lengths: NDArray[np.float64]
    status: NDArray[np.int_]
    in_valid_range: NDArray[np.bool_]
    in_range_of_motion: NDArray[np.bool_]

    @property
    def inside(self) -> NDArray[np.bool_]:
        """Per row: whether the answer lies inside the validated model."""
        return self.status == 0

    @property
    def message(self) -> list[str]:
        """Per row: the status in words."""
        return [validity_message(code) for code in self.status]
