"""rosbag2 recording and ``exodigit plot``: a real session recorded, read back and plotted.

The plant runs as a process, the recorder runs with the exact command line the glove runner
uses, and the test publishes ``pressure_command`` itself; the bag is then read back with
``rosbags`` (independently of the tools) and compared with what was published and with the
model's own solve of the commanded pressures.
"""

import signal
import subprocess
import sys
from functools import partial

import numpy as np
import pytest
from exodigit_model.tools.bag import Series, read_bag, step_pairs
from exodigit_model.tools.cli import main
from exodigit_nodes.nodes.recorder import main as recorder_main
from ros_harness import ros_environment, wait_until
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

NAMESPACE = '/tools_bag'
COMMANDS = ([20e3, 10e3, 5e3], [35e3, 25e3, 15e3])
"""Pressure steps published (Pa); the plant settles on each before the next."""
#: Joint angles in the bag against GloveModel.solve of the commanded pressure, rad.
ANGLE_TOLERANCE = 1e-6
#: Plant cycles (joint_states messages) to wait after the last command before stopping.
AFTER_LAST_COMMAND = 20
#: Plant cycles to hold each command once the plant has settled on it (0.5 s at 100 Hz): ten
#: heartbeat periods of the project's Fast DDS profile (50 ms, exodigit_nodes/nodes/dds.py), after
#: which a reader that joined late or missed a message (the recorder on a loaded machine) has
#: asked for it again and caught up. Fast DDS's own 3 s period needed 400 cycles here.
SETTLED_STEPS = 50
#: Seconds for the plant to settle, or for the recorder to start or stop.
TIMEOUT = 60.0


def recorder_command(output):
    return [
        sys.executable,
        '-m',
        'exodigit_nodes.nodes.recorder',
        '--output',
        str(output),
        '--ros-args',
        '-r',
        f'__ns:={NAMESPACE}',
    ]


def start_recorder(output, domain, workdir, stderr=subprocess.PIPE):
    return subprocess.Popen(
        recorder_command(output),
        cwd=workdir,
        env=ros_environment(domain),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=stderr,
        text=True,
        start_new_session=True,
    )


