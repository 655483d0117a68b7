"""When the next simulated step is due in wall time, at a real-time factor (docs/spec/ros.md).

Plain Python (no ROS), so the schedule is unit-testable. The schedule is anchored: step times
are measured from the wall and simulated times of the latest :meth:`Pacer.restart`, so rounding
never accumulates and simulated time keeps pace with wall time over long runs. A plant that
falls more than ``MAX_CATCH_UP`` behind its schedule (a loaded machine, a slow controller in
lockstep) is re-anchored instead of publishing a burst of steps to catch up.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

CLOCKS = ('wall', 'sim')
"""Time sources of the plant: the system clock, or its own simulated time."""
MAX_REAL_TIME_FACTOR = 1000.0
"""Highest real-time factor a plant accepts."""
MAX_CATCH_UP = 0.1
"""Largest lag behind the schedule that is caught up with back-to-back steps, wall s."""


@dataclass(frozen=True)
class TimeSettings:
    """How simulated time runs (the plant's parameters of the same names).

    Attributes
    ----------
    real_time_factor : float
        Simulated seconds per wall second; 0 = as fast as possible.
    lockstep : bool
        One step in flight: each step waits for every member's answer.
    lockstep_timeout : float
        Wall seconds without an answer before the clock unlocks (0 = wait forever).
    start_paused : bool
        Start paused (``set_paused`` false, or ``step``, to go).
    pause_at : float
        Pause once simulated time reaches this, s (0 = never).
    run_until : float
        Take no step past this simulated time, s (0 = no limit): not a pause, raising it lets
        the steps go on. A runner keeps it a few steps ahead of what its record has received.
    """

    real_time_factor: float = 1.0
    lockstep: bool = False
    lockstep_timeout: float = 1.0
    start_paused: bool = False
    pause_at: float = 0.0
    run_until: float = 0.0


#: The parameters (plant's and hand's) that are :class:`TimeSettings` fields.
TIME_SETTING_NAMES = frozenset(field.name for field in fields(TimeSettings))


class Pacer:
    """Wall-clock schedule of simulated steps.

    Attributes
    ----------
    late_restarts : int
        How often the plant fell more than ``MAX_CATCH_UP`` behind and the schedule was
        re-anchored.
    """

    def __init__(self) -> None:
        self._wall = 0.0
        self._sim = 0.0
        self.late_restarts = 0

    def restart(self, wall: float, sim: float) -> None:
        """Anchor the schedule: simulated time ``sim`` (s) is due at wall time ``wall`` (s)."""
        self._wall, self._sim = wall, sim

    def due(self, wall: float, next_sim: float, factor: float) -> bool:
        """Whether the step to simulated time ``next_sim`` may start at wall time ``wall``.

        Parameters
        ----------
        wall : float
            Now, monotonic wall seconds.
        next_sim : float
            Simulated time of the step to take, s.
        factor : float
            Simulated seconds per wall second; 0 = no pacing (always due).
        """
        if factor == 0.0:
            return True
        target = self._wall + (next_sim - self._sim) / factor
        if wall - target > MAX_CATCH_UP:
            self.late_restarts += 1
            self.restart(wall, next_sim)  # this step now, the next ones on time from here
            return True
        return wall >= target


UNKNOWN_NODE = '_NODE_NAME_UNKNOWN_'
"""What the graph names an endpoint whose node has not been announced yet (rmw)."""


def known_node(info) -> bool:
    """Whether a graph endpoint's node is known by name yet (its participant announced it)."""
    return info.node_name != UNKNOWN_NODE
