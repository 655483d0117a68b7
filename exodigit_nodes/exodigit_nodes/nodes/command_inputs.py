"""What ``pressure_command`` hears: joint states, contact-force estimates, chamber pressures.

:class:`CommandInputs` keeps the latest valid sample of each with its arrival time (node clock,
s) and, in lockstep, hands the node each state once complete: in ``force`` mode with the estimate
stamped with its stamp, with valves with the ``chamber_pressure`` of its step, paired as the
estimator pairs them (a refused state keeps its place in the pairing and is not answered).
docs/spec/ros.md, "Simulated time, faster than real time, lockstep" and "Valves".
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from exodigit_model.stepping.joining import STEP_TOLERANCE
from rclpy.clock import Clock, ClockType
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from ..logic.estimation import Pair, SamplePairer
from ..logic.inputs import (
    NANOSECONDS,
    InvalidInputError,
    joint_positions,
    joint_vector,
    sent_seconds,
    stamp_age,
    stamp_nanoseconds,
)
from .message_info import WithInfo
from .messages import CHAMBER_PRESSURE, ESTIMATED_CONTACT_FORCES, JOINT_STATES
from .qos import READER_QOS

if TYPE_CHECKING:
    from .pressure_command import PressureCommand

MAX_FORCE_READING = 1e3
"""Largest |estimated contact force| accepted as a measurement, N."""
ESTIMATOR_POLL = 0.05
"""Lockstep force mode: wall seconds between two looks for the estimator's publisher."""

Sample = tuple[float, np.ndarray]
"""A value and when it arrived (node clock, s)."""


