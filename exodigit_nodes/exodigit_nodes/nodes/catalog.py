"""The glove's nodes in one table: executables, parameters and their defaults.

Every way of starting a node reads it: the node classes, the runners (:data:`NODES`), the launch
file, each node's ``--help`` and the generated ``config/<executable>.yaml`` (a test checks them
against it: ``python -m exodigit_nodes.nodes.config_files --write-config exodigit_nodes/config``).
No rclpy here. ``pressure_command``'s row is in :mod:`.command_catalog`.
"""

from __future__ import annotations

from exodigit_model.stepping.joining import STEP_TOLERANCE
from exodigit_model.stepping.settings import ACTUATIONS

from exodigit_model import SimulationSettings

from ..logic.pacing import CLOCKS, MAX_REAL_TIME_FACTOR
from ..logic.parameters import ParamSpec, ParamTable, params_file_spec
from .command_catalog import PRESSURE_COMMAND_NODE
from .node_entry import DIAGNOSTIC_PERIOD, NodeEntry

SIM_DEFAULTS = SimulationSettings()
"""The stepper's defaults, which are the plant's."""
NEXT_SESSION = 'settable: taken at the next reset_simulation, clock sim'

# The rows laid out as a table: name, default, description, then the rules.
# fmt: off
PLANT_PARAMETERS = [
    params_file_spec('the simulated glove and patient', NEXT_SESSION),
    ParamSpec('rate_hz', SIM_DEFAULTS.rate_hz,
              'Simulation and publishing rate, Hz (simulated steps per simulated second)',
              low=1.0, high=5000.0, read_only=True),
    ParamSpec('actuation', ACTUATIONS[0],
              'How the chambers are driven (docs/spec/model.md §14): regulator (subscribe '
              'pressure_command, chamber pressures with a first-order lag) or valves '
              '(subscribe valve_command, six inlet and outlet openings; the pressures follow '
              'the air mass)', choices=ACTUATIONS, read_only=True),
    ParamSpec('pressure_time_constant', SIM_DEFAULTS.pressure_time_constant,
              'regulator: first-order chamber lag T, s (0 = ideal: chambers follow the '
              'command at once)', low=0.0, high=10.0),
    ParamSpec('max_supply_pressure', SIM_DEFAULTS.max_supply_pressure,
              'Supply pressure, Pa (regulator commands are clipped to [0, this], reported; '
              "with valves the inlets' supply unless the model file's pneumatics sets one)",
              low=1e3, high=1e6),
    ParamSpec('command_timeout', 0.5,
              'No valid command (pressure_command, or valve_command with valves) for this '
              'long: the chambers vent (to zero; valves: inlets closed, outlets open), s '
              '(simulated s with clock sim; lockstep uses lockstep_timeout instead)',
              low=0.01, high=60.0),
    ParamSpec('effort_timeout', 0.5,
              'patient_effort older than this counts as none (zero effort), s (simulated with '
              'clock sim)', low=0.01, high=60.0),
    ParamSpec('angle_noise_std', SIM_DEFAULTS.angle_noise_std,
              'Joint-angle sensor noise (std), rad', low=0.0, high=0.1),
    ParamSpec('pressure_noise_std', SIM_DEFAULTS.pressure_noise_std,
              'Pressure sensor noise (std), Pa', low=0.0, high=10e3),
    ParamSpec('seed', SIM_DEFAULTS.seed, f'Seed of the sensor noise ({NEXT_SESSION})',
              low=0.0, high=2.0**31 - 1),
    ParamSpec('joint_prefix', '', 'Prefix of the joint names (<prefix>mcp, ...)', read_only=True),
    ParamSpec('frame_id', 'exodigit_base', 'Frame of the markers (exo-digit base)', required=True),
    ParamSpec('marker_rate_hz', 10.0, 'Rate of the markers topic, Hz (0 = off)',
              low=0.0, high=100.0),
    ParamSpec('clock', 'wall',
              'Time source: wall (system clock) or sim (the plant owns simulated time and '
              'publishes /clock; run the other nodes with use_sim_time)',
              choices=CLOCKS, read_only=True),
    ParamSpec('real_time_factor', 1.0,
              'sim: simulated seconds per wall second (0 = as fast as possible)',
              low=0.0, high=MAX_REAL_TIME_FACTOR),
    ParamSpec('lockstep', False,
              'sim: one step in flight: after each step wait for a command (the answer: '
              'pressure_command, or valve_command with valves)', read_only=True),
    ParamSpec('lockstep_timeout', 1.0,
              'lockstep: no answer within this many wall seconds: vent and step on at real '
              'time until a command comes, s (0 = wait forever)', low=0.0, high=3600.0),
    ParamSpec('start_paused', False, 'sim: start paused (set_paused false, or step, to go)',
              read_only=True),
    ParamSpec('run_until', 0.0,
              'sim: take no step past this simulated time, s (0 = no limit; not a pause: '
              'raising it lets the steps go on; the runners keep it a few steps ahead of '
              'what their record has received, never past the end of their run)', low=0.0,
              high=1e9),
    DIAGNOSTIC_PERIOD,
]
# fmt: on

