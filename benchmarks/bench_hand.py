"""A whole hand under load: five gloves, their controllers and estimators.

Each finger (thumb, index, middle, ring, little) runs in its own namespace ``/hand/<finger>``
with joint prefix ``<finger>_`` and its own model file (``exodigit_nodes/config/hand``): a plant,
a ``pressure_command`` in ``sine`` mode and an ``estimator``, all at ``--rate`` Hz. With
``--layout one-process`` (default) a hand is one ``hand_nodes`` process, as the hand runner and
launch file start it (every node on one EventsExecutor); ``--layout processes`` starts the three
nodes of every finger as 15 processes (the layout before issue 11, kept for comparison).
``--hands 2`` runs two hands (``/hand`` and ``/hand2``), ``--busy``
keeps one core busy with another process meanwhile. A monitor node in this process listens for
``--duration`` seconds and prints, per process, CPU % of one core (and its own, so a starved
monitor shows), and per finger:

- late cycles: plant steps that started more than 1.5 periods after the previous one (the
  plant's own count, read from its /diagnostics at the start and end of the window), and the
  worst burst: the most late cycles between two of its reports (one per second);
- lost messages: gaps in the publication sequence numbers of the commands the monitor received
  (rclpy's message info, no change to the message type), and "message lost" events of the
  monitor's reliable subscriptions. The monitor's subscriptions keep 1000 samples, so a gap is a
  command the transport lost, not one the monitor was too slow to take;
- end-to-end latency p50/p99, command publish to the plant state that reflects it.

Latency method (no message type changes): the plants run with no chamber lag and no noise, so a
plant step publishes ``chamber_pressure`` exactly equal to the latest command (the sine stays
inside the supply range, and every command of a sine differs from the one before). The monitor
stamps each ``pressure_command`` and each ``chamber_pressure`` on arrival (same clock, same
transport path); the latency of a command is the arrival of the first ``chamber_pressure``
carrying its values minus the arrival of the command. The plant publishes ``joint_states``
just before ``chamber_pressure`` in the same step. A command overwritten by the next one
before a plant step used it is counted as superseded, not lost.

``--lockstep S``: instead, run the hand(s) in lockstep simulated time as fast as the CPU allows
(``--clock sim --lockstep --real-time-factor 0``) for S wall seconds and print how many
simulated seconds per wall second every finger made (the /clock the monitor receives).

Nodes run on a free ROS domain with loopback discovery (tests/ros_harness.py starts them).
Run: ``.venv/bin/python benchmarks/bench_hand.py [--duration 60] [--fingers thumb,index]``.
``--json FILE`` also writes the figures for tests.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / 'tests'))

from ros_harness import TEST_QOS, NodeLauncher, claim_domain  # noqa: E402

HAND_DIR = REPO / 'exodigit_nodes' / 'config' / 'hand'
FINGERS = ('thumb', 'index', 'middle', 'ring', 'little')
NODES = ('plant', 'pressure_command', 'estimator')
#: Seconds to wait for every plant's first joint_states.
START_TIMEOUT = 60.0


@dataclass
class FingerRecord:
    """What the monitor saw of one finger (arrival times in s, monotonic clock)."""

    commands: list[tuple[float, tuple[float, ...]]] = field(default_factory=list)
    sequence: list[int] = field(default_factory=list)
    pressures: list[tuple[float, tuple[float, ...]]] = field(default_factory=list)
    lost: int = 0
    diagnostics: dict[str, str] = field(default_factory=dict)
    late_counts: list[int] = field(default_factory=list)

    def clear(self) -> None:
        """Forget everything before the measurement window (keeps the latest diagnostics)."""
        self.commands.clear()
        self.sequence.clear()
        self.pressures.clear()
        self.lost = 0
        self.late_counts.clear()


def command_latencies(record: FingerRecord) -> tuple[list[float], int]:
    """Latency of each command that reached a plant step, s, and the number superseded."""
    arrivals: dict[tuple[float, ...], float] = {}
    for arrival, values in record.pressures:
        arrivals.setdefault(values, arrival)
    latencies, superseded = [], 0
    for index, (sent, values) in enumerate(record.commands):
        seen = arrivals.get(values)
        if seen is not None and seen >= sent:
            latencies.append(seen - sent)
        elif index + 1 < len(record.commands):
            superseded += 1
    return latencies, superseded


def worst_second(late_counts: list[int]) -> int:
    """Most late cycles between two consecutive plant reports (one per second): a burst."""
    return int(np.max(np.diff(late_counts), initial=0)) if len(late_counts) > 1 else 0


def sequence_gaps(sequence: list[int]) -> int:
    """Commands missing from a publisher's sequence numbers as received (lost on the way)."""
    steps = np.diff(np.asarray(sequence))
    return int(np.sum(steps[steps > 1] - 1))


