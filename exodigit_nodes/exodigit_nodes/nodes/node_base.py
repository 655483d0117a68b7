"""What every glove node shares: its parameters, its diagnostics, the inputs it drops.

Parameters come in three phases: checked by the node table, made into the node's settings
(:meth:`GloveNode.make_settings`), applied (:meth:`GloveNode.apply`) only after a set has
succeeded. A node's process, from its command line to its last words, is :mod:`.process`.
"""

from __future__ import annotations

import sys
import time
from typing import TYPE_CHECKING, Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from numpy.typing import NDArray
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

import exodigit_model
from exodigit_model import ParameterError, load_params

from ..logic.inputs import MAX_PRESSURE_READING, InvalidInputError, RejectionTally, joint_vector
from ..logic.parameters import ParamSpec, ParamTable
from .messages import CHAMBER_PRESSURE, DIAGNOSTICS, status
from .qos import STREAM_QOS

if TYPE_CHECKING:
    from exodigit_model import GloveModel, GloveParams

LOG_THROTTLE = 2.0
"""Shortest time between two repeats of a warning logged from a loop or callback, s."""
DROP_WARNING = 5.0
"""How long after the latest dropped input message the diagnostics stay at WARN, s."""


class ConfigurationError(Exception):
    """A node cannot start with its configuration; the text is the one line the user sees."""


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """The ROS ParameterDescriptor of a parameter: description, range, read-only.

    Typing is dynamic, so that a wrong type reaches the table's check, which names the parameter,
    and an integer given for a float is accepted.
    """
    kind = type(spec.default)
    result = ParameterDescriptor(
        name=spec.name,
        type=Parameter.Type.from_parameter_value(spec.default).value,
        description=spec.description,
        read_only=spec.read_only,
        dynamic_typing=True,
    )
    if spec.choices:
        result.additional_constraints = 'one of: ' + ', '.join(spec.choices)
    if spec.files:
        result.additional_constraints = 'a file name, or a list of file names merged in order'
    if kind is tuple:
        result.additional_constraints = 'three values: MCP, PIP, DIP'
    if spec.low is None and spec.high is None:
        return result
    # A range has both ends: an open one is the type's limit (the check refuses non-finite).
    if kind is int:
        low = -(2**63) if spec.low is None else int(spec.low)
        high = 2**63 - 1 if spec.high is None else int(spec.high)
        result.integer_range = [IntegerRange(from_value=low, to_value=high, step=0)]
    else:
        low = -sys.float_info.max if spec.low is None else float(spec.low)
        high = sys.float_info.max if spec.high is None else float(spec.high)
        result.floating_point_range = [FloatingPointRange(from_value=low, to_value=high, step=0.0)]
    return result


def load_model(paths: tuple[str, ...]) -> GloveModel:
    """The model of the ``params_file`` files (none: defaults); one-line ConfigurationError."""
    params = load_model_params(paths)
    try:  # exodigit_model.GloveModel: numba loads only in the nodes that use a model
        return exodigit_model.GloveModel(params)
    except ValueError as error:
        raise ConfigurationError('params_file: ' + ' '.join(str(error).split())) from None


def load_model_params(paths: tuple[str, ...]) -> GloveParams:
    """The parameters of the ``params_file`` files, checked; one-line ConfigurationError."""
    try:
        return load_params(paths)
    except (ParameterError, OSError, ValueError) as error:
        raise ConfigurationError('params_file: ' + ' '.join(str(error).split())) from None


