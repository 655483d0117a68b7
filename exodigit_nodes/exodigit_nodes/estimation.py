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

from exodigit_model import GloveModel, StiffnessFit

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
    """The last ``size`` pairs, and the finger stiffness K_H identified from them.

    Parameters
    ----------
    model : GloveModel
        Model of the exo-digit used for the robot-side force estimate.
    size : int
        Number of pairs kept (the oldest is dropped first).
    """

    def __init__(self, model: GloveModel, size: int) -> None:
        self.model = model
        self.size = size
        self._angles = np.zeros((size, 3))
        self._pressure = np.zeros((size, 3))
        self.count = 0
        self._next = 0

    def add(self, pair: Pair) -> None:
        """Put one pair in, dropping the oldest when full."""
        self._angles[self._next] = pair.angles
        self._pressure[self._next] = pair.pressure
        self._next = (self._next + 1) % self.size
        self.count = min(self.count + 1, self.size)

    def clear(self) -> None:
        """Empty the window."""
        self.count = self._next = 0

    def fit(self) -> StiffnessFit:
        """Least-squares K_H over the window (``GloveModel.fit_stiffness``).

        Raises
        ------
        ValueError
            If the window is empty or a joint never moved in it.
        """
        return self.model.fit_stiffness(self._angles[: self.count], self._pressure[: self.count])