PLANT_NODE = NodeEntry(
    executable='plant',
    class_name='Plant',
    summary='the simulated glove',
    table=ParamTable(PLANT_PARAMETERS),
)

SIMULATED_SAMPLE_AGE = 10.0
"""The estimator's ``max_sample_age`` in simulated time (its largest), s: a backlog of up to a
publisher's 1,000 samples (10 s at 100 Hz) is no reason to refuse an exactly stamped state."""

# fmt: off
ESTIMATOR_PARAMETERS = [
    params_file_spec('the estimate (the nominal glove and finger)'),
    ParamSpec('max_sample_age', 0.5,
              'Oldest joint_states stamp accepted (stale, future or zero stamps are refused), s',
              low=1e-4, high=SIMULATED_SAMPLE_AGE),
    ParamSpec('pairing_tolerance', STEP_TOLERANCE,
              'Longest time from a chamber_pressure to the joint_states paired with it (both '
              'as sent), s', low=1e-4, high=10.0, read_only=True),
    ParamSpec('identification_window', 500,
              'Pairs used to identify the finger stiffness (sliding window), samples',
              low=10.0, high=100000.0),
    ParamSpec('identification_period', 1.0, 'Time between two stiffness identifications, s',
              low=0.05, high=3600.0),
    ParamSpec('glove_node', 'plant',
              'The node of our namespace whose chamber_pressure and joint_states we estimate '
              'from: plant (simulated) or hardware (a board); ~/ready says when it has matched '
              'our readers', choices=('plant', 'hardware'), read_only=True),
    DIAGNOSTIC_PERIOD,
]
# fmt: on

ESTIMATOR_NODE = NodeEntry(
    executable='estimator',
    class_name='Estimator',
    summary="robot-side contact forces and the patient's effective spring",
    table=ParamTable(ESTIMATOR_PARAMETERS),
)

NODES = (PLANT_NODE, ESTIMATOR_NODE, PRESSURE_COMMAND_NODE)
"""The glove's nodes in start order: the plant first, the commands last."""

# fmt: off
HARDWARE_PARAMETERS = [
    ParamSpec('port', '',
              'Serial port of the board (pyserial name: /dev/ttyACM0, COM3, or the link of '
              'mcu_emulator)', required=True, read_only=True),
    ParamSpec('baud_rate', 115200,
              'Line speed, Hz (baud, 8N1; USB boards and pseudo-terminals ignore it)',
              low=300.0, high=4e6, read_only=True),
    ParamSpec('max_pressure', 80e3,
              'A chamber reading at or above this gets no air: its inlet closed, its outlet '
              "opened (above pressure_command's 60 kPa limit), Pa", low=1e3, high=1e6),
    ParamSpec('command_timeout', 0.5,
              'No valid valve_command for this long: vent (inlets closed, outlets open), s',
              low=0.01, high=60.0),
    ParamSpec('sample_timeout', 0.1,
              'No valid sample from the board for this long: the link is lost (ERROR, vent, '
              'hello again), s', low=0.005, high=60.0, read_only=True),
    ParamSpec('handshake_timeout', 3.0,
              'Longest wait for the board to answer hello after opening its port, s',
              low=0.05, high=60.0, read_only=True),
    ParamSpec('heartbeat_period', 0.05,
              'Longest time without a frame to the board (then a heartbeat; below its '
              'watchdog time), s', low=0.001, high=10.0, read_only=True),
    ParamSpec('reconnect_max', 2.0,
              'Longest wait between two attempts to reopen the port (from 0.1 s, doubled at '
              'each failure), s', low=0.1, high=600.0, read_only=True),
    ParamSpec('joint_prefix', '', 'Prefix of the joint names (<prefix>mcp, ...)', read_only=True),
    DIAGNOSTIC_PERIOD,
]
# fmt: on

HARDWARE_NODE = NodeEntry(
    executable='hardware',
    class_name='Hardware',
    summary="the bridge to a real (or emulated) glove board, in the plant's place",
    table=ParamTable(HARDWARE_PARAMETERS),
)
"""The bridge to a board, in the plant's place (not in :data:`NODES`: a simulated glove's)."""

EXECUTABLES = (*NODES, HARDWARE_NODE)
"""Every node of the table: each has its parameter file ``config/<executable>.yaml``."""
