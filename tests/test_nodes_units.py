"""Unit tests of the plain classes behind the nodes (no ROS traffic; fast)."""

import importlib
import math
import subprocess
import sys

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from exodigit_nodes.logic.inputs import (
    InvalidInputError,
    RejectionTally,
    joint_positions,
    joint_vector,
    stamp_age,
    stamp_seconds,
)
from exodigit_nodes.logic.parameters import ParamSpec, ParamTable
from exodigit_nodes.logic.watchdog import Watchdog
from exodigit_nodes.nodes.catalog import NODES
from exodigit_nodes.nodes.node_base import descriptor
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from exodigit_model import GloveModel, load_params, params_from_dict

#: Relative tolerance of closed-form comparisons (floating-point rounding only).
EXACT = 1e-12


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


# -- watchdog ------------------------------------------------------------------------------


def test_watchdog_trips_after_its_timeout_and_counts_each_trip_once():
    watchdog = Watchdog(0.5)
    assert watchdog.missing(0.0) and not watchdog.update(0.0)  # nothing yet: no trip
    assert watchdog.trips == 0
    assert not watchdog.feed(10.0)
    assert not watchdog.update(10.5) and not watchdog.missing(10.5)
    assert watchdog.missing(10.5001) and not watchdog.tripped  # a query changes nothing
    assert watchdog.update(10.5001) and not watchdog.update(11.0)  # the trip is new once
    assert watchdog.trips == 1 and watchdog.tripped
    assert watchdog.feed(12.0)  # ends the trip
    assert not watchdog.update(12.1) and not watchdog.tripped
    assert watchdog.update(13.0) and watchdog.trips == 2
    watchdog.clear()
    assert watchdog.age(20.0) == math.inf and not watchdog.tripped


# -- input checks --------------------------------------------------------------------------


@pytest.mark.parametrize('length', [0, 1, 2, 4, 1000])
def test_a_vector_of_the_wrong_length_is_rejected(length):
    with pytest.raises(InvalidInputError, match='needs 3 values') as caught:
        joint_vector([1.0] * length, 'pressure_command')
    assert caught.value.kind == 'wrong length'


@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf])
def test_a_non_finite_vector_is_rejected(bad):
    with pytest.raises(InvalidInputError, match='non-finite'):
        joint_vector([1.0, bad, 2.0], 'pressure_command')


def test_a_vector_beyond_its_bound_is_rejected_and_a_good_one_passes():
    with pytest.raises(InvalidInputError, match='beyond'):
        joint_vector([1.0, 2.0, 1e308], 'chamber_pressure', 1e7)
    np.testing.assert_array_equal(joint_vector([1.0, -2.0, 3e-310], 'x'), [1.0, -2.0, 3e-310])


def state(names, position, velocity=(), effort=()):
    return JointState(name=list(names), position=position, velocity=velocity, effort=effort)


def test_joint_states_in_any_order_give_angles_in_mcp_pip_dip_order():
    message = state(['l_dip', 'l_mcp', 'l_pip'], [0.3, 0.1, 0.2], [0.0] * 3)
    np.testing.assert_array_equal(joint_positions(message), [0.1, 0.2, 0.3])


@pytest.mark.parametrize(
    'message',
    [
        state([], []),
        state(['mcp', 'mcp', 'dip'], [0.1, 0.2, 0.3]),
        state(['mcp', 'pip', ''], [0.1, 0.2, 0.3]),
        state(['mcp', 'pip', 'dip'], [0.1, 0.2]),
        state(['mcp', 'pip', 'dip'], [0.1, 0.2, 0.3], velocity=[0.0]),
        state(['mcp', 'pip', 'dip'], [0.1, 0.2, 0.3], effort=[0.0] * 4),
        state(['mcp', 'pip', 'dip'], [0.1, math.nan, 0.3]),
        state(['mcp', 'pip', 'dip'], [0.1, 1e308, 0.3]),
    ],
)
def test_malformed_joint_states_are_rejected(message):
    with pytest.raises(InvalidInputError):
        joint_positions(message)


def test_stale_future_zero_and_negative_stamps_are_rejected():
    stamp_age(99.95, 100.0, 0.1, 'joint_states')
    negative = stamp_seconds(Time(sec=-(2**31), nanosec=5))
    assert negative == -(2**31) + 5e-9
    for stamp in (0.0, 99.0, 100.5, negative):
        with pytest.raises(InvalidInputError, match='max_sample_age'):
            stamp_age(stamp, 100.0, 0.1, 'joint_states')
    with pytest.raises(InvalidInputError, match=r'beyond feedback_timeout 0\.1 s'):
        stamp_age(99.0, 100.0, 0.1, 'joint_states', 'feedback_timeout')


