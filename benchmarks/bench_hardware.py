"""Speed figures of issue 36: the host-board link through a pseudo-terminal, and the bridge's CPU.

Prints, measured in one run on this machine, with ``mcu_emulator`` as the board (its own
process):

1. the round trip of the bytes alone: HELLO from the host's link core to the board's
   CAPABILITIES back (the board answers at once), through the pty both ways, median, p95 and
   largest over ``--hellos`` hellos;
2. the round trip of a command: OPENINGS sent to the first sample that applies them (the board
   applies them at its next sample: up to one period more), at 100 and 500 Hz;
3. the CPU of the ``hardware`` bridge node (% of one core) with a controller publishing
   ``valve_command`` at the board's rate, at 100 and 500 Hz, over ``--windows`` windows of
   ``--duration`` s each (the range is printed: a shared machine is noisy), beside the
   emulator's.

Run: ``.venv/bin/python benchmarks/bench_hardware.py [--duration 5] [--windows 3]``.
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests'))

import numpy as np
from exodigit_nodes.hardware.framing import FrameDecoder, encode_frame
from exodigit_nodes.hardware.link import Connected, HostLink, LinkSettings, SampleReceived
from exodigit_nodes.hardware.messages import Hello, MessageType, duties_of, encode
from exodigit_nodes.hardware.port import SerialPort
from ros_harness import NodeLauncher, RosProbe, claim_domain, cpu_seconds, ros_environment
from std_msgs.msg import Float64MultiArray

RATES = (100, 500)
WARM_UP = 3.0
FILL = [0.6, 0.3, 1.0, 0.0, 0.0, 0.0]
EMPTY = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0]


def start_emulator(directory: Path, rate: int, domain_id: int) -> tuple[subprocess.Popen, str]:
    link = str(directory / f'board-{rate}')
    process = subprocess.Popen(
        [sys.executable, '-m', 'exodigit_nodes.hardware.emulator', '--link', link,
         '--rate-hz', str(rate)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=ros_environment(domain_id),
    )  # fmt: skip
    process.stdout.readline()  # 'mcu_emulator: board ... on <link>': it serves
    return process, link


def stop(process: subprocess.Popen) -> None:
    process.stdin.write('quit\n')
    process.stdin.flush()
    process.wait(10)


def connected(link: HostLink) -> None:
    end = time.monotonic() + 10.0
    while time.monotonic() < end:
        if any(isinstance(e, Connected) for e in link.poll(time.monotonic())):
            return
        time.sleep(0.001)
    raise RuntimeError('the emulator did not answer')


def hello_round_trips(port: str, count: int) -> list[float]:
    """Times from a HELLO's write to its CAPABILITIES' arrival on the raw port, s."""
    serial = SerialPort(port, 115200)
    decoder = FrameDecoder()
    hello = encode_frame(encode(Hello()))
    times = []
    for _ in range(count):
        time.sleep(0.005)
        serial.read()  # samples of the session the hello restarts
        sent = time.perf_counter()
        serial.write(hello)
        deadline = sent + 1.0
        while time.perf_counter() < deadline:
            payloads = decoder.feed(serial.read())
            if any(p[0] == MessageType.CAPABILITIES for p in payloads):
                times.append(time.perf_counter() - sent)
                break
    serial.close()
    return times


def command_round_trips(port: str, seconds: float) -> list[float]:
    """Round trips of OPENINGS sent right after each sample (HostLink.round_trip), s."""
    link = HostLink(LinkSettings(port=port))
    connected(link)
    trips = []
    end = time.monotonic() + seconds
    count = 0
    while time.monotonic() < end:
        for event in link.poll(time.monotonic()):
            if isinstance(event, SampleReceived):
                if event.sample.applied_sequence and link.round_trip.count > len(trips):
                    trips.append(link.round_trip.last)
                count += 1
                link.send_openings(duties_of(FILL if count % 50 < 25 else EMPTY), time.monotonic())
    link.close()
    return trips


def figures(values: list[float]) -> str:
    ms = np.asarray(values) * 1e3
    return (
        f'median {statistics.median(ms):.2f} ms, p95 {np.percentile(ms, 95):.2f} ms, '
        f'largest {ms.max():.2f} ms (n={len(ms)})'
    )


def bridge_cpu(directory, domain_id, rate, duration, windows, probe) -> tuple[list, list]:
    emulator, port = start_emulator(directory, rate, domain_id)
    launcher = NodeLauncher(domain_id, directory)
    namespace = f'/bench_hw{rate}'
    bridge = launcher.start('hardware', {'port': port}, namespace=namespace)
    publisher = probe.publisher(f'{namespace}/valve_command', Float64MultiArray)
    stopping = threading.Event()

    def command() -> None:
        period, k = 1.0 / rate, 0
        next_time = time.monotonic()
        while not stopping.is_set():
            k += 1
            publisher.publish(Float64MultiArray(data=FILL if k % 200 < 100 else EMPTY))
            next_time += period
            time.sleep(max(0.0, next_time - time.monotonic()))

    thread = threading.Thread(target=command, daemon=True)
    thread.start()
    time.sleep(WARM_UP)
    bridge_share, emulator_share = [], []
    for _ in range(windows):
        start = time.monotonic(), bridge.cpu_seconds(), cpu_seconds(emulator.pid)
        time.sleep(duration)
        wall = time.monotonic() - start[0]
        bridge_share.append((bridge.cpu_seconds() - start[1]) / wall * 100)
        emulator_share.append((cpu_seconds(emulator.pid) - start[2]) / wall * 100)
    stopping.set()
    thread.join()
    launcher.stop_all()
    stop(emulator)
    return bridge_share, emulator_share


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--duration', type=float, default=5.0, help='s per CPU window')
    parser.add_argument('--windows', type=int, default=3)
    parser.add_argument('--hellos', type=int, default=300)
    options = parser.parse_args()
    lease = claim_domain()
    probe = RosProbe(lease.domain_id, 'bench_hardware')
    try:
        with tempfile.TemporaryDirectory() as scratch:
            directory = Path(scratch)
            for rate in RATES:
                emulator, port = start_emulator(directory, rate, lease.domain_id)
                try:
                    if rate == RATES[0]:
                        print(f'hello round trip through the pty: '
                              f'{figures(hello_round_trips(port, options.hellos))}')  # fmt: skip
                    trips = command_round_trips(port, 5.0)
                    print(f'{rate} Hz board: command round trip {figures(trips)} '
                          f'(period {1e3 / rate:.1f} ms)')  # fmt: skip
                finally:
                    stop(emulator)
            for rate in RATES:
                bridge, board = bridge_cpu(
                    directory, lease.domain_id, rate, options.duration, options.windows, probe
                )
                print(
                    f'{rate} Hz: bridge CPU {min(bridge):.1f}-{max(bridge):.1f} % of a core '
                    f'(median {statistics.median(bridge):.1f}), emulator '
                    f'{min(board):.1f}-{max(board):.1f} % ({options.windows} windows of '
                    f'{options.duration:g} s, valve_command at {rate} Hz)'
                )
    finally:
        probe.close()
        lease.release()


if __name__ == '__main__':
    main()
