"""``pressure_command``'s row of the node table (:mod:`.catalog`): its parameters and defaults.

The defaults are those of :mod:`exodigit_model.control` (modes, safety limiter, valve loop),
which the node runs.
"""

from __future__ import annotations

from exodigit_model.control import MODE_DEFAULTS, MODES, OUTPUTS, SafetyLimits, ValveLoopSettings

from ..logic.parameters import ParamSpec, ParamTable, params_file_spec
from .node_entry import DIAGNOSTIC_PERIOD, NodeEntry

SAFETY, VALVE_LOOP = SafetyLimits(), ValveLoopSettings()
STAIRCASE, SINE = MODE_DEFAULTS['staircase'], MODE_DEFAULTS['sine']
POSITION, FORCE = MODE_DEFAULTS['position'], MODE_DEFAULTS['force']

# The rows laid out as a table: name, default, description, then the rules.
# fmt: off
PARAMETERS = [
    params_file_spec('the feed-forward (the nominal glove and finger)'),
    ParamSpec('mode', 'sine',
              'Command session: ' + '; '.join(f'{mode} ({what})' for mode, what in MODES.items()),
              choices=tuple(MODES)),
    ParamSpec('rate_hz', 100.0, 'Command rate, Hz', low=1.0, high=1000.0, read_only=True),
    ParamSpec('output', OUTPUTS[0],
              'What it publishes: pressure (pressure_command, the targets) or valves '
              '(valve_command: openings from a pressure loop on chamber_pressure toward the '
              'targets, for a plant with actuation valves)', choices=OUTPUTS, read_only=True),
    ParamSpec('lockstep', False,
              'Answer each joint_states with one command instead of commanding on a timer '
              '(the plant in lockstep, clock sim)', read_only=True),
    ParamSpec('staircase_step', STAIRCASE['staircase_step'], 'staircase: pressure step, Pa',
              low=100.0, high=1e6),
    ParamSpec('staircase_peak', STAIRCASE['staircase_peak'], 'staircase: highest level, Pa',
              low=100.0, high=1e6),
    ParamSpec('step_duration', STAIRCASE['step_duration'], 'staircase: time on each level, s',
              low=0.01, high=3600.0),
    ParamSpec('sine_low', SINE['sine_low'], 'sine: lowest pressure, Pa', low=0.0, high=1e6),
    ParamSpec('sine_high', SINE['sine_high'], 'sine: highest pressure, Pa', low=0.0, high=1e6),
    ParamSpec('sine_period', SINE['sine_period'], 'sine: period of one flex-extend cycle, s',
              low=0.1, high=3600.0),
    ParamSpec('hold_pressure', MODE_DEFAULTS['hold']['hold_pressure'],
              'hold: chamber pressures, Pa', low=0.0, high=1e6),
    ParamSpec('joint_targets', (0.3, 0.3, 0.2),
              'position: desired joint angles, rad (until a joint_targets or joint_trajectory)',
              low=-3.14, high=3.14),
    ParamSpec('position_kp', POSITION['position_kp'], 'position: proportional gain, Pa/rad',
              low=0.0, high=1e7),
    ParamSpec('position_ki', POSITION['position_ki'], 'position: integral gain, Pa/(rad·s)',
              low=0.0, high=1e8),
    ParamSpec('force_targets', FORCE['force_targets'], 'force: desired contact forces, N',
              low=-100.0, high=100.0),
    ParamSpec('force_kp', FORCE['force_kp'], 'force: proportional gain, Pa/N', low=0.0, high=1e7),
    ParamSpec('force_ki', FORCE['force_ki'], 'force: integral gain, Pa/(N·s)', low=0.0, high=1e8),
    ParamSpec('max_pressure', SAFETY.max_pressure, 'Safety: highest pressure ever sent, Pa',
              low=1e3, high=1e6),
    ParamSpec('max_pressure_rate', SAFETY.max_pressure_rate,
              'Safety: fastest command change, Pa/s', low=1.0, high=1e8),
    ParamSpec('joint_lower_limits', SAFETY.joint_lower, 'Safety: range of motion, lower ends, rad',
              low=-3.14, high=3.14),
    ParamSpec('joint_upper_limits', SAFETY.joint_upper, 'Safety: range of motion, upper ends, rad',
              low=-3.14, high=3.14),
    ParamSpec('max_contact_force', SAFETY.max_contact_force,
              'Safety: largest |contact force| tolerated, N', low=0.01, high=100.0),
    ParamSpec('feedback_timeout', 0.5,
              'Feedback older than this is missing (closed loops ramp down to zero); also the '
              'largest joint_states stamp age accepted, s', low=0.01, high=60.0),
    ParamSpec('valve_deadband', VALVE_LOOP.valve_deadband,
              'valves: pressure error within which a chamber holds (both valves closed), Pa',
              low=0.0, high=1e5),
    ParamSpec('valve_kp', VALVE_LOOP.valve_kp,
              'valves: proportional gain (opening per Pa of error), 1/Pa', low=1e-9, high=1.0),
    ParamSpec('valve_ki', VALVE_LOOP.valve_ki,
              'valves: integral gain (opening per Pa·s of integrated error), 1/(Pa·s)',
              low=0.0, high=10.0),
    DIAGNOSTIC_PERIOD,
]
"""The node's parameters, in the order ``--help`` and its parameter file list them."""
# fmt: on

PRESSURE_COMMAND_NODE = NodeEntry(
    executable='pressure_command',
    class_name='PressureCommand',
    summary='the reference controller and command source',
    table=ParamTable(PARAMETERS),
)