def test_rejection_tally_counts_per_topic_and_reason():
    tally = RejectionTally()
    for data in ([1.0], [math.nan] * 3, [2.0]):
        try:
            joint_vector(data, 'pressure_command')
        except InvalidInputError as error:
            tally.add('pressure_command', error)
    summary = tally.summary()
    assert summary['rejected pressure_command: wrong length'] == '2'
    assert summary['rejected pressure_command: non-finite'] == '1'
    assert tally.total == 3 and 'needs 3 values' in summary['last rejection']


# -- parameters ----------------------------------------------------------------------------

RATE = ParamSpec('rate_hz', 100.0, 'rate, Hz', low=1.0, high=1000.0)
TARGETS = ParamSpec('joint_targets', (0.1, 0.2, 0.3), 'targets, rad', low=-3.0, high=3.0)
MODE = ParamSpec('mode', 'sine', 'session', choices=('sine', 'hold'))
FRAME = ParamSpec('frame_id', 'base', 'marker frame', required=True)


@pytest.mark.parametrize(
    ('spec', 'value'),
    [
        (RATE, 0.5),
        (RATE, math.nan),
        (RATE, math.inf),
        (RATE, 'fast'),
        (RATE, True),
        (TARGETS, [0.1, 0.2]),
        (TARGETS, [0.1, 0.2, 9.0]),
        (TARGETS, 'abc'),
        (MODE, 'bogus'),
        (MODE, 3),
        (FRAME, ''),
        (FRAME, 1.0),
    ],
)
def test_a_bad_value_is_refused_with_a_reason_naming_the_parameter(spec, value):
    with pytest.raises(ValueError, match=spec.name):
        spec.check(value)


def test_good_values_are_converted_to_the_parameter_type():
    assert RATE.check(200) == 200.0 and isinstance(RATE.check(200), float)
    assert TARGETS.check([0, 1, 2]) == (0.0, 1.0, 2.0)
    assert MODE.check('hold') == 'hold'
    with pytest.raises(ValueError, match='not a parameter'):
        ParamTable([RATE]).check({'rate': 1.0})


@pytest.mark.parametrize('default', [5.0, 5], ids=['float', 'int'])
@pytest.mark.parametrize(
    ('bounds', 'beyond', 'open_side', 'rule'),
    [({'low': 0.0}, -1, 10**9, '>= 0'), ({'high': 10.0}, 11, -(10**9), '<= 10')],
    ids=['low only', 'high only'],
)
def test_a_parameter_with_one_bound_is_described_listed_and_checked(
    probe, default, bounds, beyond, open_side, rule
):
    spec = ParamSpec('gain', default, 'gain, Pa/rad', **bounds)
    kind = type(default)
    assert spec.help_line() == f'  gain = {default!r} {rule}\n      gain, Pa/rad'
    with pytest.raises(ValueError, match=f'^gain = {kind(beyond)!r}: must be {rule}$'):
        spec.check(kind(beyond))
    assert spec.check(kind(open_side)) == open_side
    # The node's declaration: rclpy takes the descriptor and refuses what lies past the bound
    # (a node nothing spins, in the probe's context: no parameter services, no rosout).
    with probe.local_node('one_bound') as node:
        node.declare_parameter('gain', default, descriptor(spec))
        refused = node.set_parameters([Parameter('gain', value=kind(beyond))])[0]
        accepted = node.set_parameters([Parameter('gain', value=kind(open_side))])[0]
    assert not refused.successful and 'out of range' in refused.reason, refused.reason
    assert accepted.successful, accepted.reason


# -- markers -------------------------------------------------------------------------------


def test_markers_draw_the_finger_links_at_their_length_and_forces_to_scale(model):
    from exodigit_nodes.nodes.markers import FORCE_SCALE, GloveMarkers

    markers = GloveMarkers(model)
    solution = model.solve([40e3, 40e3, 40e3])
    backbone, finger, *arrows = markers.update(solution.q, solution.forces, None, 'base').markers
    points = np.array([[p.x, p.y] for p in finger.points])
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    expected = [2 * j.link_half_length for j in model.params.finger.joints]
    np.testing.assert_allclose(lengths, expected, rtol=EXACT)
    assert (backbone.points[0].x, backbone.points[0].y) == (0.0, 0.0)
    for arrow, force in zip(arrows, solution.forces, strict=True):
        start, end = arrow.points
        length = math.hypot(end.x - start.x, end.y - start.y)
        assert length == pytest.approx(FORCE_SCALE * abs(force), rel=1e-9)
    assert all(m.header.frame_id == 'base' for m in markers.array.markers)


