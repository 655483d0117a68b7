"""What others ask of simulated time: pause, step, a new session, and whom lockstep waits for.

:class:`TimeServices` serves ``set_paused``, ``step`` and ``reset_simulation`` and publishes
``lockstep_controllers`` in the namespace of a :class:`.sim_time.SimulatedTime`'s owner node
(docs/spec/ros.md, "Simulated time, faster than real time, lockstep"). A step a service asks
for waits in the clock's loop until the outputs have matched every subscriber the graph lists,
at most `READER_WAIT`; no service callback waits.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

from diagnostic_msgs.msg import DiagnosticStatus
from std_srvs.srv import SetBool, Trigger

from .messages import LOCKSTEP_CONTROLLERS, RESET_SIMULATION, SET_PAUSED, STEP, status
from .node_base import ConfigurationError
from .qos import HANDED_OVER_QOS

if TYPE_CHECKING:
    from .sim_time import SimulatedTime

READER_WAIT = 2.0
"""Longest wait of a service-triggered step for new subscribers to be matched, wall s."""
WAITING = (
    f'published once every new subscriber of the outputs is matched (at most {READER_WAIT:g} s)'
)
"""What a service answers about a step it could not take at once."""
CONTROLLERS_PERIOD = 0.02
"""How often a paused clock looks again for the controllers its members have matched, wall s."""


class TimeServices:
    """The services and the ``lockstep_controllers`` topic of ``clock``'s owner node."""

    def __init__(self, clock: SimulatedTime) -> None:
        self.clock = clock
        self.requested = 0
        """Steps asked for by a service, waiting for readers to match."""
        self.requested_since = 0.0
        self.controllers: tuple[str, ...] | None = None
        self.controllers_seen = -math.inf
        owner = clock.owner
        self.controllers_publisher = owner.create_publisher(
            DiagnosticStatus, LOCKSTEP_CONTROLLERS, HANDED_OVER_QOS
        )
        owner.create_service(SetBool, SET_PAUSED, self.on_set_paused)
        owner.create_service(Trigger, STEP, self.on_step)
        owner.create_service(Trigger, RESET_SIMULATION, self.on_reset_simulation)

    # -- the services ------------------------------------------------------------------------

    def on_set_paused(
        self, request: SetBool.Request, response: SetBool.Response
    ) -> SetBool.Response:
        """Pause (data true) or resume; the answer (and the log, on a change) says the time."""
        clock = self.clock
        changed = clock.set_paused(request.data)
        response.success = True
        state = 'paused' if clock.paused else 'running'
        response.message = f'{state} at t = {clock.t:.9f} s (step {clock.step_number})'
        if changed:
            clock.owner.get_logger().info(response.message)
        self.publish_controllers(time.monotonic())
        if not clock.paused:
            clock.try_step(time.monotonic())
        return response

    def on_step(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """While paused: one step with the latest commands (:meth:`request_step`)."""
        clock = self.clock
        if not clock.paused:
            response.success = False
            response.message = 'not paused: call set_paused (true) first'
            return response
        response.success = True
        if self.request_step():
            response.message = f'stepped to t = {clock.t:.9f} s (step {clock.step_number})'
        else:
            response.message = f'step {clock.step_number + self.requested}: {WAITING}'
        return response

    def on_reset_simulation(
        self, request: Trigger.Request, response: Trigger.Response
    ) -> Trigger.Response:
        """A new session: every member rebuilt from its parameters at t = 0, step 1 published.

        Every simulation is built before any is used: a ``params_file`` that no longer loads
        refuses the reset and changes nothing.
        """
        clock = self.clock
        try:
            simulations = [member.new_simulation() for member in clock.members]
        except ConfigurationError as error:
            response.success = False
            response.message = f'simulation not reset: {error}'
            return response
        clock.restart(simulations)
        self.requested = 0
        response.success = True
        if self.request_step():
            response.message = f'simulation reset: rest state published at t = {clock.t:.9f} s'
        else:
            response.message = f'simulation reset: rest state {WAITING}'
        clock.owner.get_logger().info(response.message)
        return response

    # -- steps asked for by a service --------------------------------------------------------

    def request_step(self) -> bool:
        """A step asked for by a service; whether it was taken at once (else the loop takes it)."""
        if not self.requested:
            if self.clock.readers_matched():
                self.clock.step()
                return True
            self.requested_since = time.monotonic()
        self.requested += 1
        return False

    def take_requested(self, wall: float) -> None:
        """The loop: take the requested steps whose readers are matched or whose wait is over."""
        if not self.requested:
            return
        matched = self.clock.readers_matched()
        if not matched and wall - self.requested_since < READER_WAIT:
            return
        if not matched:
            self.clock.owner.get_logger().warning(
                f'subscribers still not matched after {READER_WAIT:g} s: taking the requested '
                'step anyway (they may miss it)'
            )
        for _ in range(self.requested):
            self.clock.step()
        self.requested = 0

    # -- whom lockstep waits for ---------------------------------------------------------------

    def look_for_controllers(self, wall: float) -> None:
        """The loop, while paused: :meth:`publish_controllers` every `CONTROLLERS_PERIOD`."""
        if wall - self.controllers_seen >= CONTROLLERS_PERIOD:
            self.publish_controllers(wall)

    def publish_controllers(self, wall: float) -> None:
        """Say on ``lockstep_controllers`` whom the members have matched both ways, if it changed.

        One KeyValue per controller, keyed by its fully qualified name
        (:meth:`.plant.Plant.lockstep_controllers`).
        """
        self.controllers_seen = wall
        members = self.clock.members
        controllers = tuple(n for member in members for n in member.lockstep_controllers())
        if controllers != self.controllers:
            self.controllers = controllers
            self.controllers_publisher.publish(
                status(
                    self.clock.owner.get_fully_qualified_name(),
                    '',
                    DiagnosticStatus.OK,
                    f'{len(controllers)} lockstep controllers matched both ways',
                    dict.fromkeys(controllers, 'publishes the commands, subscribes the states'),
                )
            )