class GloveNode(Node):
    """Base of the glove nodes: declared parameters, diagnostics and the rejection tally.

    A subclass names its executable (also the default node name) and its parameter table as class
    attributes ``executable`` and ``table``. Keyword ``node_options`` go to rclpy's ``Node``
    (``namespace``, ``parameter_overrides``, ``context``...).

    Raises
    ------
    ConfigurationError
        If a parameter given at start breaks its rule.
    """

    executable: str
    table: ParamTable
    quiet_parameters: frozenset[str] = frozenset()
    """Parameters whose changes are logged at debug level, not info: flow control set every few
    steps (an info line costs the node about 0.5 ms of CPU)."""

    def __init__(self, **node_options) -> None:
        super().__init__(self.executable, **node_options)
        given = {}
        try:
            for spec in self.table.specs.values():
                default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
                given[spec.name] = self.declare_parameter(
                    spec.name, default, descriptor(spec)
                ).value
            self.values = self.table.check(given)
            self.settings = self.make_settings(self.values)
        except (ValueError, ParameterException) as error:
            raise ConfigurationError(' '.join(str(error).split())) from None
        self._pending: tuple[dict[str, Any], Any] | None = None
        self.rejections = RejectionTally()
        self.last_rejection: float | None = None
        self.diagnostics_publisher = self.create_publisher(
            DiagnosticArray, DIAGNOSTICS, STREAM_QOS
        )
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

    def make_settings(self, values: dict[str, Any]) -> Any:
        """The node's plain settings from checked parameter values (ValueError if inconsistent)."""
        return values

    def apply(self, settings: Any, changed: set[str]) -> None:
        """Take new settings into use (called after a successful parameter set)."""

    def on_shutdown(self) -> None:
        """Last words before the node is destroyed (e.g. a safe command)."""

    def _ours(self, parameters) -> dict[str, Any]:
        """The node's own parameters among ``parameters`` (rclpy's, e.g. use_sim_time, aside)."""
        return {p.name: p.value for p in parameters if p.name in self.table.specs}

    def _validate_parameters(self, parameters) -> SetParametersResult:
        try:
            changed = self.table.check(self._ours(parameters))
            values = {**self.values, **changed}
            self._pending = (values, self.make_settings(values))
        except ValueError as error:
            self._pending = None
            return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters) -> None:
        changed = set(self._ours(parameters))
        if self._pending is None or not changed:
            return
        self.values, self.settings = self._pending
        self._pending = None
        self.apply(self.settings, changed)
        text = 'parameters set: ' + ', '.join(f'{name}={self.values[name]!r}' for name in changed)
        if changed <= self.quiet_parameters:
            self.get_logger().debug(text)
        else:
            self.get_logger().info(text)

    def now_seconds(self) -> float:
        """The node clock (ROS time, so ``use_sim_time`` works), s."""
        return self.get_clock().now().nanoseconds * 1e-9

    def reject(self, topic: str, error: InvalidInputError) -> None:
        """Count a dropped message and warn (throttled)."""
        self.rejections.add(topic, error)
        self.last_rejection = time.monotonic()
        self.get_logger().warning(
            f'dropped a message on {topic}: {error} ({self.rejections.total} dropped so far)',
            throttle_duration_sec=LOG_THROTTLE,
        )

    def pressure_reading(self, data) -> NDArray[np.float64] | None:
        """The chamber pressures (Pa) of a ``chamber_pressure``'s ``data``; None if refused."""
        try:
            return joint_vector(data, CHAMBER_PRESSURE, MAX_PRESSURE_READING)
        except InvalidInputError as error:
            self.reject(CHAMBER_PRESSURE, error)
            return None

    def publish_status(self, level: bytes, text: str, values: dict[str, str], stamp=None) -> None:
        """Publish one DiagnosticStatus of this node on /diagnostics, stamped ``stamp`` (now).

        WARN (at least) while the latest dropped input message is under ``DROP_WARNING`` old.
        """
        if self.last_rejection is not None:
            age = time.monotonic() - self.last_rejection
            if age < DROP_WARNING:
                level = max(level, DiagnosticStatus.WARN)
                text = (
                    f'{text}; {self.rejections.total} input messages dropped so far, '
                    f'the latest {age:.1f} s ago'
                )
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg() if stamp is None else stamp
        array.status = [
            status(
                self.get_fully_qualified_name(),
                self.get_namespace(),
                level,
                text,
                {**values, **self.rejections.summary()},
            )
        ]
        self.diagnostics_publisher.publish(array)