def read_back(path):
    """Every message of the bag as {topic: [(stamp_ns, message)]}, with rosbags."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    found = {}
    with Reader(path) as reader:
        assert reader.connections
        for connection, stamp, raw in reader.messages():
            message = typestore.deserialize_cdr(raw, connection.msgtype)
            found.setdefault(connection.topic, []).append((stamp, message))
        types = {c.topic: c.msgtype for c in reader.connections}
    return found, types


@pytest.fixture(scope='module')
def session(launcher, probe, ros_domain, tmp_path_factory):
    """Record a plant driven through two pressure steps; returns (bag, published, recorder)."""
    workdir = tmp_path_factory.mktemp('bag')
    bag = workdir / 'session'
    launcher.start('plant', {'pressure_time_constant': 0.0}, namespace=NAMESPACE)
    log = workdir / 'recorder.err'
    with open(log, 'w') as errors:
        recorder = start_recorder(bag, ros_domain, workdir, stderr=errors)
    states = probe.subscribe(f'{NAMESPACE}/joint_states', JointState)
    # A recorder that has not matched the plant yet misses the first command's steps (a CI run
    # did; another, whose test waited for the graph to list the recorder's subscriptions, got
    # none of the plant's messages): wait until it has heard each of the plant's outputs.
    for topic in ('joint_states', 'chamber_pressure', 'contact_forces', 'segment_lengths'):
        heard = f'first message on {NAMESPACE}/{topic}'
        assert wait_until(lambda heard=heard: heard in log.read_text(), TIMEOUT), log.read_text()
    command = probe.publisher(f'{NAMESPACE}/pressure_command', Float64MultiArray, wait_for=2)
    model = GloveModel(load_params())
    published = []
    try:
        for pressure in COMMANDS:
            target = model.solve(pressure).q

            def settled(target=target):
                latest = states.latest()
                return latest is not None and np.allclose(
                    latest.position, target, atol=ANGLE_TOLERANCE
                )

            def publish_until(condition, pressure=pressure):
                command.publish(Float64MultiArray(data=pressure))
                published.append(list(pressure))
                return condition()

            assert wait_until(partial(publish_until, settled), TIMEOUT, interval=0.05)

            enough = states.count() + SETTLED_STEPS

            def held(enough=enough):
                return states.count() >= enough

            assert wait_until(partial(publish_until, held), TIMEOUT, interval=0.05)
        # Messages in flight when the recorder stops are lost, as with any recorder: let
        # AFTER_LAST_COMMAND plant cycles pass (a condition, not a fixed sleep) before SIGINT.
        seen = states.count()
        assert wait_until(lambda: states.count() >= seen + AFTER_LAST_COMMAND, TIMEOUT)
    finally:
        recorder.send_signal(signal.SIGINT)
        try:
            recorder.communicate(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            recorder.kill()
            recorder.communicate()
    return bag, published, recorder.returncode, log.read_text()


def test_recorder_stops_cleanly_on_sigint(session):
    _, _, code, err = session
    assert code == 0
    assert 'Traceback' not in err
    assert 'closed' in err
    assert f'{NAMESPACE}/joint_trajectory 0,' in err  # nobody published it: listed, empty


def test_bag_holds_exactly_the_published_commands(session):
    bag, published, _, _ = session
    found, types = read_back(bag)
    commands = [list(m.data) for _, m in found[f'{NAMESPACE}/pressure_command']]
    assert commands == published
    assert types[f'{NAMESPACE}/pressure_command'] == 'std_msgs/msg/Float64MultiArray'
    assert types[f'{NAMESPACE}/joint_states'] == 'sensor_msgs/msg/JointState'
    assert types['/diagnostics'] == 'diagnostic_msgs/msg/DiagnosticArray'
    assert types[f'{NAMESPACE}/joint_trajectory'] == 'trajectory_msgs/msg/JointTrajectory'
    assert bag.joinpath('metadata.yaml').is_file()
    assert list(bag.glob('*.mcap'))


def test_bag_states_are_the_models_solution_of_the_commands(session):
    bag, _, _, _ = session
    found, _ = read_back(bag)
    model = GloveModel(load_params())
    positions = np.array([m.position for _, m in found[f'{NAMESPACE}/joint_states']])
    for pressure in COMMANDS:
        target = model.solve(pressure).q
        close = np.all(np.abs(positions - target) <= ANGLE_TOLERANCE, axis=1)
        assert np.any(close), f'no recorded joint state at the solution for {pressure}'
    chamber = np.array([m.data for _, m in found[f'{NAMESPACE}/chamber_pressure']])
    assert np.allclose(chamber[-1], COMMANDS[-1])
    forces = np.array([m.data for _, m in found[f'{NAMESPACE}/contact_forces']])
    np.testing.assert_allclose(forces[-1], model.solve(COMMANDS[-1]).forces, atol=1e-6)
    lengths = np.array([m.data for _, m in found[f'{NAMESPACE}/segment_lengths']])
    rest = [segment.arc_length for segment in model.params.exo_digit.segments]
    np.testing.assert_array_equal(lengths[-1], rest)  # the default glove is inextensible
    stamps = [stamp for stamp, _ in found[f'{NAMESPACE}/joint_states']]
    assert stamps == sorted(stamps)


def test_plot_reports_the_bag_contents(session, tmp_path, capsys):
    bag, _, _, _ = session
    found, _ = read_back(bag)
    assert main(['plot', str(bag), '--out', str(tmp_path)]) == 0
    out = capsys.readouterr().out
    for topic in ('joint_states', 'chamber_pressure', 'pressure_command', 'contact_forces'):
        count = len(found[f'{NAMESPACE}/{topic}'])
        assert f'{NAMESPACE}/{topic}: {count} messages' in out
    for name in ('session_timeseries.png', 'session_angle_pressure.png'):
        assert (tmp_path / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_recorder_refuses_an_existing_output(ros_domain, tmp_path):
    existing = tmp_path / 'taken'
    existing.mkdir()
    recorder = start_recorder(existing, ros_domain, tmp_path)
    _, err = recorder.communicate(timeout=TIMEOUT)
    assert recorder.returncode == 2
    assert err.strip().splitlines() == [
        f'recorder: error: --output {existing}: exists already; the bag needs a new folder'
    ]


def test_plot_refuses_a_folder_without_a_bag(tmp_path, capsys):
    assert main(['plot', str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert 'not a rosbag2 bag folder' in err and '\n' not in err


def test_plot_pairs_each_state_with_the_pressure_of_its_step(session):
    """The angle-against-pressure view: every paired state is the solve of its pressure."""
    bag, _, _, _ = session
    series = read_bag(bag)
    pressure, angles = step_pairs(series)
    recorded = min(series[s].time.size for s in ('joint_states', 'chamber_pressure'))
    assert len(pressure) >= recorded - 2  # all but a step the recording began or ended inside
    model = GloveModel(load_params())
    np.testing.assert_allclose(angles, model.solve_batch(pressure).q, atol=ANGLE_TOLERANCE)


def logged(topic, times, values):
    return Series(topic, np.array(times), np.array(values, dtype=float).reshape(-1, 3), 0)


def test_step_pairs_leave_out_the_steps_a_recording_began_and_ended_inside():
    # Step k: pressure k kPa logged at 10 k ms, its angles 0.1 ms later. The recorder started
    # after step 0's pressure and stopped before step 4's angles.
    steps = range(5)
    series = {
        'chamber_pressure': logged(
            'p', [0.01 * k for k in steps[1:]], [[k * 1e3] * 3 for k in steps[1:]]
        ),
        'joint_states': logged(
            'q', [0.01 * k + 1e-4 for k in steps[:-1]], [[k * 0.1] * 3 for k in steps[:-1]]
        ),
    }
    pressure, angles = step_pairs(series)
    np.testing.assert_array_equal(pressure[:, 0], [k * 1e3 for k in (1, 2, 3)])
    np.testing.assert_array_equal(angles[:, 0], [k * 0.1 for k in (1, 2, 3)])


def test_step_pairs_of_a_recorder_that_fell_behind_and_lost_a_message_keep_to_their_steps():
    # Behind, the recorder logs a backlog in one burst, a step's pressure then its angles 20 µs
    # later, steps 40 µs apart, and step 3's angles are lost: by nearest log time, step 3's
    # pressure would go with step 2's angles.
    logs = 1.0 + 40e-6 * np.arange(6)
    kept = [k for k in range(6) if k != 3]
    series = {
        'chamber_pressure': logged('p', logs, [[k * 1e3] * 3 for k in range(6)]),
        'joint_states': logged('q', logs[kept] + 20e-6, [[k * 0.1] * 3 for k in kept]),
    }
    pressure, angles = step_pairs(series)
    np.testing.assert_array_equal(pressure[:, 0], [k * 1e3 for k in kept])
    np.testing.assert_array_equal(angles[:, 0], [k * 0.1 for k in kept])


def test_step_pairs_keep_a_step_the_plant_stalled_in():
    # Step k's pressure logged at 10 k ms, its angles 0.1 ms later; the plant stopped 0.3 s (a
    # garbage collection, a busy machine) after step 2's pressure and after step 3's.
    stall = [0.0, 0.0, 0.3, 0.3]
    pressure_times = [0.01 * k + 0.3 * (k > 2) for k in range(4)]
    series = {
        'chamber_pressure': logged('p', pressure_times, [[k * 1e3] * 3 for k in range(4)]),
        'joint_states': logged(
            'q',
            [t + 1e-4 + s for t, s in zip(pressure_times, stall, strict=True)],
            [[k * 0.1] * 3 for k in range(4)],
        ),
    }
    pressure, angles = step_pairs(series)
    np.testing.assert_array_equal(pressure[:, 0], [k * 1e3 for k in range(4)])
    np.testing.assert_array_equal(angles[:, 0], [k * 0.1 for k in range(4)])


@pytest.mark.parametrize(
    ('arguments', 'fragment'),
    [
        (['--output', 'x', '--ros-args', '-p'], 'recorder: error: Failed to parse ROS arguments'),
        (['--output', 'x', '--duration', '1'], 'unrecognized arguments: --duration 1'),  # timeout
    ],
)
def test_recorder_refuses_bad_arguments(arguments, fragment, tmp_path, monkeypatch, capsys):
    # The recorder's main, in this process: it refuses before rclpy starts (the command's exit
    # status and stderr: test_recorder_refuses_an_existing_output).
    monkeypatch.chdir(tmp_path)
    try:
        code = recorder_main(arguments)
    except SystemExit as exit_:  # argparse's error exit
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err
    assert fragment in err and 'Traceback' not in err
    assert not (tmp_path / 'x').exists()
