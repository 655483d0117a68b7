"""``plant``: the simulated glove (INTERFACES.md).

At ``rate_hz`` it advances the chambers toward the latest valid ``pressure_command`` (first-order
lag, saturation), solves the coupled quasi-statics warm-started from the last state
(``GloveModel.solve``, MODEL.md §7) and publishes ``joint_states``, ``chamber_pressure`` and
``contact_forces``; ``markers`` and ``/diagnostics`` at lower rates. ``reset`` (std_srvs/Trigger)
puts pressures and angles back to zero. With no command for ``command_timeout`` it vents.

Run: ``python -m exodigit_nodes.plant --ros-args -p rate_hz:=200 -r __ns:=/left/index``.
"""

from __future__ import annotations

import time
from array import array
from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from exodigit_model import JOINT_NAMES

from .chambers import Chambers, ChamberSettings
from .inputs import InvalidInputError, joint_vector
from .markers import GloveMarkers
from .messages import (
    CHAMBER_PRESSURE,
    CONTACT_FORCES,
    JOINT_STATES,
    MARKERS,
    PRESSURE_COMMAND,
    RESET,
    fill,
    joint_vector_message,
)
from .node_base import LOG_THROTTLE, GloveNode, load_model, run
from .parameters import ParamSpec, ParamTable
from .qos import GLOVE_QOS
from .watchdog import Watchdog

DIAGNOSTIC_PERIOD = 1.0
"""Time between two /diagnostics reports, s."""
LATE_FACTOR = 1.5
"""A cycle is late when it starts more than this many periods after the previous one."""

PLANT_PARAMETERS = ParamTable(
    [
        ParamSpec(
            'params_file',
            '',
            'Model parameter YAML (MODEL.md §10); empty = built-in defaults',
            read_only=True,
        ),
        ParamSpec('rate_hz', 100.0, 'Simulation and publishing rate, Hz', 1.0, 5000.0, True),
        ParamSpec(
            'pressure_time_constant',
            0.05,
            'First-order chamber lag T, s (0 = ideal: chambers follow the command at once)',
            0.0,
            10.0,
        ),
        ParamSpec(
            'max_supply_pressure',
            100e3,
            'Supply saturation: commands are clipped to [0, this], Pa (reported)',
            1e3,
            1e6,
        ),
        ParamSpec(
            'command_timeout',
            0.5,
            'No valid pressure_command for this long: the chambers vent to zero, s',
            0.01,
            60.0,
        ),
        ParamSpec('angle_noise_std', 0.0, 'Joint-angle sensor noise (std), rad', 0.0, 0.1),
        ParamSpec('pressure_noise_std', 0.0, 'Pressure sensor noise (std), Pa', 0.0, 10e3),
        ParamSpec('seed', 0, 'Seed of the sensor noise', 0.0, 2.0**31 - 1, True),
        ParamSpec(
            'joint_prefix', '', 'Prefix of the joint names (<prefix>mcp, ...)', read_only=True
        ),
        ParamSpec(
            'frame_id', 'exodigit_base', 'Frame of the markers (exo-digit base)', required=True
        ),
        ParamSpec('marker_rate_hz', 10.0, 'Rate of the markers topic, Hz (0 = off)', 0.0, 100.0),
    ]
)


@dataclass(frozen=True)
class PlantSettings:
    """The plant's run-time settings (SI), from its parameters."""

    chambers: ChamberSettings
    command_timeout: float
    angle_noise_std: float
    frame_id: str
    marker_rate_hz: float


