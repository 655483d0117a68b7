"""Simulated time of a plant or a hand: /clock, pacing, lockstep, pause (docs/spec/ros.md Part II).

:class:`SimulatedTime` steps its *members* (plants: one, or a hand's fingers) together at t_k,
publishes ``/clock`` once per step before the members' outputs, paces the steps at
``real_time_factor`` (:class:`.pacing.Pacer`), and in lockstep waits for every member's answer;
on ``lockstep_timeout`` the silent members vent and every member steps on at real time until
they answer again. Its owner node serves what others ask of it: ``set_paused``, ``step`` and
``reset_simulation``, and whom lockstep waits for on ``lockstep_controllers`` (docs/spec/ros.md,
"Simulated time, faster than real time, lockstep").
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import TYPE_CHECKING

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMessage
from std_srvs.srv import SetBool, Trigger

from ..logic.pacing import Pacer, TimeSettings
from .messages import CLOCK, LOCKSTEP_CONTROLLERS, RESET_SIMULATION, SET_PAUSED, STEP, status
from .node_base import ConfigurationError
from .qos import HANDED_OVER_QOS, STREAM_QOS

if TYPE_CHECKING:
    from .plant import Plant

POLL_LIMITS = (0.5e-3, 0.01)
"""Shortest and longest period of the simulated-time loop's wall timer, s."""
FREE_RUN_BUDGET = 2e-3
"""Longest burst of unpaced steps before the executor takes new messages, wall s."""
MEASURE_WINDOW = 0.5
"""Shortest wall time over which the real-time factor is measured, s."""
CONTROLLERS_PERIOD = 0.02
"""How often a paused clock looks again for the controllers its members have matched, wall s."""


