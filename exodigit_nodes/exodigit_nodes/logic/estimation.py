"""Pairing ``joint_states`` with the ``chamber_pressure`` of the same plant step (no ROS).

By the times they were sent (docs/running.md, "How signals are paired";
:mod:`exodigit_model.stepping.joining`). Sequence numbers only reveal losses: when a step's
angles and the next step's pressure are both lost, times alone would pair a pressure with the
next step's angles, so angles whose number does not follow one received pair with nothing. So
do the first angles received, unless the node must answer every state (``trust_first``): a node
that joins a running plant matches its two publishers one after the other, so it may hear the
pressure of the step before them without that step's angles, and nothing orders its two
readers, so it may take them before their own pressure (a starting node drains one reader's
backlog, then the other's), and times alone would pair them with that pressure.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exodigit_model import Joined, Joiner

ANGLES = 'joint_states'
PRESSURE = 'chamber_pressure'
RECENT_NUMBERS = 32
"""Publication numbers remembered (several publishers on one topic each number their own)."""


@dataclass(frozen=True)
class Pair:
    """Angles (rad) and pressures (Pa) of the same plant step.

    ``state`` is what the node passed along with the angles: the ``joint_states`` message they
    came in (its stamp and joint names go on the estimates), or None.
    """

    angles: NDArray[np.float64]
    pressure: NDArray[np.float64]
    state: Any = None


class SamplePairer:
    """Pairs ``joint_states`` and ``chamber_pressure`` samples by the times they were sent.

    A sample the node refused is offered as None (it keeps its place: ``Joiner``). Pairs are
    returned as soon as they are complete (a controller in lockstep waits for them).

    Parameters
    ----------
    tolerance : float
        Longest time from a pressure to the angles paired with it, s (``Joiner``).
    trust_first : bool
        Whether the first angles received pair like any others. False (the module docstring):
        they pair with nothing, but for a publisher's first (number 1: it sent nothing before
        them). True for a node in lockstep, which must answer every state it hears and whose
        plant steps only once it has matched both topics (docs/spec/ros.md, "The session
        protocol"), so that it hears both from the same step.
    """

    def __init__(self, tolerance: float, *, trust_first: bool = False) -> None:
        self._joiner = Joiner((PRESSURE, ANGLES), tolerance=tolerance)
        self._angle_numbers: deque[int] = deque(maxlen=RECENT_NUMBERS)
        self._trust_first = trust_first

    @property
    def unpaired(self) -> int:
        """Samples dropped without a partner so far."""
        return self._joiner.unpaired

    def add_angles(
        self, angles: NDArray[np.float64] | None, sent: float, number: int, state: Any = None
    ) -> list[Pair]:
        """Offer the angles sent at ``sent`` (s, source timestamp), publication ``number``.

        ``state`` (the message they came in) is handed on with the pair they make.
        """
        numbers = self._angle_numbers
        first = self._trust_first and not numbers
        follows = number == 1 or first or number - 1 in numbers
        numbers.append(number)
        usable = follows and angles is not None
        return self._pairs(self._joiner.add(ANGLES, sent, (angles, state) if usable else None))

    def add_pressure(self, pressure: NDArray[np.float64] | None, sent: float) -> list[Pair]:
        """Offer the pressures sent at ``sent`` (s, source timestamp); the pairs they complete."""
        return self._pairs(self._joiner.add(PRESSURE, sent, pressure))

    @staticmethod
    def _pairs(groups: list[Joined]) -> list[Pair]:
        pairs = []
        for group in groups:
            offered, pressure = group.values[ANGLES], group.values[PRESSURE]
            if offered is not None and pressure is not None:
                angles, state = offered
                pairs.append(Pair(angles, pressure, state))
        return pairs