def node_parameters(finger: str, rate: float) -> dict[str, dict]:
    """Parameters of the three nodes of one finger."""
    params = str(HAND_DIR / f'{finger}.yaml')
    return {
        'plant': {
            'params_file': params,
            'joint_prefix': f'{finger}_',
            'rate_hz': rate,
            'pressure_time_constant': 0.0,
            'marker_rate_hz': 0.0,
        },
        'pressure_command': {'params_file': params, 'mode': 'sine', 'rate_hz': rate},
        'estimator': {'params_file': params},
    }


def hand_namespaces(args: argparse.Namespace) -> list[str]:
    """``/hand``, then ``/hand2``... one per hand."""
    return ['/hand' + (str(i + 1) if i else '') for i in range(args.hands)]


def start_hands(launcher: NodeLauncher, args: argparse.Namespace) -> dict:
    """Start every hand in ``args.layout``; the processes by name."""
    if args.layout == 'processes':
        return {
            f'{hand}/{finger}/{node}': launcher.start(
                node, parameters, namespace=f'{hand}/{finger}'
            )
            for hand in hand_namespaces(args)
            for finger in args.fingers
            for node, parameters in node_parameters(finger, args.rate).items()
        }
    everyone = {'rate_hz': args.rate, 'pressure_time_constant': 0.0, 'marker_rate_hz': 0.0}
    sim = ['--clock', 'sim', '--lockstep', '--real-time-factor', '0'] if args.lockstep else []
    estimator = ['--estimator', 'false'] if args.no_estimator else []
    return {
        f'hand_nodes {hand}': launcher.start(
            'hand_nodes',
            everyone,
            arguments=['--fingers', ','.join(args.fingers), '--namespace', hand, *sim, *estimator],
        )
        for hand in hand_namespaces(args)
    }


def start_busy_process() -> subprocess.Popen:
    """Another process that keeps one core busy (a spinning Python loop)."""
    return subprocess.Popen([sys.executable, '-c', 'while True: pass'])


class HandMonitor:
    """An rclpy node recording commands, pressures and plant diagnostics per glove.

    ``gloves`` are the gloves' namespaces, ``/hand/<finger>``.
    """

    def __init__(self, gloves: list[str]) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.event_handler import SubscriptionEventCallbacks
        from rclpy.node import Node
        from std_msgs.msg import Float64MultiArray

        self.node = Node('bench_hand_monitor')
        self.records = {glove: FingerRecord() for glove in gloves}
        for glove, record in self.records.items():
            events = SubscriptionEventCallbacks(message_lost=self._lost(record))
            prefix = f'{glove}/'
            self.node.create_subscription(
                Float64MultiArray, prefix + 'pressure_command',
                self._commands(record), TEST_QOS, event_callbacks=events,
            )  # fmt: skip
            self.node.create_subscription(
                Float64MultiArray, prefix + 'chamber_pressure',
                self._values(record.pressures), TEST_QOS, event_callbacks=events,
            )  # fmt: skip
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._diagnostics, 50)

    @staticmethod
    def _commands(record: FingerRecord):
        def keep(message, info) -> None:
            record.commands.append((time.monotonic(), tuple(message.data)))
            record.sequence.append(info['publication_sequence_number'])

        return keep

    @staticmethod
    def _values(store: list):
        def record(message) -> None:
            store.append((time.monotonic(), tuple(message.data)))

        return record

    @staticmethod
    def _lost(record: FingerRecord):
        def lost(status) -> None:
            record.lost += status.total_count_change

        return lost

    def _diagnostics(self, message) -> None:
        for status in message.status:
            glove, _, node = status.name.rpartition('/')
            if node == 'plant':
                record = self.records.get(glove)
                if record is not None:
                    record.diagnostics = {kv.key: kv.value for kv in status.values}
                    record.late_counts.append(int(record.diagnostics['late cycles']))


