"""``plant``: the simulated glove (docs/spec/ros.md, "Nodes and topics").

A thin ROS wrapper around ``exodigit_model.GloveSimulation`` (docs/spec/model.md §13): each step
applies the latest valid command (``pressure_command``, or ``valve_command`` with
``actuation:=valves``, docs/spec/model.md §14) and publishes the step's outputs; ``markers`` and
``/diagnostics`` at lower rates. A refused command is logged, counted and applied nowhere; with
none for ``command_timeout`` the plant vents. ``applied_command`` says what the next step
applies, from the vent at start on (docs/spec/ros.md, "The session protocol", guarantee 4).

Time: with ``clock:=wall`` it steps on the system clock at ``rate_hz``; with ``clock:=sim`` on
simulated time (:mod:`.sim_time`, docs/spec/ros.md Part II).

Run: ``python -m exodigit_nodes.nodes.plant --ros-args -p rate_hz:=200 -r __ns:=/left/index``.
"""

from __future__ import annotations

import time
from array import array

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_model.stepping.settings import VENT
from rclpy.clock import Clock, ClockType
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from exodigit_model import JOINT_NAMES, GloveSimulation, GloveState

from ..logic.inputs import InvalidInputError, joint_vector, valve_openings
from ..logic.pacing import TIME_SETTING_NAMES
from ..logic.plant_report import plant_report
from ..logic.plant_settings import PlantSettings, plant_settings, start_line
from ..logic.watchdog import Watchdog
from .catalog import PLANT_NODE
from .handshake import Controllers, matched_every_listed
from .markers import GloveMarkers
from .messages import (
    APPLIED_COMMAND,
    CHAMBER_PRESSURE,
    CONTACT_FORCES,
    JOINT_STATES,
    MARKERS,
    PATIENT_EFFORT,
    PRESSURE_COMMAND,
    RESET,
    SEGMENT_LENGTHS,
    VALVE_COMMAND,
    fill,
    joint_vector_message,
    valve_command_message,
)
from .node_base import LOG_THROTTLE, ConfigurationError, GloveNode, load_model
from .process import run
from .qos import APPLIED_QOS, READER_QOS, STREAM_QOS
from .sim_time import SimulatedTime

LATE_FACTOR = 1.5
"""A wall-clock cycle is late when it starts more than this many periods after the previous."""
MAX_EFFORT = 10.0
"""Largest |patient effort| accepted, N·m (a finger joint makes well under 1 N·m)."""


