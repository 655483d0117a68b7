"""What the bridge sends to the board, and why (docs/spec/hardware.md §7), without ROS.

:class:`Bridge` stands between a controller's openings and a :class:`~.link.HostLink`: it
vents at every new session and whenever the link is lost, vents when the controller goes quiet
for ``command_timeout``, and closes the inlet (opening the outlet) of any chamber whose latest
reading is at or above ``max_pressure``. It never raises for what the board or the controller
sends; the ROS node (:mod:`exodigit_nodes.nodes.hardware`) only carries its inputs and outputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from exodigit_model.checks import check_positive
from exodigit_model.stepping.settings import VENT

from .link import Connected, Event, HostLink, LinkLost, LinkState, SampleReceived
from .messages import CHAMBERS, duties_of, openings_of


@dataclass(frozen=True)
class BridgeSettings:
    """The bridge's safety settings (SI).

    Attributes
    ----------
    max_pressure : float
        A chamber reading at or above this gets no air: its inlet is closed and its outlet
        opened, Pa.
    command_timeout : float
        No command for this long: vent, s.
    """

    max_pressure: float = 80e3
    command_timeout: float = 0.5

    def __post_init__(self) -> None:
        """Refuse values that break a rule, naming the field, the value and the rule."""
        check_positive('max_pressure', self.max_pressure, 'Pa')
        check_positive('command_timeout', self.command_timeout, 's')


@dataclass(frozen=True)
class Limited:
    """Openings changed by the pressure limit: the chambers (0-2) at or above it."""

    chambers: tuple[int, ...]
    pressures: tuple[float, ...]


@dataclass(frozen=True)
class Vented:
    """The bridge vented, and why (one line)."""

    reason: str


@dataclass(frozen=True)
class Sent:
    """Openings the bridge sent (or would have: ``delivered`` False while the link is down)."""

    openings: np.ndarray
    delivered: bool


class Bridge:
    """The controller's openings to the board, with the safety rules.

    Attributes
    ----------
    openings : ndarray
        The six openings last sent (or held back while no board listens): what the board
        applies once it gets them.
    pressures : ndarray or None
        The latest chamber readings, Pa (None before any sample of the session).
    limited : int
        Commands and samples at which the pressure limit changed the openings.
    vents : int
        Vents for a lost link or a quiet controller.
    """

    def __init__(self, link: HostLink, settings: BridgeSettings) -> None:
        self.link = link
        self.settings = settings
        self.openings = VENT.copy()
        self.wanted: np.ndarray | None = None
        """The controller's latest openings (None: none, or vented since)."""
        self.last_command = -math.inf
        self.pressures: np.ndarray | None = None
        self.limited = 0
        self.vents = 0

    def command(self, openings: np.ndarray, now: float) -> list:
        """A controller's six openings in [0, 1] (checked by the caller) at ``now``; events."""
        self.wanted = np.array(openings, dtype=float)
        self.last_command = now
        return self._send(now)

    def poll(self, now: float) -> list:
        """Run the link (:meth:`HostLink.poll`) and the safety rules; the link's and ours.

        Raises
        ------
        IncompatibleBoardError
            From the link: the board answered with another version or shape.
        """
        events: list = []
        for event in self.link.poll(now):
            events.append(event)
            events += self._after(event, now)
        if self.wanted is not None and now - self.last_command > self.settings.command_timeout:
            self.wanted = None
            events += self.vent(
                now, f'no valve_command for over {self.settings.command_timeout:g} s'
            )
        return events

    def vent(self, now: float, reason: str) -> list:
        """Vent (inlets closed, outlets open), forgetting the controller's openings; events."""
        self.wanted = None
        self.vents += 1
        return [Vented(reason), *self._send(now)]

    def _after(self, event: Event, now: float) -> list:
        if isinstance(event, Connected):
            self.wanted = None
            self.pressures = None
            return self._send(now)  # the vent first (docs/spec/hardware.md §4)
        if isinstance(event, LinkLost):
            self.pressures = None
            return self.vent(now, f'link lost: {event.reason}')
        if isinstance(event, SampleReceived):
            self.pressures = np.array(event.sample.pressures_pa, dtype=float)
            over = self._over()
            if over and self.openings[list(over)].any():
                return self._send(now)
        return []

    def _over(self) -> tuple[int, ...]:
        """The chambers whose latest reading is at or above max_pressure."""
        if self.pressures is None:
            return ()
        return tuple(int(i) for i in np.flatnonzero(self.pressures >= self.settings.max_pressure))

    def _send(self, now: float) -> list:
        """Send the controller's openings (or the vent) after the pressure limit; events."""
        events: list = []
        openings = VENT.copy() if self.wanted is None else self.wanted.copy()
        over = self._over()
        if over and openings[list(over)].any():
            for chamber in over:
                openings[chamber], openings[CHAMBERS + chamber] = 0.0, 1.0
            self.limited += 1
            events.append(Limited(over, tuple(self.pressures[list(over)].tolist())))
        duties = duties_of(openings)
        self.openings = openings_of(duties)
        delivered = False
        if self.link.state in (LinkState.STREAMING, LinkState.SILENT):
            delivered = self.link.send_openings(duties, now) is not None
        events.append(Sent(self.openings, delivered))
        return events
