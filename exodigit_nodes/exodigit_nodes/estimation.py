"""The estimator's bookkeeping: pairing angles with pressures, and a sliding identification window.

The plant publishes one ``chamber_pressure`` and one ``joint_states`` per step, so the n-th
message of one publisher and the n-th of the other describe the same step: DDS numbers them
(the publication sequence number in rclpy's message info). The estimator pairs by that number,
not by arrival order or time, so neither a late executor nor a preempted plant can pair one
step's angles with another step's pressures. Samples whose partner never comes are dropped and
counted.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from exodigit_model import StiffnessFit, fit_stiffness

PAIR_DEPTH = 16
"""Unpaired samples kept per topic while waiting for their partner."""


@dataclass(frozen=True)
class Pair:
    """Angles (rad) and pressures (Pa) of the same plant step."""

    angles: NDArray[np.float64]
    pressure: NDArray[np.float64]


class SamplePairer:
    """Pairs ``joint_states`` and ``chamber_pressure`` samples that carry the same step number."""

    def __init__(self) -> None:
        self.unpaired = 0
        self._angles: deque[tuple[int, NDArray[np.float64]]] = deque()
        self._pressure: deque[tuple[int, NDArray[np.float64]]] = deque()

    def add_angles(self, angles: NDArray[np.float64], step: int) -> Pair | None:
        """Offer the angles of step ``step``; the pair if that step's pressures are here."""
        found = self._add(self._angles, self._pressure, angles, step)
        return None if found is None else Pair(angles, found)

    def add_pressure(self, pressure: NDArray[np.float64], step: int) -> Pair | None:
        """Offer the pressures of step ``step``; the pair if that step's angles are here."""
        found = self._add(self._pressure, self._angles, pressure, step)
        return None if found is None else Pair(found, pressure)

    def _add(self, mine: deque, others: deque, value, step: int):
        index = next((i for i, (key, _) in enumerate(others) if key == step), None)
        if index is None:
            if len(mine) == PAIR_DEPTH:
                mine.popleft()
                self.unpaired += 1
            mine.append((step, value))
            return None
        # Each topic arrives in order: what came before the partner will find no partner now.
        for _ in range(index):
            others.popleft()
        _, partner = others.popleft()
        self.unpaired += index + len(mine)
        mine.clear()
        return partner

    def clear(self) -> None:
        """Forget every waiting sample."""
        self._angles.clear()
        self._pressure.clear()


class StiffnessWindow:
    """The last ``size`` estimates (angles and τ̂_H), and the finger stiffness fitted to them.

    Each pair is estimated once, when it arrives (the node publishes that estimate); the window
    keeps its angles and estimated finger torque, so a fit costs a least-squares solve, not
    ``size`` force estimates (with extensible segments each is a root-find, MODEL.md §12).

    Parameters
    ----------
    size : int
        Number of estimates kept (the oldest is dropped first).
    """

    def __init__(self, size: int) -> None:
        self.size = size
        self._angles = np.zeros((size, 3))
        self._torque = np.zeros((size, 3))
        self.count = 0
        self._next = 0

    def add(self, angles: NDArray[np.float64], finger_torque: NDArray[np.float64]) -> None:
        """Put in one estimate: angles q (rad) and τ̂_H (N·m); drops the oldest when full."""
        self._angles[self._next] = angles
        self._torque[self._next] = finger_torque
        self._next = (self._next + 1) % self.size
        self.count = min(self.count + 1, self.size)

    def clear(self) -> None:
        """Empty the window."""
        self.count = self._next = 0

    def fit(self) -> StiffnessFit:
        """The least-squares spring τ̂_H,k = k_k (q_k − q_r,k) over the window.

        Raises
        ------
        ValueError
            If the window is empty or a joint never moved in it.
        """
        return fit_stiffness(self._angles[: self.count], self._torque[: self.count])
