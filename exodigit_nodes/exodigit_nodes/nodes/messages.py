"""Topic names and message conversions shared by the nodes (docs/spec/ros.md)."""

from __future__ import annotations

from array import array
from collections.abc import Sequence
from typing import TYPE_CHECKING

from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Header, MultiArrayDimension
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

if TYPE_CHECKING:
    from exodigit_model.control import Trajectory

PRESSURE_COMMAND = 'pressure_command'
VALVE_COMMAND = 'valve_command'
APPLIED_COMMAND = 'applied_command'
CHAMBER_PRESSURE = 'chamber_pressure'
JOINT_STATES = 'joint_states'
CONTACT_FORCES = 'contact_forces'
SEGMENT_LENGTHS = 'segment_lengths'
ESTIMATED_CONTACT_FORCES = 'estimated_contact_forces'
ESTIMATED_FINGER_STIFFNESS = 'estimated_finger_stiffness'
ESTIMATED_FINGER_TORQUE = 'estimated_finger_torque'
ESTIMATED_REST_ANGLE = 'estimated_rest_angle'
PATIENT_EFFORT = 'patient_effort'
JOINT_TARGETS = 'joint_targets'
JOINT_TRAJECTORY = 'joint_trajectory'
MARKERS = 'markers'
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'
RESET = 'reset'
RESET_SIMULATION = 'reset_simulation'
SET_PAUSED = 'set_paused'
STEP = 'step'
LOCKSTEP_CONTROLLERS = 'lockstep_controllers'


def set_double_request(name: str, value: float) -> SetParameters.Request:
    """A ``set_parameters`` request that sets the double parameter ``name`` to ``value``."""
    parameter = Parameter(name, value=float(value)).to_parameter_msg()
    return SetParameters.Request(parameters=[parameter])


def rate_request() -> GetParameters.Request:
    """A ``get_parameters`` request for a plant's ``rate_hz`` (the runners' :mod:`.horizon`)."""
    return GetParameters.Request(names=['rate_hz'])


def vector_message(label: str, size: int) -> Float64MultiArray:
    """A Float64MultiArray with one layout dimension (``label``, ``size``), to fill and reuse."""
    message = Float64MultiArray()
    message.layout.dim = [MultiArrayDimension(label=label, size=size, stride=size)]
    message.data = array('d', [0.0] * size)
    return message


def joint_vector_message() -> Float64MultiArray:
    """A joint vector: the one layout dimension ``joint`` (size 3), to be filled and reused."""
    return vector_message('joint', 3)


def valve_command_message() -> Float64MultiArray:
    """A ``valve_command``: the one dimension ``valve`` (6: inlets, then outlets), to fill."""
    return vector_message('valve', 6)


def fill(message: Float64MultiArray, values) -> Float64MultiArray:
    """Put the floats into a message from :func:`vector_message`; returns it."""
    message.data = array('d', values)
    return message


def trajectory_message(
    trajectory: Trajectory, start_ns: int, names: Sequence[str]
) -> JointTrajectory:
    """``trajectory`` as a ``joint_trajectory`` message starting at ``start_ns`` (0: on receipt).

    ``names``: the joints' names, MCP, PIP, DIP. Each point's ``time_from_start`` is its whole
    nanoseconds (what the node samples).
    """
    seconds, nanoseconds = divmod(start_ns, 10**9)
    velocities = trajectory.velocities
    return JointTrajectory(
        header=Header(stamp=Time(sec=seconds, nanosec=nanoseconds)),
        joint_names=list(names),
        points=[
            JointTrajectoryPoint(
                positions=array('d', trajectory.positions[k]),
                velocities=array('d', () if velocities is None else velocities[k]),
                time_from_start=Duration(sec=t // 10**9, nanosec=t % 10**9),
            )
            for k, t in enumerate(trajectory.times_ns)
        ],
    )


def estimate_message(state: JointState, effort) -> JointState:
    """An estimate (``effort``: N or N·m per joint) from the ``joint_states`` message ``state``.

    It carries ``state``'s stamp, joint names and angles, so a reader pairs it with its state.
    """
    return JointState(
        header=state.header,
        name=state.name,
        position=state.position,
        effort=array('d', effort),
    )


def status(
    name: str, hardware_id: str, level: bytes, text: str, values: dict[str, str]
) -> DiagnosticStatus:
    """A DiagnosticStatus from a level, a one-line message and key/values."""
    return DiagnosticStatus(
        level=level,
        name=name,
        message=text,
        hardware_id=hardware_id,
        values=[KeyValue(key=k, value=v) for k, v in values.items()],
    )