def drawn_arcs(array, samples):
    """The soft arcs of a marker array's backbone, each as (samples, 2) rows.

    The backbone is the base block, then each arc followed by the two ends of the block it carries.
    """
    points = np.array([[p.x, p.y] for p in array.markers[0].points])
    starts = [2 + k * (samples + 2) for k in range(3)]
    return [points[start : start + samples] for start in starts]


def test_markers_draw_the_arcs_at_the_given_lengths(monkeypatch):
    from exodigit_nodes.nodes import markers as markers_module

    data = load_params().to_dict()
    data['exo_digit']['segments'][0]['layer_axial_stiffness'] = 0.0  # MCP stretches (§12)
    extensible = GloveModel(params_from_dict(data))
    solution = extensible.solve([40e3, 40e3, 40e3])
    rest = np.array([s.arc_length for s in extensible.params.exo_digit.segments])
    assert solution.lengths[0] > rest[0] + 1e-3  # the MCP arc is visibly longer than at rest
    np.testing.assert_array_equal(solution.lengths[1:], rest[1:])
    for lengths, expected in ((None, rest), (solution.lengths, solution.lengths)):
        # A circular arc of length ℓ bent by q has the chord 2ℓ·sin(q/2)/q (closed form).
        samples = markers_module.ARC_SAMPLES
        array = markers_module.GloveMarkers(extensible).update(
            solution.q, solution.forces, None, 'base', lengths
        )
        for arc, length, angle in zip(
            drawn_arcs(array, samples), expected, solution.q, strict=True
        ):
            chord = np.linalg.norm(arc[-1] - arc[0])
            assert chord == pytest.approx(2.0 * length * math.sin(angle / 2.0) / angle, rel=EXACT)
        # Finely sampled, the drawn polyline's length approaches ℓ: n chords of an arc of
        # angle q fall short by ℓ·(1 − sin(q/2n)/(q/2n)) ≈ ℓ·q²/(24 n²).
        samples = 2001
        monkeypatch.setattr(markers_module, 'ARC_SAMPLES', samples)
        array = markers_module.GloveMarkers(extensible).update(
            solution.q, solution.forces, None, 'base', lengths
        )
        monkeypatch.undo()
        for arc, length in zip(drawn_arcs(array, samples), expected, strict=True):
            drawn = np.linalg.norm(np.diff(arc, axis=0), axis=1).sum()
            assert drawn == pytest.approx(length, rel=1e-7)


# -- packaging of the logic ----------------------------------------------------------------


def test_the_plain_logic_and_the_node_table_import_no_ros():
    # exodigit_nodes.logic is the ROS-free layer; the node table is read by launch files and
    # runners without ROS.
    code = (
        'import importlib, pkgutil, sys\n'
        'import exodigit_nodes.logic as logic\n'
        'for module in pkgutil.iter_modules(logic.__path__):\n'
        "    importlib.import_module(f'exodigit_nodes.logic.{module.name}')\n"
        'import exodigit_nodes.nodes.catalog\n'
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
        "{'rclpy', 'std_msgs', 'sensor_msgs', 'rcl_interfaces'})\n"
        'print(bad); sys.exit(1 if bad else 0)'
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize('node', NODES, ids=lambda node: node.executable)
def test_help_lists_every_parameter_and_exits_0(node, capsys):
    # In process: ``--help`` is answered before rclpy starts (process.run); the module's
    # ``__main__`` line runs in every test that starts a node process.
    assert importlib.import_module(node.module).main(['--help']) == 0
    assert 'parameters:\n' + node.table.help() in capsys.readouterr().out


@pytest.mark.parametrize(
    ('module', 'program'),
    [
        (NODES[0].module, NODES[0].executable),
        ('exodigit_nodes.nodes.hand_nodes', 'hand_nodes'),
        ('exodigit_nodes.nodes.recorder', 'python -m exodigit_nodes.nodes.recorder'),
    ],
)
def test_malformed_ros_arguments_are_one_usage_error_not_a_traceback(capsys, module, program):
    try:
        code = importlib.import_module(module).main(['--ros-args', '-p'])
    except SystemExit as exit_:  # argparse's error exit, from a console script's main
        code = exit_.code
    assert code == 2
    errors = capsys.readouterr().err.splitlines()  # argparse's usage (some lines), the error
    assert errors[0].startswith('usage: ') and 'Traceback' not in '\n'.join(errors), errors
    assert errors[-1].startswith(f'{program}: error: ') and 'ROS arguments' in errors[-1]