class SimulatedTime:
    """The simulated clock of its members, served by the node ``owner``.

    Parameters
    ----------
    owner : rclpy.node.Node
        Publishes ``/clock`` and ``lockstep_controllers``, serves the services (in its
        namespace) and runs the loop's wall timer.
    settings : TimeSettings
    """

    def __init__(self, owner: Node, settings: TimeSettings) -> None:
        self.owner = owner
        self.settings = settings
        self.members: list[Plant] = []
        self.paused = settings.start_paused
        self.started = False  # lockstep: the first step is published once every controller is here
        self.awaiting: set[Plant] = set()
        self.silent: set[Plant] = set()  # unlocked: the members whose controller went quiet
        self.waiting_since = time.monotonic()
        self.pacer = Pacer()
        self.clock_message = ClockMessage()
        self.clock_publisher = owner.create_publisher(ClockMessage, CLOCK, STREAM_QOS)
        self.wall_clock = Clock(clock_type=ClockType.STEADY_TIME)
        self.timer = None
        self._measure_marks = (time.monotonic(), 0.0)
        self._measured = 0.0
        self.controllers: dict[str, str] | None = None
        self.controllers_seen = -math.inf
        self.controllers_publisher = owner.create_publisher(
            DiagnosticStatus, LOCKSTEP_CONTROLLERS, HANDED_OVER_QOS
        )
        owner.create_service(SetBool, SET_PAUSED, self.on_set_paused)
        owner.create_service(Trigger, STEP, self.on_step)
        owner.create_service(Trigger, RESET_SIMULATION, self.on_reset_simulation)

    # -- members ---------------------------------------------------------------------------

    def add(self, member: Plant) -> None:
        """Step ``member`` with the others from now on (same rate, same simulated time).

        Raises
        ------
        ValueError
            If its period or its simulated time differs from the members' already there.
        """
        if self.members:
            first = self.members[0]
            if member.period != first.period or member.state.t != first.state.t:
                raise ValueError(
                    f'a plant at {1.0 / member.period:g} Hz, t = {member.state.t} s cannot share '
                    f'simulated time with plants at {1.0 / first.period:g} Hz, t = '
                    f'{first.state.t} s: give every finger the same rate_hz'
                )
        self.members.append(member)
        if len(self.members) == 1:
            self.restart_pacing()

    @property
    def t(self) -> float:
        """Simulated time of the latest step, s."""
        return self.members[0].state.t if self.members else 0.0

    @property
    def period(self) -> float:
        """Simulated seconds per step."""
        return self.members[0].period

    @property
    def unlocked(self) -> bool:
        """Lockstep suspended: a controller did not answer within ``lockstep_timeout``."""
        return bool(self.silent)

    # -- events ----------------------------------------------------------------------------

    def on_answer(self, member: Plant) -> None:
        """Lockstep: ``member`` has the answer to the latest step; step if everyone has."""
        self.awaiting.discard(member)
        if member in self.silent:
            self.silent.discard(member)
            member.get_logger().info(f'{member.command_topic} again: stepping in lockstep again')
            if not self.silent:
                self.restart_pacing()
        self.try_step(time.monotonic())

    def on_timer(self) -> None:
        """Take the steps that are due; paused, :meth:`publish_controllers` now and then."""
        wall = time.monotonic()
        if self.paused and wall - self.controllers_seen >= CONTROLLERS_PERIOD:
            self.publish_controllers(wall)
        if self.paused or not self.members or self.held():
            return  # a held plant waits for no controller: no lockstep timeout
        if self.settings.lockstep and self.awaiting and not self.unlocked:
            timeout = self.settings.lockstep_timeout
            if timeout == 0.0 or wall - self.waiting_since <= timeout:
                return
            for member in self.awaiting:  # never silent ones: step leaves them out
                member.get_logger().warning(
                    f'no {member.command_topic} within lockstep_timeout {timeout:g} s: venting '
                    'and stepping on at real time until a command comes'
                )
            self.silent |= self.awaiting
            self.awaiting = set()
            self.restart_pacing()
        budget = wall + FREE_RUN_BUDGET
        while self.try_step(wall) and wall < budget and not self.awaiting:
            wall = time.monotonic()

    # -- stepping --------------------------------------------------------------------------

    def try_step(self, wall: float) -> bool:
        """Take the next step if nothing holds it back; whether it was taken."""
        if self.paused or not self.members:
            return False
        if self.settings.lockstep and not self.unlocked:
            ready = self.started or all(m.lockstep_controllers() for m in self.members)
            if self.awaiting or not ready:
                return False
        if self.held() or not self.pacer.due(wall, self.t + self.period, self.pacing_factor()):
            return False
        self.step()
        return True

    def held(self) -> bool:
        """Whether the next step would go past ``run_until`` (to the nearest step)."""
        run_until = self.settings.run_until
        return run_until > 0.0 and self.t + 0.5 * self.period > run_until

    def step(self) -> None:
        """One step of every member: /clock, then each member's outputs stamped with its time."""
        lockstep = self.settings.lockstep
        states = [
            (member, member.take_step(vent=(member in self.silent) if lockstep else None))
            for member in self.members
        ]
        time_ns = states[0][1].time_ns
        self.clock_message.clock = Time(sec=time_ns // 10**9, nanosec=time_ns % 10**9)
        self.clock_publisher.publish(self.clock_message)
        for member, state in states:
            member.publish_state(state, self.clock_message.clock)
        if lockstep:
            self.started = True
            self.awaiting = set(self.members) - self.silent
            self.waiting_since = time.monotonic()

    @property
    def step_number(self) -> int:
        """The number of the latest step (0 before the first)."""
        return self.members[0].state.step if self.members else 0

    # -- what others ask of it -------------------------------------------------------------

    def on_set_paused(
        self, request: SetBool.Request, response: SetBool.Response
    ) -> SetBool.Response:
        """Pause (data true) or resume; the answer (and the log, on a change) says the time."""
        changed = request.data != self.paused
        self.paused = request.data
        if changed and not self.paused:
            self.restart_pacing()
        response.success = True
        state = 'paused' if self.paused else 'running'
        response.message = f'{state} at t = {self.t:.9f} s (step {self.step_number})'
        if changed:
            self.owner.get_logger().info(response.message)
        self.publish_controllers(time.monotonic())
        if not self.paused:
            self.try_step(time.monotonic())
        return response

    def on_step(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """While paused: one step with the latest commands, published before the answer."""
        if not self.paused:
            response.success = False
            response.message = 'not paused: call set_paused (true) first'
            return response
        self.step()
        response.success = True
        response.message = f'stepped to t = {self.t:.9f} s (step {self.step_number})'
        return response

    def on_reset_simulation(
        self, request: Trigger.Request, response: Trigger.Response
    ) -> Trigger.Response:
        """A new session: every member rebuilt from its parameters at t = 0, step 1 published.

        Every simulation is built before any is used: a ``params_file`` that no longer loads
        refuses the reset and changes nothing. Nothing is owed after it (no answer, no silence).
        """
        try:
            simulations = [member.new_simulation() for member in self.members]
        except ConfigurationError as error:
            response.success = False
            response.message = f'simulation not reset: {error}'
            return response
        for member, simulation in zip(self.members, simulations, strict=True):
            member.use_simulation(simulation)
        self.awaiting, self.silent = set(), set()
        self._measure_marks = (time.monotonic(), 0.0)
        self.restart_pacing()
        self.step()
        response.success = True
        response.message = f'simulation reset: rest state published at t = {self.t:.9f} s'
        self.owner.get_logger().info(response.message)
        return response

    def publish_controllers(self, wall: float) -> None:
        """Say on ``lockstep_controllers`` whom the members have matched both ways, if it changed.

        One KeyValue per controller: its fully qualified name, and the ids of its command
        publishers (:meth:`.plant.Plant.lockstep_controllers`).
        """
        self.controllers_seen = wall
        ids: dict[str, list[str]] = {}  # a hand's controller may command several members
        for member in self.members:
            for name, own in member.lockstep_controllers().items():
                ids.setdefault(name, []).append(own)
        controllers = {name: ' '.join(own) for name, own in sorted(ids.items())}
        if controllers != self.controllers:
            self.controllers = controllers
            self.controllers_publisher.publish(
                status(
                    self.owner.get_fully_qualified_name(),
                    '',
                    DiagnosticStatus.OK,
                    f'{len(controllers)} lockstep controllers matched both ways',
                    controllers,
                )
            )

    # -- pacing ----------------------------------------------------------------------------

    def configure(self, **changes) -> None:
        """New :class:`TimeSettings` values by keyword (a new pace takes effect at once)."""
        before = self.settings
        self.settings = replace(self.settings, **changes)
        if self.settings.real_time_factor != before.real_time_factor:
            self.restart_pacing()
        if self.settings.run_until > before.run_until and self.members:
            self.try_step(time.monotonic())  # released: the next step need not wait for a timer

    def pacing_factor(self) -> float:
        """Simulated seconds per wall second now: never faster than real time when unlocked."""
        factor = self.settings.real_time_factor
        if self.unlocked:
            return 1.0 if factor == 0.0 else min(factor, 1.0)
        return factor

    def restart_pacing(self) -> None:
        """Re-anchor the schedule at now and size the loop's wall timer to the pace."""
        wall = time.monotonic()
        self.pacer.restart(wall, self.t)
        self.waiting_since = wall
        factor = self.pacing_factor()
        low, high = POLL_LIMITS
        poll = high if factor == 0.0 and self.settings.lockstep and not self.unlocked else low
        if factor > 0.0 and self.members:
            poll = min(max(self.period / factor / 4.0, low), high)
        if self.timer is not None:
            if self.timer.timer_period_ns == round(poll * 1e9):
                return
            self.owner.destroy_timer(self.timer)
        self.timer = self.owner.create_timer(poll, self.on_timer, clock=self.wall_clock)

    # -- diagnostics -----------------------------------------------------------------------

    def status(self) -> tuple[list[str], dict[str, str]]:
        """Problems and key/values of simulated time for a /diagnostics report.

        Every member reports (a hand: several a second); the first report after
        `MEASURE_WINDOW` measures the real-time factor, the others show the same figure.
        """
        wall = time.monotonic()
        last_wall, last_sim = self._measure_marks
        if wall - last_wall >= MEASURE_WINDOW:
            self._measured = (self.t - last_sim) / (wall - last_wall)
            self._measure_marks = (wall, self.t)
        if not self.settings.lockstep:
            lockstep = 'off'
        elif self.unlocked:
            lockstep = 'unlocked: no answer within lockstep_timeout, vented'
        elif not self.started:
            lockstep = 'waiting for a controller'
        else:
            lockstep = 'waiting for the answer' if self.awaiting else 'locked'
        problems = ['lockstep: no answer, vented, stepping at real time'] if self.unlocked else []
        return problems, {
            'clock': 'sim',
            'simulated time (s)': f'{self.t:.9f}',
            'paused': str(self.paused),
            'held at run_until': str(bool(self.members) and self.held()),
            'real time factor (set)': f'{self.settings.real_time_factor:g}',
            'real time factor (measured)': f'{self._measured:.3g}',
            'lockstep': lockstep,
            'schedule restarts (late)': str(self.pacer.late_restarts),
        }