def percentile_ms(values: list[float], q: float) -> float:
    """The ``q`` percentile of ``values`` (s) in ms, NaN when empty."""
    return float(np.percentile(values, q) * 1e3) if values else float('nan')


def measure(args: argparse.Namespace, domain_id: int) -> dict:
    """Start the hand, measure for ``args.duration`` s, stop it; return the figures."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    os.environ.update(ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_DOMAIN_ID=str(domain_id))
    log_dir = Path(args.log_dir)
    log_dir.mkdir(parents=True, exist_ok=True)
    launcher = NodeLauncher(domain_id, log_dir)
    nodes = start_hands(launcher, args)
    busy = start_busy_process() if args.busy else None
    rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
    gloves = [f'{hand}/{finger}' for hand in hand_namespaces(args) for finger in args.fingers]
    monitor = HandMonitor(gloves)
    executor = SingleThreadedExecutor()
    executor.add_node(monitor.node)
    period = 1.0 / args.rate
    try:
        deadline = time.monotonic() + START_TIMEOUT
        while not all(r.pressures and r.diagnostics for r in monitor.records.values()):
            exited = [name for name, node in nodes.items() if not node.alive()]
            if time.monotonic() > deadline or exited:
                raise RuntimeError(
                    f'the hand did not start within {START_TIMEOUT:g} s (logs in {log_dir}; '
                    f'exited: {exited})'
                )
            executor.spin_once(timeout_sec=0.05)
        start_cpu = {name: node.cpu_seconds() for name, node in nodes.items()}
        start_diag = {f: dict(r.diagnostics) for f, r in monitor.records.items()}
        monitor_cpu = time.process_time()
        for record in monitor.records.values():
            record.clear()
        started = time.monotonic()
        while time.monotonic() - started < args.duration:
            executor.spin_once(timeout_sec=0.05)
        elapsed = time.monotonic() - started
        cpu = {
            name: 100.0 * (node.cpu_seconds() - start_cpu[name]) / elapsed
            for name, node in nodes.items()
        }
        cpu['bench monitor (this process)'] = 100.0 * (time.process_time() - monitor_cpu) / elapsed
        crashed = [name for name, node in nodes.items() if not node.alive()]
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()
        launcher.stop_all()
        executor.shutdown()
        monitor.node.destroy_node()
        rclpy.try_shutdown()
    result = figures(monitor, start_diag, cpu, crashed, elapsed, period)
    result['nodes per glove'] = 2 if args.no_estimator else 3
    result['layout'] = (
        args.layout
        + (', lockstep' if args.lockstep else '')
        + (', one core kept busy' if args.busy else '')
    )
    return result


def figures(monitor, start_diag, cpu, crashed, elapsed, period) -> dict:
    """The printed and returned figures of one run."""
    fingers = {}
    all_latencies = []
    for finger, record in monitor.records.items():
        latencies, superseded = command_latencies(record)
        all_latencies += latencies
        end, begin = record.diagnostics, start_diag[finger]
        fingers[finger] = {
            'plant cycles': int(end['cycles']) - int(begin['cycles']),
            'late cycles (plant)': int(end['late cycles']) - int(begin['late cycles']),
            'worst second, late cycles': worst_second(record.late_counts),
            'commands received': len(record.commands),
            'commands expected': round(elapsed / period),
            'commands missing (sequence)': sequence_gaps(record.sequence),
            'messages lost': record.lost,
            'superseded commands': superseded,
            'latency p50 (ms)': percentile_ms(latencies, 50),
            'latency p99 (ms)': percentile_ms(latencies, 99),
            'watchdog trips': int(end['watchdog trips']) - int(begin['watchdog trips']),
            'simulated s per wall s': (
                float(end.get('simulated time (s)', 'nan'))
                - float(begin.get('simulated time (s)', 'nan'))
            )
            / elapsed,
        }
    return {
        'duration (s)': elapsed,
        'rate (Hz)': 1.0 / period,
        'crashed': crashed,
        'cpu (% of a core)': cpu,
        'fingers': fingers,
        'latency p50 (ms)': percentile_ms(all_latencies, 50),
        'latency p99 (ms)': percentile_ms(all_latencies, 99),
    }


def report(result: dict) -> str:
    """The figures as text."""
    lines = [
        f'{len(result["fingers"])} gloves x {result["nodes per glove"]} nodes at '
        f'{result["rate (Hz)"]:g} Hz for '
        f'{result["duration (s)"]:.1f} s ({result["layout"]}); crashed: '
        f'{result["crashed"] or "none"}',
        '',
        'CPU per process (% of one core):',
    ]
    lines += [f'  {name:28s} {value:6.1f}' for name, value in result['cpu (% of a core)'].items()]
    lines.append(f'  {"total":28s} {sum(result["cpu (% of a core)"].values()):6.1f}')
    lines.append('')
    columns = {
        'plant cycles': 'cycles',
        'late cycles (plant)': 'late',
        'worst second, late cycles': 'worst 1 s',
        'commands received': 'cmd recv',
        'commands expected': 'cmd expect',
        'commands missing (sequence)': 'cmd missing',
        'messages lost': 'lost',
        'superseded commands': 'superseded',
        'latency p50 (ms)': 'p50 ms',
        'latency p99 (ms)': 'p99 ms',
        'watchdog trips': 'wd trips',
        'simulated s per wall s': 'sim/wall',
    }
    lines.append('per finger:  ' + ' '.join(f'{short:>12s}' for short in columns.values()))
    for finger, row in result['fingers'].items():
        cells = [row[key] for key in columns]
        text = [f'{v:12.2f}' if isinstance(v, float) else f'{v:12d}' for v in cells]
        lines.append(f'  {finger:14s} ' + ' '.join(text))
    lines += [
        '  late = plant steps more than 1.5 periods after the previous one; worst 1 s = most late',
        '  steps between two plant reports; cmd missing = gaps in the publication sequence',
        '  numbers of the commands received; lost = DDS "message lost" events; superseded =',
        '  overwritten by the next command before a plant step used it; sim/wall = simulated',
        '  seconds per wall second (lockstep; nan on the wall clock)',
    ]
    lines.append('')
    lines.append(
        f'end-to-end latency, command publish -> plant state: p50 '
        f'{result["latency p50 (ms)"]:.2f} ms, p99 {result["latency p99 (ms)"]:.2f} ms'
    )
    return '\n'.join(lines)


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--duration', type=float, default=60.0, help='measured time, s')
    parser.add_argument('--rate', type=float, default=100.0, help='node rate, Hz')
    parser.add_argument(
        '--fingers',
        type=lambda text: text.split(','),
        default=list(FINGERS),
        help='comma-separated subset of ' + ','.join(FINGERS),
    )
    parser.add_argument(
        '--layout',
        choices=('one-process', 'processes'),
        default='one-process',
        help='per hand: one hand_nodes process (default, as the hand runner starts it), or three '
        'processes per glove',
    )
    parser.add_argument('--hands', type=int, default=1, help='number of hands (default 1)')
    parser.add_argument(
        '--busy', action='store_true', help='keep one core busy with another process meanwhile'
    )
    parser.add_argument(
        '--lockstep',
        action='store_true',
        help='in lockstep simulated time at real_time_factor 0 (not with --layout processes): '
        'measure the simulated seconds per wall second',
    )
    parser.add_argument(
        '--no-estimator',
        action='store_true',
        help='the plants and controllers alone (one-process layout)',
    )
    parser.add_argument('--log-dir', default='runs/bench_hand', help='node logs go here')
    parser.add_argument('--json', help='also write the figures to this file')
    return parser


def main(argv=None) -> int:
    """Run the benchmark and print the figures."""
    args = build_parser().parse_args(argv)
    unknown = sorted(set(args.fingers) - set(FINGERS))
    one_process_only = (args.lockstep or args.no_estimator) and args.layout == 'processes'
    if unknown or args.duration <= 0 or args.rate <= 0 or args.hands < 1 or one_process_only:
        print(f'bench_hand: bad arguments (unknown fingers {unknown})', file=sys.stderr)
        return 2
    lease = claim_domain()
    try:
        result = measure(args, lease.domain_id)
    finally:
        lease.release()
    print(report(result))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1))
    return 1 if result['crashed'] else 0


if __name__ == '__main__':
    raise SystemExit(main())