class CommandInputs:
    """The feedback subscriptions of ``node`` (``pressure_command``) and their latest samples.

    Parameters
    ----------
    node : PressureCommand
        Makes the subscriptions, logs, counts rejected messages, and in lockstep answers each
        complete state (:meth:`.PressureCommand.answer`); its ``lockstep``, ``valves`` and
        parameter values (``mode``, ``feedback_timeout``) are read when needed.
    """

    def __init__(self, node: PressureCommand) -> None:
        self.node = node
        self.angles: Sample | None = None
        self.forces: Sample | None = None
        self.pressure: Sample | None = None
        lockstep_valves = node.valves and node.lockstep
        self.pairer = SamplePairer(STEP_TOLERANCE, trust_first=True) if lockstep_valves else None
        """Lockstep valves: pairs each state with its step's pressure, the first heard too."""
        # Lockstep: the state (stamp (ns), angles, chamber pressures) not answered yet, and in
        # force mode the latest estimate (stamp, forces) not used yet.
        self.waiting_state: tuple[int, np.ndarray, np.ndarray | None] | None = None
        self.waiting_estimate: tuple[int, np.ndarray] | None = None
        if node.valves:
            node.create_subscription(
                Float64MultiArray, CHAMBER_PRESSURE, WithInfo(self.on_pressure), READER_QOS
            )
        self.forces_subscription = node.create_subscription(
            JointState, ESTIMATED_CONTACT_FORCES, self.on_forces, READER_QOS
        )
        self.estimator_timer = None
        if node.lockstep and node.values['mode'] == 'force':
            # Read states (and so count as the plant's lockstep controller) only once the
            # estimator is matched, or the first state's estimate could come before we hear it.
            self.estimator_timer = node.create_timer(
                ESTIMATOR_POLL,
                self.listen_once_estimated,
                clock=Clock(clock_type=ClockType.STEADY_TIME),
            )
            node.get_logger().info(
                f'lockstep force mode: answering {JOINT_STATES} once an estimator on '
                f'{ESTIMATED_CONTACT_FORCES} is matched'
            )
        else:
            self.listen_to_states()

    def forget(self) -> None:
        """A new session: forget a state waiting for its estimate or pressure.

        An estimate waiting is kept: it may be the new session's, come before its state (pairing
        is by stamp, so an older one never pairs with a new session's state).
        """
        self.waiting_state = None

    def fresh(self, sample: Sample | None, now: float) -> np.ndarray | None:
        """The sample's value if it is younger than feedback_timeout at ``now`` (s), else None."""
        if sample is None or now - sample[0] > self.node.values['feedback_timeout']:
            return None
        return sample[1]

    def listen_to_states(self) -> None:
        """Subscribe ``joint_states`` (the state each command answers in lockstep)."""
        self.node.create_subscription(
            JointState, JOINT_STATES, WithInfo(self.on_joint_states), READER_QOS
        )

    def listen_once_estimated(self) -> None:
        """Lockstep force mode: subscribe states once every estimator publisher is matched."""
        matched = self.forces_subscription.get_publisher_count()
        listed = self.node.count_publishers(self.forces_subscription.topic_name)
        if matched == 0 or matched < listed:
            return
        self.node.destroy_timer(self.estimator_timer)
        self.estimator_timer = None
        self.listen_to_states()
        self.node.get_logger().info(f'estimator matched: answering {JOINT_STATES}')

    def on_joint_states(self, message: JointState, info: dict) -> None:
        """Keep valid, recently stamped joint angles (rad) with their arrival time.

        In lockstep the stamp is the time itself, not compared with the node clock (which may
        not have heard ``/clock`` yet).
        """
        stamp = stamp_nanoseconds(message.header.stamp)
        try:
            angles = joint_positions(message)
            if not self.node.lockstep:
                now, timeout = self.node.now_seconds(), self.node.values['feedback_timeout']
                stamp_age(stamp / NANOSECONDS, now, timeout, JOINT_STATES, 'feedback_timeout')
        except InvalidInputError as error:
            self.node.reject(JOINT_STATES, error)
            angles = None
        if self.pairer is not None:
            number = info['publication_sequence_number']
            self.take_pairs(self.pairer.add_angles(angles, sent_seconds(info), number, stamp))
        elif angles is not None:
            self.take_state(stamp, angles, None)

    def on_pressure(self, message: Float64MultiArray, info: dict) -> None:
        """Valves: keep a valid measured chamber pressure (Pa) with its arrival time."""
        pressure = self.node.pressure_reading(message.data)
        if pressure is not None:
            self.pressure = (self.node.now_seconds(), pressure)
        if self.pairer is not None:
            self.take_pairs(self.pairer.add_pressure(pressure, sent_seconds(info)))

    def take_pairs(self, pairs: list[Pair]) -> None:
        """Lockstep valves: take each state paired with its pressure (``Pair.state``: stamp)."""
        for pair in pairs:
            self.take_state(pair.state, pair.angles, pair.pressure)

    def take_state(self, stamp: int, angles: np.ndarray, pressure: np.ndarray | None) -> None:
        """Take a valid state stamped ``stamp`` (ns); in lockstep, answer it once complete."""
        self.angles = (self.node.now_seconds(), angles)
        if self.node.lockstep:
            self.waiting_state = (stamp, angles, pressure)
            self.complete()

    def on_forces(self, message: JointState) -> None:
        """Keep valid estimated forces (N, ``effort``) with their arrival time and stamp."""
        try:
            forces = joint_vector(message.effort, ESTIMATED_CONTACT_FORCES, MAX_FORCE_READING)
            stamp = stamp_nanoseconds(message.header.stamp)
        except InvalidInputError as error:
            self.node.reject(ESTIMATED_CONTACT_FORCES, error)
            return
        self.forces = (self.node.now_seconds(), forces)
        if self.node.lockstep:
            self.waiting_estimate = (stamp, forces)
            self.complete()

    def complete(self) -> None:
        """Lockstep: hand the waiting state to the node to answer once it is complete."""
        state, estimate, forces = self.waiting_state, self.waiting_estimate, None
        if state is None:
            return
        if self.node.values['mode'] == 'force':
            if estimate is not None and estimate[0] < state[0]:
                self.waiting_estimate = estimate = None
            if estimate is None or estimate[0] != state[0]:
                return
            forces = estimate[1]
        self.waiting_state = self.waiting_estimate = None
        stamp, angles, pressure = state
        self.node.answer(stamp, angles, forces, pressure)
