"""``estimator``: robot-side contact forces and the patient's effective spring.

Pairs each ``chamber_pressure`` with the ``joint_states`` of its plant step by the times they
were sent (:mod:`exodigit_model.stepping.joining`) and publishes ``estimated_contact_forces``
f = (J_R*)^{-T}(τ_s(q) + B_R p) (docs/spec/model.md §7) and ``estimated_finger_torque``
τ̂_H = (J_H*)ᵀ f (§11), each stamped as the state it comes from; every ``identification_period``
it fits τ̂_H = k (q − q_r) over the last ``identification_window`` pairs and publishes k and q_r
(docs/spec/ros.md, "Nodes and topics", "The patient"); ``~/ready`` is "The session protocol",
guarantee 2.

Run: ``python -m exodigit_nodes.nodes.estimator --ros-args -p max_sample_age:=0.05``.
"""

from __future__ import annotations

import warnings
from collections import deque

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import fit_stiffness

from ..logic.estimation import Pair, SamplePairer
from ..logic.inputs import (
    InvalidInputError,
    joint_positions,
    sent_seconds,
    stamp_age,
    stamp_seconds,
)
from ..logic.parameters import describe_files
from .catalog import ESTIMATOR_NODE
from .handshake import Ready
from .message_info import WithInfo
from .messages import (
    CHAMBER_PRESSURE,
    ESTIMATED_CONTACT_FORCES,
    ESTIMATED_FINGER_STIFFNESS,
    ESTIMATED_FINGER_TORQUE,
    ESTIMATED_REST_ANGLE,
    JOINT_STATES,
    estimate_message,
    fill,
    joint_vector_message,
)
from .node_base import GloveNode, load_model
from .process import run
from .qos import READER_QOS, STREAM_QOS


