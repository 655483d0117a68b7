"""When the next simulated step is due in wall time, at a real-time factor (no ROS).

The schedule is anchored at the latest :meth:`Pacer.restart`, so rounding never accumulates; a
plant more than ``MAX_CATCH_UP`` behind is re-anchored instead of catching up with a burst of
steps (docs/spec/ros.md, "Simulated time, faster than real time, lockstep").
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
    """How simulated time runs: the plant's parameters of the same names (:mod:`.catalog`)."""

    real_time_factor: float = 1.0
    lockstep: bool = False
    lockstep_timeout: float = 1.0
    start_paused: bool = False
    run_until: float = 0.0


#: The parameters (plant's and hand's) that are :class:`TimeSettings` fields.
TIME_SETTING_NAMES = frozenset(field.name for field in fields(TimeSettings))


class Pacer:
    """Wall-clock schedule of simulated steps; ``late_restarts`` counts re-anchorings."""

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