class Plant(GloveNode):
    """The glove plant node: wires ROS to :class:`exodigit_model.GloveSimulation`.

    ``sim_time``: the simulated time this plant shares (a hand's); None: its own with
    ``clock:=sim``.
    """

    executable = PLANT_NODE.executable
    table = PLANT_NODE.table
    quiet_parameters = frozenset({'run_until'})  # raised every step by the testing kit

    def __init__(self, *, sim_time: SimulatedTime | None = None, **node_options) -> None:
        super().__init__(**node_options)
        values, settings = self.values, self.settings
        sim_clock = values['clock'] == 'sim'
        self.valves = values['actuation'] == 'valves'
        self.command_topic = VALVE_COMMAND if self.valves else PRESSURE_COMMAND
        self.vent = VENT if self.valves else np.zeros(3)
        """The command of a vent: outlets open (valves) or zero pressure (regulator)."""
        self.watchdog = Watchdog(settings.command_timeout)
        self.use_simulation(self.new_simulation())
        self.period = self.simulation.period
        self.cycles = 0
        self.late_cycles = 0
        self._last_wall: float | None = None

        # Outputs before inputs: a controller that sees our command subscription has seen them.
        self.joint_state = JointState(name=[values['joint_prefix'] + n for n in JOINT_NAMES])
        self.pressure_message = joint_vector_message()
        self.force_message = joint_vector_message()
        self.length_message = joint_vector_message()
        self.applied_message = valve_command_message() if self.valves else joint_vector_message()
        vector = Float64MultiArray
        self.pressure_publisher = self.create_publisher(vector, CHAMBER_PRESSURE, STREAM_QOS)
        self.joint_publisher = self.create_publisher(JointState, JOINT_STATES, STREAM_QOS)
        self.force_publisher = self.create_publisher(vector, CONTACT_FORCES, STREAM_QOS)
        self.length_publisher = self.create_publisher(vector, SEGMENT_LENGTHS, STREAM_QOS)
        self.applied_publisher = self.create_publisher(vector, APPLIED_COMMAND, APPLIED_QOS)
        self.outputs = (
            self.pressure_publisher,
            self.joint_publisher,
            self.force_publisher,
            self.length_publisher,
            self.applied_publisher,
        )
        self.publish_applied()
        self.marker_publisher = self.create_publisher(MarkerArray, MARKERS, STREAM_QOS)
        self.command_subscription = self.create_subscription(
            Float64MultiArray, self.command_topic, self.on_command, READER_QOS
        )
        self.create_subscription(Float64MultiArray, PATIENT_EFFORT, self.on_effort, READER_QOS)
        self.create_service(Trigger, RESET, self.on_reset)
        self.controllers = Controllers(self, self.command_subscription, self.joint_publisher)
        self.marker_timer = None
        # With clock sim the reports and markers go on the wall clock: a paused plant reports too.
        self.report_clock = (
            Clock(clock_type=ClockType.STEADY_TIME) if sim_clock else self.get_clock()
        )
        self.time: SimulatedTime | None = None
        if sim_clock:
            self.time = sim_time or SimulatedTime(self, settings.time)
            self.outputs += (self.time.clock_publisher,)
        else:
            self.create_timer(self.period, self.on_wall_timer)
        self.apply(settings, {'marker_rate_hz'})
        if self.time is not None:
            self.time.add(self)
        # Made after the step's timer: when both fire together, the report shows that step.
        self.create_timer(values['diagnostic_period'], self.report, clock=self.report_clock)
        self.get_logger().info(start_line(values, settings))

    # -- parameters ------------------------------------------------------------------------

    def make_settings(self, values) -> PlantSettings:
        """Plant settings from checked parameters; a new ``params_file`` must load."""
        if values['params_file'] != self.values['params_file']:
            try:
                load_model(values['params_file'])
            except ConfigurationError as error:
                raise ValueError(str(error)) from None
        return plant_settings(values)

    def apply(self, settings: PlantSettings, changed: set[str]) -> None:
        """Use new settings from the next step on."""
        simulation = settings.simulation
        self.simulation.configure(
            pressure_time_constant=simulation.pressure_time_constant,
            max_supply_pressure=simulation.max_supply_pressure,
            angle_noise_std=simulation.angle_noise_std,
            pressure_noise_std=simulation.pressure_noise_std,
        )
        self.watchdog.timeout = settings.command_timeout
        if 'marker_rate_hz' in changed:
            if self.marker_timer is not None:
                self.destroy_timer(self.marker_timer)
                self.marker_timer = None
            if settings.marker_rate_hz > 0.0:
                self.marker_timer = self.create_timer(
                    1.0 / settings.marker_rate_hz, self.publish_markers, clock=self.report_clock
                )
        changes = {name: getattr(settings.time, name) for name in changed & TIME_SETTING_NAMES}
        if self.time is not None and changes:
            # Only what changed: the time may be a hand's, shared with other fingers' plants.
            self.time.configure(**changes)
            for member in self.time.members:
                if member is not self:
                    member.follow_time(changes)

    def new_simulation(self) -> GloveSimulation:
        """A simulation of the current parameters (``params_file``, ``seed``...) at rest, t = 0.

        Raises
        ------
        ConfigurationError
            If ``params_file`` does not load (one line naming it).
        """
        return GloveSimulation(
            load_model(self.values['params_file']),
            self.settings.simulation,
            actuation=self.values['actuation'],
        )

    def use_simulation(self, simulation: GloveSimulation) -> None:
        """Simulate on ``simulation`` from its state on: no command, effort or failure yet."""
        self.simulation = simulation
        self.state: GloveState = simulation.state
        self.markers = GloveMarkers(simulation.model)
        self.failure_residual = 0.0
        self.failures_reported = 0
        self.forget_inputs()

    def forget_inputs(self) -> None:
        """No command and no effort until new ones come (the watchdog has seen none)."""
        self.command = self.vent
        self.effort: tuple[float, np.ndarray] | None = None  # (time received, N·m)
        self.watchdog.clear()

    def follow_time(self, changes: dict) -> None:
        """Show the time settings another plant of our shared time was set to as our own.

        Setting them applies nothing new (the time has them already), so nothing goes round.
        """
        stale = {name: value for name, value in changes.items() if self.values[name] != value}
        if stale:
            self.set_parameters([Parameter(name, value=value) for name, value in stale.items()])

    # -- inputs ----------------------------------------------------------------------------

    def on_command(self, message: Float64MultiArray) -> None:
        """Keep a valid command (Pa, or openings) and feed the watchdog; drop and count the rest.

        Either way publish ``applied_command`` (a refused command keeps the last); in lockstep
        either way it answers the latest step.
        """
        topic = self.command_topic
        try:
            if self.valves:
                self.command = valve_openings(message.data, topic)
            else:
                self.command = joint_vector(message.data, topic)
        except InvalidInputError as error:
            self.reject(topic, error)
        else:
            if self.watchdog.feed(self.time_now()):
                self.get_logger().info(f'{topic} again: venting stopped')
        self.publish_applied()
        if self.values['lockstep']:
            self.time.on_answer(self)

    def on_effort(self, message: Float64MultiArray) -> None:
        """Keep a valid patient effort (N·m per joint, u of eq 11.1) with its arrival time."""
        try:
            effort = joint_vector(message.data, PATIENT_EFFORT, MAX_EFFORT)
        except InvalidInputError as error:
            self.reject(PATIENT_EFFORT, error)
            return
        self.effort = (self.time_now(), effort)

    def publish_applied(self) -> None:
        """``applied_command``: the command the next step applies (Pa, or openings)."""
        self.applied_publisher.publish(fill(self.applied_message, self.command))

    def time_now(self) -> float:
        """The plant's time: simulated (its latest step) with clock sim, else the node clock, s."""
        return self.state.t if self.time is not None else self.now_seconds()

    def current_effort(self) -> np.ndarray | None:
        """The latest effort if younger than effort_timeout, else None (no effort)."""
        if self.effort is None or self.time_now() - self.effort[0] > self.settings.effort_timeout:
            return None
        return self.effort[1]

    def on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Pressures, angles and the last command back to rest (until a new command comes).

        With clock sim the rest state is published at once as the next step (time goes on).
        """
        self.simulation.reset()
        self.forget_inputs()
        response.success = True
        response.message = 'pressures and joint angles reset to rest; waiting for a new command'
        if self.time is not None:
            self.time.step()
            response.message += f' (rest state published at t = {self.state.t:.9f} s)'
        self.get_logger().info(response.message)
        return response

    # -- the steps -------------------------------------------------------------------------

    def on_wall_timer(self) -> None:
        """Wall clock: one step at the node clock's time, published."""
        wall = time.monotonic()
        if self._last_wall is not None and wall - self._last_wall > LATE_FACTOR * self.period:
            self.late_cycles += 1
        self._last_wall = wall
        stamp = self.get_clock().now()
        state = self.take_step(vent=self.check_watchdog(stamp.nanoseconds * 1e-9))
        self.publish_state(state, stamp.to_msg())

    def check_watchdog(self, now: float) -> bool:
        """Whether the plant vents at ``now`` (s, node or simulated time); says so once."""
        if self.watchdog.update(now):
            self.get_logger().warning(
                f'no valid {self.command_topic} for over {self.watchdog.timeout:g} s: venting'
            )
        return self.watchdog.missing(now)

    def take_step(self, *, vent: bool | None) -> GloveState:
        """One step with the latest command, or a vent, not yet published.

        ``vent`` None: the watchdog decides at the step's simulated time.
        """
        if vent is None:
            vent = self.check_watchdog(self.state.t + self.period)
        self.cycles += 1
        state = self.simulation.step(self.vent if vent else self.command, self.current_effort())
        self.state = state
        if state.saturated:
            self.get_logger().warning(
                f'{PRESSURE_COMMAND} {self.command.tolist()} Pa saturated to '
                f'[0, {self.simulation.settings.max_supply_pressure:g}] Pa',
                throttle_duration_sec=LOG_THROTTLE,
            )
        if not state.converged:
            self.failure_residual = state.residual
            self.get_logger().warning(
                f'coupled solve did not converge at p = {state.pressure.tolist()} Pa (residual '
                f'{state.residual:.3g} N·m): keeping the last good state',
                throttle_duration_sec=LOG_THROTTLE,
            )
        return state

    def publish_state(self, state: GloveState, stamp) -> None:
        """Publish the step's chamber_pressure, joint_states, contact_forces, segment_lengths."""
        message = self.joint_state
        message.header.stamp = stamp
        message.position = array('d', state.q_measured)
        message.velocity = array('d', state.qdot)
        message.effort = array('d', state.finger_torque)
        # Pressure first, the rest back to back: a step's messages are paired by the times they
        # were sent, each with the chamber_pressure before it (exodigit_model.stepping.joining).
        self.pressure_publisher.publish(fill(self.pressure_message, state.pressure_measured))
        self.joint_publisher.publish(message)
        self.force_publisher.publish(fill(self.force_message, state.forces))
        self.length_publisher.publish(fill(self.length_message, state.lengths))

    # -- asked by SimulatedTime ------------------------------------------------------------

    def readers_matched(self) -> bool:
        """Whether each output has matched every subscriber the graph knows of its topic."""
        return all(matched_every_listed(self, publisher) for publisher in self.outputs)

    def lockstep_controllers(self) -> dict[str, str]:
        """Nodes that publish our commands and subscribe our states, both matched with us.

        A lockstep plant's first step waits for one (docs/spec/ros.md, "The session protocol",
        guarantee 5): another reader of the states or another publisher of commands is not
        enough, as a controller that subscribes the states late would miss the first; nor is
        one that has not answered our handshake (:class:`.handshake.Controllers`).
        """
        return self.controllers.matched() if self.readers_matched() else {}

    def stamp(self):
        """The stamp of what the plant publishes now: simulated time, or the node clock."""
        if self.time is not None:
            return self.time.clock_message.clock
        return self.get_clock().now().to_msg()

    def publish_markers(self) -> None:
        """Publish the glove's markers at the current state (only when someone listens)."""
        if self.marker_publisher.get_subscription_count() == 0:
            return
        state = self.state
        self.marker_publisher.publish(
            self.markers.update(
                state.q, state.forces, self.stamp(), self.settings.frame_id, state.lengths
            )
        )

    # -- diagnostics -----------------------------------------------------------------------

    def report(self) -> None:
        """One /diagnostics status: solver, validity, watchdog, saturation, timing."""
        failures = self.simulation.solver_failures
        report = plant_report(
            self.state,
            self.watchdog,
            self.time_now(),
            cycles=self.cycles,
            late_cycles=self.late_cycles,
            failures=failures,
            new_failures=failures - self.failures_reported,
            failure_residual=self.failure_residual,
            saturation=self.simulation.chambers.saturation,
        )
        self.failures_reported = failures
        if self.time is None:
            problems, time_values = [], {'clock': 'wall'}
        else:
            problems, time_values = self.time.status()
        problems += report.problems
        level = DiagnosticStatus.WARN if problems else DiagnosticStatus.OK
        text = '; '.join(problems + report.notes) or 'running'
        self.publish_status(level, text, report.values | time_values, self.stamp())


def main(args: list[str] | None = None) -> int:
    """Console script ``plant`` (``ros2 run exodigit_nodes plant``)."""
    return run(Plant, args)


if __name__ == '__main__':
    raise SystemExit(main())