class Plant(GloveNode):
    """The glove plant node: wires ROS to :class:`.Chambers` and ``GloveModel``."""

    events_executor = True
    executable = 'plant'
    table = PLANT_PARAMETERS

    def __init__(self) -> None:
        super().__init__()
        values, settings = self.values, self.settings
        self.model = load_model(values['params_file'])
        self.stiffness = np.asarray(self.model.geometry.stiffness)
        self.period = 1.0 / values['rate_hz']
        noise_streams = np.random.SeedSequence(values['seed']).spawn(2)
        self.chambers = Chambers(settings.chambers, np.random.default_rng(noise_streams[0]))
        self.angle_rng = np.random.default_rng(noise_streams[1])
        self.watchdog = Watchdog(settings.command_timeout)
        self.command = np.zeros(3)
        self.angles = np.zeros(3)
        self.forces = np.zeros(3)
        self.solution = None
        self.last_good = None  # the last converged Solution: the warm start of the next solve
        self.solver_failures = 0
        self.failure_residual = 0.0
        self.failures_reported = 0
        self.cycles = 0
        self.late_cycles = 0
        self._last_wall: float | None = None
        self.markers = GloveMarkers(self.model)

        self.joint_state = JointState()
        self.joint_state.name = [values['joint_prefix'] + name for name in JOINT_NAMES]
        self.pressure_message = joint_vector_message()
        self.force_message = joint_vector_message()
        self.joint_publisher = self.create_publisher(JointState, JOINT_STATES, GLOVE_QOS)
        self.pressure_publisher = self.create_publisher(
            Float64MultiArray, CHAMBER_PRESSURE, GLOVE_QOS
        )
        self.force_publisher = self.create_publisher(Float64MultiArray, CONTACT_FORCES, GLOVE_QOS)
        self.marker_publisher = self.create_publisher(MarkerArray, MARKERS, GLOVE_QOS)
        self.create_subscription(Float64MultiArray, PRESSURE_COMMAND, self.on_command, GLOVE_QOS)
        self.create_service(Trigger, RESET, self.on_reset)
        self.timer = self.create_timer(self.period, self.step)
        self.create_timer(DIAGNOSTIC_PERIOD, self.report)
        self.marker_timer = None
        self.apply(settings, {'marker_rate_hz'})
        self.get_logger().info(
            f'plant running at {values["rate_hz"]:g} Hz, model from '
            f'{values["params_file"] or "built-in defaults"}, chamber lag '
            f'{settings.chambers.time_constant:g} s, command timeout '
            f'{settings.command_timeout:g} s'
        )

    # -- parameters ------------------------------------------------------------------------

    def make_settings(self, values) -> PlantSettings:
        """Plant settings from checked parameters (ValueError naming the parameter)."""
        return PlantSettings(
            chambers=ChamberSettings(
                time_constant=values['pressure_time_constant'],
                max_supply_pressure=values['max_supply_pressure'],
                noise_std=values['pressure_noise_std'],
            ),
            command_timeout=values['command_timeout'],
            angle_noise_std=values['angle_noise_std'],
            frame_id=values['frame_id'],
            marker_rate_hz=values['marker_rate_hz'],
        )

    def apply(self, settings: PlantSettings, changed: set[str]) -> None:
        """Use new settings from the next step on."""
        self.chambers.configure(settings.chambers)
        self.watchdog.timeout = settings.command_timeout
        if 'marker_rate_hz' in changed:
            if self.marker_timer is not None:
                self.destroy_timer(self.marker_timer)
                self.marker_timer = None
            if settings.marker_rate_hz > 0.0:
                self.marker_timer = self.create_timer(
                    1.0 / settings.marker_rate_hz, self.publish_markers
                )

    # -- inputs ----------------------------------------------------------------------------

    def on_command(self, message: Float64MultiArray) -> None:
        """Keep a valid command (Pa) and feed the watchdog; drop and count anything else."""
        try:
            self.command = joint_vector(message.data, PRESSURE_COMMAND)
        except InvalidInputError as error:
            self.reject(PRESSURE_COMMAND, error)
            return
        self.watchdog.feed(self.now_seconds())

    def on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Pressures, angles and the last command back to zero (until a new command comes)."""
        self.chambers.reset()
        self.command = np.zeros(3)
        self.angles = np.zeros(3)
        self.forces = np.zeros(3)
        self.last_good = None
        self.watchdog.clear()
        response.success = True
        response.message = 'pressures and joint angles reset to zero; waiting for a new command'
        self.get_logger().info(response.message)
        return response

    # -- the step --------------------------------------------------------------------------

    def _count_cycle(self) -> None:
        wall = time.monotonic()
        if self._last_wall is not None and wall - self._last_wall > LATE_FACTOR * self.period:
            self.late_cycles += 1
        self._last_wall = wall
        self.cycles += 1

    def step(self) -> None:
        """One cycle: command → chambers → coupled solve → publish."""
        self._count_cycle()
        stamp = self.get_clock().now()
        if self.watchdog.expired(stamp.nanoseconds * 1e-9):
            command = np.zeros(3)
            if self.watchdog.tripped:
                self.get_logger().warning(
                    f'no valid {PRESSURE_COMMAND} for over {self.watchdog.timeout:g} s: venting',
                    throttle_duration_sec=LOG_THROTTLE,
                )
        else:
            command = self.command
        pressure = self.chambers.advance(command, self.period)
        if self.chambers.saturated_now:
            self.get_logger().warning(
                f'{PRESSURE_COMMAND} {command.tolist()} Pa saturated to '
                f'[0, {self.chambers.settings.max_supply_pressure:g}] Pa',
                throttle_duration_sec=LOG_THROTTLE,
            )
        # A previous Solution as the start also reuses its evaluation (exodigit_model docs).
        start = self.angles if self.last_good is None else self.last_good
        solution = self.model.solve(pressure, q0=start)
        self.solution = solution
        previous = self.angles
        if solution.converged:
            self.angles, self.forces = solution.q, solution.forces
            self.last_good = solution
        else:
            self.solver_failures += 1
            self.failure_residual = solution.residual
            self.get_logger().warning(
                f'coupled solve did not converge at p = {pressure.tolist()} Pa (residual '
                f'{solution.residual:.3g} N·m): keeping the last good state',
                throttle_duration_sec=LOG_THROTTLE,
            )
        self.publish_state(stamp.to_msg(), previous)

    def publish_state(self, stamp, previous: np.ndarray) -> None:
        """Publish joint_states, chamber_pressure and contact_forces of the current state."""
        angles = self.angles
        std = self.settings.angle_noise_std
        measured = angles + self.angle_rng.normal(0.0, std, 3) if std > 0.0 else angles
        state = self.joint_state
        state.header.stamp = stamp
        state.position = array('d', measured)
        state.velocity = array('d', (angles - previous) / self.period)
        state.effort = array('d', self.stiffness * angles)
        fill(self.pressure_message, self.chambers.measured())
        fill(self.force_message, self.forces)
        # Back to back: the estimator pairs these two by their publication times.
        self.pressure_publisher.publish(self.pressure_message)
        self.joint_publisher.publish(state)
        self.force_publisher.publish(self.force_message)

    def publish_markers(self) -> None:
        """Publish the glove's markers at the current state (only when someone listens)."""
        if self.marker_publisher.get_subscription_count() == 0:
            return
        stamp = self.get_clock().now().to_msg()
        self.marker_publisher.publish(
            self.markers.update(self.angles, self.forces, stamp, self.settings.frame_id)
        )

    # -- diagnostics -----------------------------------------------------------------------

    def report(self) -> None:
        """One /diagnostics status: solver, validity, watchdog, saturation, timing."""
        now = self.now_seconds()
        solution = self.solution
        problems = []
        if self.watchdog.tripped:
            problems.append(f'watchdog: no command for {self.watchdog.age(now):.2f} s, vented')
        if self.solver_failures > self.failures_reported:
            problems.append(
                f'solver did not converge {self.solver_failures - self.failures_reported} times '
                f'(last residual {self.failure_residual:.3g} N·m), kept the last good state'
            )
            self.failures_reported = self.solver_failures
        if solution is not None and not solution.in_valid_range:
            problems.append('outside the validated stretch range 1 <= lambda <= 1.5')
        if self.chambers.saturated_now:
            problems.append('command saturated to the supply range')
        values = {
            'joint angles (rad)': str(self.angles.tolist()),
            'chamber pressure (Pa)': str(self.chambers.pressure.tolist()),
            'solver iterations': str(solution.iterations if solution else 0),
            'solver residual (N·m)': f'{solution.residual if solution else 0.0:.3g}',
            'solver failures': str(self.solver_failures),
            'in valid range': str(bool(solution.in_valid_range) if solution else True),
            'watchdog': 'venting'
            if self.watchdog.tripped
            else ('waiting for a command' if self.watchdog.last_feed is None else 'ok'),
            'command age (s)': f'{self.watchdog.age(now):.3f}',
            'watchdog trips': str(self.watchdog.trips),
            'saturated below 0': str(self.chambers.saturation.below_zero),
            'saturated above supply': str(self.chambers.saturation.above_supply),
            'cycles': str(self.cycles),
            'late cycles': str(self.late_cycles),
        }
        level = DiagnosticStatus.WARN if problems else DiagnosticStatus.OK
        self.publish_status(level, '; '.join(problems) or 'running', values)


def main(args: list[str] | None = None) -> int:
    """Console script ``plant`` (``ros2 run exodigit_nodes plant``)."""
    return run(Plant, args)


if __name__ == '__main__':
    raise SystemExit(main())
