"""What the testing kit returns: one plant step (:class:`SimState`), a run (:class:`SimRecord`).

Both kinds of run record (this :class:`SimRecord` and the targets run's ``TargetRecord``) are a
:class:`StateHistory` with their commands added.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class SimState:
    """One plant step as published (SI units; joint order MCP, PIP, DIP).

    Attributes
    ----------
    t : float
        Simulated time of the step, s (the stamp of ``joint_states``).
    q : ndarray, shape (3,)
        Joint angles (``joint_states`` position, with the plant's sensor noise), rad.
    qdot : ndarray, shape (3,)
        Joint velocities, rad/s.
    effort : ndarray, shape (3,)
        Finger joint torque from the exo-digit, N·m.
    pressure : ndarray, shape (3,)
        Chamber pressures (``chamber_pressure``), Pa.
    forces : ndarray, shape (3,)
        Simulated contact forces (``contact_forces``), N.
    lengths : ndarray, shape (3,)
        ℓ_i, the segments' bottom-face arc lengths (``segment_lengths``), m: the rest lengths
        unless a segment is extensible (docs/spec/model.md §12).
    estimated_forces : ndarray, shape (3,), or None
        The estimator's robot-side estimate of this step, N (None without the estimator).
    """

    t: float
    q: NDArray[np.float64]
    qdot: NDArray[np.float64]
    effort: NDArray[np.float64]
    pressure: NDArray[np.float64]
    forces: NDArray[np.float64]
    lengths: NDArray[np.float64]
    estimated_forces: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class StateHistory:
    """Published plant states stacked by step (SI units; joint order MCP, PIP, DIP).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Simulated time of each state, s (the stamps of ``joint_states``).
    q, qdot, pressure, forces, lengths : ndarray, shape (n, 3)
        The fields of :class:`SimState` by step (rad, rad/s, Pa, N, m).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qdot: NDArray[np.float64]
    pressure: NDArray[np.float64]
    forces: NDArray[np.float64]
    lengths: NDArray[np.float64]


@dataclass(frozen=True)
class SimRecord(StateHistory):
    """The states of a :meth:`GloveSim.run` and the commands that answered them.

    Row i is one step: its state and ``command[i]``, the command the plant took in answer to
    it (``applied_command``: the controller's answer, or the command before if the plant refused
    the answer) and applies in the next step, Pa, shape (n, 3); with valves the openings, shape
    (n, 6).
    """

    command: NDArray[np.float64]


def state_arrays(states: list[SimState]) -> dict[str, NDArray[np.float64]]:
    """The published fields of ``states`` stacked by step, as a :class:`StateHistory`'s fields."""
    return {
        name: np.array([getattr(s, name) for s in states])
        for name in (f.name for f in fields(StateHistory))
    }
