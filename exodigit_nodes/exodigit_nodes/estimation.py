"""The estimator's bookkeeping: pairing angles with pressures, and a sliding identification window.

The plant publishes ``chamber_pressure`` and ``joint_states`` back to back in the same step. The
estimator pairs them by their DDS source timestamps (when each was published), not by arrival
order, so a late executor never pairs one step's angles with another step's pressures. Samples
left without a partner are dropped and counted.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from exodigit_model import GloveModel, StiffnessFit

PAIR_DEPTH = 8
"""Unpaired samples kept per topic while waiting for their partner."""


@dataclass(frozen=True)
class Pair:
    """Angles (rad) and pressures (Pa) published in the same plant step."""

    angles: NDArray[np.float64]
    pressure: NDArray[np.float64]


class SamplePairer:
    """Pairs ``joint_states`` and ``chamber_pressure`` samples published together.

    Parameters
    ----------
    max_gap : float
        Largest difference of the two source timestamps of a pair, s; under half the plant's
        step period, so that neighbouring steps never pair.
    """

    def __init__(self, max_gap: float) -> None:
        self.max_gap = max_gap
        self.unpaired = 0
        self._angles: deque[tuple[float, NDArray[np.float64]]] = deque()
        self._pressure: deque[tuple[float, NDArray[np.float64]]] = deque()

    def add_angles(self, angles: NDArray[np.float64], published: float) -> Pair | None:
        """Offer angles published at ``published`` (s); the pair if their pressures are here."""
        found = self._add(self._angles, self._pressure, angles, published)
        return None if found is None else Pair(angles, found)

    def add_pressure(self, pressure: NDArray[np.float64], published: float) -> Pair | None:
        """Offer pressures published at ``published`` (s); the pair if their angles are here."""
        found = self._add(self._pressure, self._angles, pressure, published)
        return None if found is None else Pair(found, pressure)

    def _add(self, mine: deque, others: deque, value, published: float):
        partner = min(others, key=lambda entry: abs(entry[0] - published), default=None)
        if partner is None or abs(partner[0] - published) > self.max_gap:
            if len(mine) == PAIR_DEPTH:
                mine.popleft()
                self.unpaired += 1
            mine.append((published, value))
            return None
        # Samples published before the pair can no longer find their partner: drop them.
        while others[0] is not partner:
            others.popleft()
            self.unpaired += 1
        others.popleft()
        while mine and mine[0][0] < published:
            mine.popleft()
            self.unpaired += 1
        return partner[1]

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