class Estimator(GloveNode):
    """Wires ROS to :class:`.SamplePairer`, the model's estimate and its stiffness fit."""

    executable = ESTIMATOR_NODE.executable
    table = ESTIMATOR_NODE.table

    def __init__(self, **node_options) -> None:
        super().__init__(**node_options)
        self.model = load_model(self.values['params_file'])
        self.warm_up()
        # In simulated time the plant steps only once we have matched both topics ("The session
        # protocol", docs/spec/ros.md), and a controller in lockstep waits for every estimate.
        simulated = self.get_parameter('use_sim_time').value
        self.pairer = SamplePairer(self.values['pairing_tolerance'], trust_first=simulated)
        self.window = deque(maxlen=self.values['identification_window'])
        """The latest (angles q, rad; τ̂_H, N·m) pairs: a fit solves over them, no new estimate."""
        self.pairs = 0
        self.outside = 0
        """Estimates outside the validated model (docs/spec/ros.md, "Parameters", estimator)."""
        self.new_outside = 0
        """Of those, how many since the last report (each report after one is a WARN)."""
        self.latest_outside = ''
        self.forces = np.zeros(3)
        self.fit = None
        self.fit_problem = 'no identification yet'
        self.stiffness_message = joint_vector_message()
        self.rest_message = joint_vector_message()
        self.force_publisher = self.create_publisher(
            JointState, ESTIMATED_CONTACT_FORCES, STREAM_QOS
        )
        self.torque_publisher = self.create_publisher(
            JointState, ESTIMATED_FINGER_TORQUE, STREAM_QOS
        )
        self.stiffness_publisher = self.create_publisher(
            Float64MultiArray, ESTIMATED_FINGER_STIFFNESS, STREAM_QOS
        )
        self.rest_publisher = self.create_publisher(
            Float64MultiArray, ESTIMATED_REST_ANGLE, STREAM_QOS
        )
        # Nothing orders the two subscriptions (a starting node drains one's backlog, then the
        # other's): the pairer pairs by the times the samples were sent, not taken.
        # In simulated time every state is estimated, also while behind (docs/spec/ros.md, QoS).
        inputs = STREAM_QOS if simulated else READER_QOS
        self.create_subscription(
            Float64MultiArray, CHAMBER_PRESSURE, WithInfo(self.on_pressure), inputs
        )
        self.create_subscription(JointState, JOINT_STATES, WithInfo(self.on_joint_states), inputs)
        self.readiness = Ready(self, [self.values['glove_node']])
        self.identify_timer = self.create_timer(
            self.values['identification_period'], self.identify
        )
        self.create_timer(self.values['diagnostic_period'], self.report)
        self.get_logger().info(
            f'estimator: model from {describe_files(self.values["params_file"])}, '
            f'window {self.values["identification_window"]} pairs'
        )

    def warm_up(self) -> None:
        """Estimate once at rest, so that the compiled kernels load now, not at the first state.

        Loading takes a few hundred milliseconds, in which a lockstep plant at real-time factor 0
        steps on past the states our readers keep, and their estimates would be lost.
        """
        rest, no_pressure = np.zeros(3), np.zeros(3)
        with warnings.catch_warnings():  # whatever it says of this made-up state
            warnings.simplefilter('ignore')
            estimate = self.model.estimate(rest, no_pressure)
            self.model.contact_torque(rest, estimate.forces)

    def apply(self, settings, changed: set[str]) -> None:
        """Use a new window size or identification period (max_sample_age is read live)."""
        if 'identification_window' in changed:
            self.window = deque(maxlen=self.values['identification_window'])
        if 'identification_period' in changed:
            self.destroy_timer(self.identify_timer)
            self.identify_timer = self.create_timer(
                self.values['identification_period'], self.identify
            )

    def on_joint_states(self, message: JointState, info: dict) -> None:
        """Offer angles (rad) to the pairer at the time they were sent (refused: None)."""
        try:
            angles = joint_positions(message)
            stamp = stamp_seconds(message.header.stamp)
            stamp_age(stamp, self.now_seconds(), self.values['max_sample_age'], JOINT_STATES)
        except InvalidInputError as error:
            self.reject(JOINT_STATES, error)
            angles = None
        number = info['publication_sequence_number']
        pairs = self.pairer.add_angles(angles, sent_seconds(info), number, message)
        self.estimate(pairs, JOINT_STATES)

    def on_pressure(self, message: Float64MultiArray, info: dict) -> None:
        """Offer pressures (Pa) to the pairer at the time they were sent (refused: None)."""
        pressure = self.pressure_reading(message.data)
        self.estimate(self.pairer.add_pressure(pressure, sent_seconds(info)), CHAMBER_PRESSURE)

    def estimate(self, pairs: list[Pair], topic: str) -> None:
        """Estimate each pair the latest message on ``topic`` completed."""
        for pair in pairs:
            try:
                self.publish_estimate(pair)
            except InvalidInputError as error:
                self.reject(topic, error)

    def publish_estimate(self, pair: Pair) -> None:
        """Publish the forces (N) and finger torque (N·m) of a pair; keep it to identify."""
        try:
            estimate = self.model.estimate(pair.angles, pair.pressure)
        except ValueError as error:  # extensible segments: no bottom strain balances them
            raise InvalidInputError('no estimate', str(error)) from None
        forces = estimate.forces
        torque = self.model.contact_torque(pair.angles, forces)
        if not (np.isfinite(forces).all() and np.isfinite(torque).all()):
            raise InvalidInputError(
                'non-finite result', f'no finite force estimate at q={pair.angles.tolist()}'
            )
        self.pairs += 1
        if estimate.status != 0:
            self.outside += 1
            self.new_outside += 1
            self.latest_outside = estimate.message
        self.forces = forces
        self.force_publisher.publish(estimate_message(pair.state, forces))
        self.torque_publisher.publish(estimate_message(pair.state, torque))
        self.window.append((pair.angles, torque))

    def identify(self) -> None:
        """Fit the effective spring over the window; publish k (N·m/rad) and q_r (rad)."""
        rows = np.reshape(self.window, (-1, 2, 3))
        try:
            fit = fit_stiffness(rows[:, 0], rows[:, 1])
        except ValueError as error:
            self.fit_problem = str(error)
            return
        if not (np.isfinite(fit.stiffness).all() and np.isfinite(fit.rest_angle).all()):
            self.fit_problem = (
                f'fit not finite: k {fit.stiffness.tolist()}, rest {fit.rest_angle.tolist()}'
            )
            return
        self.fit, self.fit_problem = fit, ''
        self.stiffness_publisher.publish(fill(self.stiffness_message, fit.stiffness))
        self.rest_publisher.publish(fill(self.rest_message, fit.rest_angle))

    def report(self) -> None:
        """One /diagnostics status: pairs made, latest forces, identified stiffness.

        WARN when estimates left the validated model since the last report.
        """
        problems = []
        if self.new_outside:
            problems.append(
                f'{self.new_outside} estimates outside the validated model since the last '
                f'report (latest: {self.latest_outside})'
            )
            self.new_outside = 0
        values = {
            'pairs estimated': str(self.pairs),
            'estimated contact forces (N)': str(self.forces.tolist()),
            'window samples': str(len(self.window)),
            'unpaired samples': str(self.pairer.unpaired),
            'estimates outside the model': str(self.outside),
        }
        if self.fit is not None:
            values['finger stiffness (N·m/rad)'] = str(self.fit.stiffness.tolist())
            values['standard error (N·m/rad)'] = str(self.fit.standard_error.tolist())
            values['rest angle (rad)'] = str(self.fit.rest_angle.tolist())
            values['rest angle standard error (rad)'] = str(
                self.fit.rest_angle_standard_error.tolist()
            )
            values['fit RMSE (N·m)'] = str(self.fit.rmse.tolist())
        level = DiagnosticStatus.WARN if problems else DiagnosticStatus.OK
        notes = [*problems, f'K_H: {self.fit_problem}'] if self.fit_problem else problems
        self.publish_status(level, '; '.join(['running', *notes]), values)


def main(args: list[str] | None = None) -> int:
    """Console script ``estimator`` (``ros2 run exodigit_nodes estimator``)."""
    return run(Estimator, args)


if __name__ == '__main__':
    raise SystemExit(main())
