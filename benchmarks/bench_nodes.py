"""Speed figures of issue 3 for the three glove nodes.

Prints, measured in one run on this machine:

1. the cost of one plant step (take the latest command through the subscription callback,
   advance the chambers, solve warm-started, publish joint_states, chamber_pressure and
   contact_forces to a live subscriber), median and p99, beside the round trip of a bare rclpy
   echo node (JointState ping → pong between two processes) measured in the same run; the
   markers (published at 10 Hz, not every step) are timed separately and amortised;
2. the highest plant ``rate_hz`` (of the ones tried) that keeps fewer than 1 % late cycles
   (a cycle is late when it starts more than 1.5 periods after the previous one) over
   ``--duration`` seconds, with a pressure_command session driving it; measured in
   ``--windows`` consecutive windows and judged on the median one, since other work on a
   shared machine makes single windows noisy;
3. the CPU use of each node (% of one core) at the default 100 Hz, beside that of a bare rclpy
   node with the plant's input and outputs and none of its work (the executor's floor).

Run: ``.venv/bin/python benchmarks/bench_nodes.py [--duration 10] [--windows 3]
[--rates 250 500 1000 2000]``.
Targets (issue 3): ≥ 500 Hz, plant ≤ 15 % of a core at 100 Hz, step median ≤ 1× echo round trip.
"""

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests'))

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from exodigit_nodes.nodes.plant import Plant
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions
from ros_harness import (
    DISCOVERY_TIMEOUT,
    NodeLauncher,
    RosProbe,
    claim_domain,
    cpu_seconds,
    ros_environment,
    wait_until,
)
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from visualization_msgs.msg import MarkerArray

STEPS = 3000
PINGS = 1000
LATE_LIMIT = 0.01
WARM_UP = 3.0  # s before measuring a running process
NS = '/bench_nodes'


def percentile(values, q):
    return float(np.percentile(np.asarray(values), q))


# -- echo round trip ------------------------------------------------------------------------


def spin_until_stopped(node) -> None:
    """Spin a helper node (plain rclpy, Python executor) until it is interrupted."""
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()


def echo_main() -> None:
    """The bare echo node: republish every JointState from ``ping`` on ``pong``."""
    rclpy.init()
    node = rclpy.create_node('bench_echo')
    pong = node.create_publisher(JointState, 'pong', 10)
    node.create_subscription(JointState, 'ping', pong.publish, 10)
    spin_until_stopped(node)


def bare_main(namespace: str) -> None:
    """A bare rclpy node with the plant's I/O and none of its work: the executor's floor.

    Subscribes to the glove's ``pressure_command`` and publishes a JointState and two
    Float64MultiArray at 100 Hz (on ``bare_*`` topics, so the glove does not hear them).
    """
    rclpy.init()
    node = rclpy.create_node('bench_bare', namespace=namespace)
    publishers = [
        (node.create_publisher(JointState, 'bare_joint_states', 10), JointState),
        (node.create_publisher(Float64MultiArray, 'bare_chamber_pressure', 10), Float64MultiArray),
        (node.create_publisher(Float64MultiArray, 'bare_contact_forces', 10), Float64MultiArray),
    ]
    latest = []
    node.create_subscription(Float64MultiArray, 'pressure_command', latest.append, 10)

    def publish_all():
        latest.clear()
        for publisher, kind in publishers:
            publisher.publish(kind())

    node.create_timer(0.01, publish_all)
    spin_until_stopped(node)


def echo_round_trips(domain_id: int, workdir: Path) -> list[float]:
    """Round-trip times (s) of PINGS JointState messages through the echo process."""
    echo = subprocess.Popen(
        [sys.executable, __file__, '--echo'],
        env=ros_environment(domain_id),
        cwd=workdir,
        start_new_session=True,
    )
    context = rclpy.Context()
    rclpy.init(
        context=context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO
    )
    node = rclpy.create_node('bench_pinger', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    replies = []
    ping = node.create_publisher(JointState, 'ping', 10)
    node.create_subscription(JointState, 'pong', replies.append, 10)
    message = JointState(name=['mcp', 'pip', 'dip'], position=[0.1, 0.2, 0.3])
    message.velocity = [0.0] * 3
    message.effort = [0.0] * 3
    deadline = time.monotonic() + DISCOVERY_TIMEOUT
    while not replies and time.monotonic() < deadline:  # until the path works both ways
        ping.publish(message)
        executor.spin_once(timeout_sec=0.05)
    times = []
    for _ in range(PINGS):
        replies.clear()
        started = time.perf_counter()
        ping.publish(message)
        while not replies:
            executor.spin_once(timeout_sec=1.0)
        times.append(time.perf_counter() - started)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    echo.terminate()
    echo.wait()
    return times


# -- one plant step -------------------------------------------------------------------------


def step_costs(domain_id: int) -> tuple[list[float], list[float]]:
    """Times (s) of STEPS plant steps and of 200 marker publications, in this process."""
    probe = RosProbe(domain_id, 'bench_step_probe')
    inboxes = [
        probe.subscribe(f'{NS}_step/{topic}', kind)
        for topic, kind in (
            ('joint_states', JointState),
            ('chamber_pressure', Float64MultiArray),
            ('contact_forces', Float64MultiArray),
            ('markers', MarkerArray),
        )
    ]
    rclpy.init(
        args=['--ros-args', '-r', f'__ns:={NS}_step', '-p', 'pressure_time_constant:=0.05'],
        domain_id=domain_id,
        signal_handler_options=SignalHandlerOptions.NO,
    )
    plant = Plant()  # not spun: its wall timer never fires, the loop below steps it
    wait_until(
        lambda: all(
            p.get_subscription_count() > 0
            for p in (plant.joint_publisher, plant.pressure_publisher, plant.force_publisher)
        ),
        DISCOVERY_TIMEOUT,
    )
    command = Float64MultiArray()
    steps = []
    for i in range(STEPS):
        level = 25e3 * (1.0 - math.cos(2.0 * math.pi * i / 400.0))
        command.data = [level, 0.8 * level, 0.6 * level]
        started = time.perf_counter()
        plant.on_command(command)
        plant.on_wall_timer()
        steps.append(time.perf_counter() - started)
    markers = []
    for _ in range(200):
        started = time.perf_counter()
        plant.publish_markers()
        markers.append(time.perf_counter() - started)
    wait_until(lambda: inboxes[0].count() >= STEPS * 0.9, 10.0)
    plant.destroy_node()
    rclpy.try_shutdown()
    probe.close()
    return steps, markers


# -- running processes ----------------------------------------------------------------------


def plant_cycles(inbox, namespace):
    """(stamp s, cycles, late cycles) of the latest plant diagnostics in ``namespace``."""
    for array in reversed(inbox.messages()):
        for status in array.status:
            if status.name == f'{namespace}/plant':
                values = {kv.key: kv.value for kv in status.values}
                stamp = array.header.stamp.sec + array.header.stamp.nanosec * 1e-9
                return stamp, int(values['cycles']), int(values['late cycles'])
    return None


def sustained_rate(launcher, diagnostics, rate_hz: float, duration: float, windows: int):
    """Per window of ``duration`` s: (seconds, cycles, late cycles) of a plant at ``rate_hz``."""
    namespace = f'{NS}_{int(rate_hz)}'
    session = {'mode': 'sine', 'sine_period': 2.0}
    nodes = [
        launcher.start('plant', {'rate_hz': rate_hz}, namespace=namespace),
        launcher.start('pressure_command', session, namespace=namespace),
    ]
    assert wait_until(lambda: plant_cycles(diagnostics, namespace), 30.0), nodes[0].stderr()
    time.sleep(WARM_UP)  # let start-up transients pass before the measured windows
    results = []
    first = plant_cycles(diagnostics, namespace)
    for _ in range(windows):
        time.sleep(duration)
        last = plant_cycles(diagnostics, namespace)
        results.append(tuple(b - a for a, b in zip(first, last, strict=True)))
        first = last
    for node in nodes:
        node.stop()
    return results


def cpu_at_100_hz(launcher, probe, duration: float, workdir: Path) -> dict[str, float]:
    """% of one core used by each node of a glove at the default 100 Hz, and by a bare node."""
    namespace = f'{NS}_cpu'
    states = probe.subscribe(f'{namespace}/estimated_contact_forces', JointState)
    for topic, kind in (
        ('bare_joint_states', JointState),
        ('bare_chamber_pressure', Float64MultiArray),
        ('bare_contact_forces', Float64MultiArray),
    ):
        probe.subscribe(f'{namespace}/{topic}', kind)
    nodes = {
        'plant': launcher.start('plant', {}, namespace=namespace),
        'pressure_command': launcher.start('pressure_command', {}, namespace=namespace),
        'estimator': launcher.start('estimator', {}, namespace=namespace),
    }
    bare = subprocess.Popen(
        [sys.executable, __file__, '--bare', namespace],
        env=ros_environment(launcher.domain_id),
        cwd=workdir,
        start_new_session=True,
    )
    assert states.wait_count(10, 30.0), nodes['estimator'].stderr()
    time.sleep(WARM_UP)
    processes = {name: node.pid for name, node in nodes.items()}
    processes['bare rclpy node'] = bare.pid
    before = {name: cpu_seconds(pid) for name, pid in processes.items()}
    started = time.monotonic()
    time.sleep(duration)
    elapsed = time.monotonic() - started
    used = {
        name: 100.0 * (cpu_seconds(pid) - before[name]) / elapsed
        for name, pid in processes.items()
    }
    for node in nodes.values():
        node.stop()
    bare.terminate()
    bare.wait()
    return used


def main(argv=None) -> int:
    """Measure and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--duration', type=float, default=10.0, help='seconds per measurement')
    parser.add_argument(
        '--rates', type=float, nargs='+', default=[250.0, 500.0, 1000.0, 2000.0], help='Hz'
    )
    parser.add_argument('--windows', type=int, default=3, help='measurement windows per rate')
    parser.add_argument('--echo', action='store_true', help=argparse.SUPPRESS)
    parser.add_argument('--bare', help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.echo:
        echo_main()
        return 0
    if args.bare:
        bare_main(args.bare)
        return 0
    lease = claim_domain()
    print(f'ROS_DOMAIN_ID={lease.domain_id}, discovery on loopback only')
    print('load average at start (1, 5, 15 min): {:.1f} {:.1f} {:.1f}'.format(*os.getloadavg()))
    with tempfile.TemporaryDirectory(prefix='bench_nodes_') as workdir:
        round_trips = echo_round_trips(lease.domain_id, Path(workdir))
        steps, markers = step_costs(lease.domain_id)
        probe = RosProbe(lease.domain_id, 'bench_nodes_probe')
        diagnostics = probe.subscribe('/diagnostics', DiagnosticArray)
        launcher = NodeLauncher(lease.domain_id, Path(workdir))
        try:
            rates = {
                rate: sustained_rate(launcher, diagnostics, rate, args.duration, args.windows)
                for rate in args.rates
            }
            cpu = cpu_at_100_hz(launcher, probe, args.duration, Path(workdir))
        finally:
            launcher.stop_all()
            probe.close()
            lease.release()

    echo_median = statistics.median(round_trips)
    step_median = statistics.median(steps)
    print('\n1. one plant step vs. the transport')
    print(
        f'   echo round trip (JointState, 2 processes): median {echo_median * 1e6:7.1f} µs, '
        f'p99 {percentile(round_trips, 99) * 1e6:7.1f} µs  ({PINGS} pings)'
    )
    print(
        f'   plant step (command, chambers, solve, 3 publishes): median {step_median * 1e6:7.1f} '
        f'µs, p99 {percentile(steps, 99) * 1e6:7.1f} µs  ({STEPS} steps)'
    )
    print(
        f'   markers: median {statistics.median(markers) * 1e6:7.1f} µs per publication, at '
        f'10 Hz of 100 Hz = {statistics.median(markers) * 0.1e6:5.1f} µs per step'
    )
    print(f'   step median / echo median = {step_median / echo_median:.2f}  (target ≤ 1, 0.5)')
    print(
        f'\n2. sustained plant rate: {args.windows} windows of {args.duration:g} s per rate '
        '(late: > 1.5 periods); a rate is sustained when the median window has < 1 % late'
    )
    best = None
    for rate, windows in rates.items():
        fractions, achieved = [], []
        for seconds, cycles, late in windows:
            fractions.append(late / cycles if cycles else 1.0)
            achieved.append(cycles / seconds if seconds > 0 else 0.0)
        ok = (
            statistics.median(achieved) > 0.99 * rate and statistics.median(fractions) < LATE_LIMIT
        )
        best = rate if ok else best
        cells = ', '.join(
            f'{a:5.0f}/s {100 * f:5.2f} %' for a, f in zip(achieved, fractions, strict=True)
        )
        print(f'   {rate:6.0f} Hz: {cells}  {"ok" if ok else "NOT sustained"}')
    print(f'   highest sustained rate: {best or 0:.0f} Hz  (target ≥ 500 Hz)')
    print('load average at end (1, 5, 15 min): {:.1f} {:.1f} {:.1f}'.format(*os.getloadavg()))
    print(f'\n3. CPU at 100 Hz (% of one core, over {args.duration:g} s)')
    for name, percent in cpu.items():
        print(f'   {name:17s} {percent:5.1f} %' + ('  (target ≤ 15 %)' if name == 'plant' else ''))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
