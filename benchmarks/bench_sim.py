"""Speed and determinism of simulated time (issue 8), printed as figures.

1. Lockstep, ``real_time_factor 0``: plant + pressure_command (sine) + estimator over DDS, 60
   simulated seconds at 100 Hz; wall time from resuming the paused plant to its state at 60 s
   (a recorder in this process takes every joint_states and pressure_command).
   [>= 20x real time, stretch 50x]
2. A controller in the benchmark process through ``GloveSim.step``. [>= 20x real time]
3. ``GloveSimulation`` in process: one glove, and a batch of 1,000.
   [>= 10,000 steps/s; >= 200,000 glove-steps/s]
4. Determinism: two lockstep runs of the same seeded 6,000-step session (sensor noise on), the
   second while ``--burners`` processes keep the cores busy: samples of joint_states positions
   and commands that differ. [0]
5. ``real_time_factor 1`` (lockstep with pressure_command): simulated against wall time over
   ``--realtime`` seconds. [within 1 %]

Run: ``.venv/bin/python benchmarks/bench_sim.py [--seconds 60] [--repeats 3] [--realtime 30]``.
Every ROS process runs in a domain of its own with discovery on loopback.
"""

import argparse
import math
import multiprocessing
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rclpy
from exodigit_nodes.qos import RECORD_QOS
from exodigit_nodes.testing import GloveSim, claim_domain
from exodigit_nodes.testing.processes import NodeProcess
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool

from exodigit_model import GloveSimulation

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
RATE_HZ = 100.0
NS = '/bench_sim'
START_TIMEOUT = 60.0


class Recorder(Node):
    """Every joint_states position and pressure_command of the session, in arrival order."""

    def __init__(self, context) -> None:
        super().__init__('bench_sim_recorder', namespace=NS, context=context)
        self.positions: list = []
        self.stamps: list = []
        self.commands: list = []
        self.wall: list = []
        self.create_subscription(JointState, 'joint_states', self.on_state, RECORD_QOS)
        self.create_subscription(
            Float64MultiArray, 'pressure_command', self.on_command, RECORD_QOS
        )
        self.pause = self.create_client(SetBool, 'set_paused')

    def on_state(self, message: JointState) -> None:
        self.positions.append(tuple(message.position))
        self.stamps.append(message.header.stamp.sec * 10**9 + message.header.stamp.nanosec)
        self.wall.append(time.monotonic())

    def on_command(self, message: Float64MultiArray) -> None:
        self.commands.append(tuple(message.data))


def spin_until(executor, condition, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        executor.spin_once(timeout_sec=0.01)
    return True


def glove_session(seconds: float, workdir: Path, *, factor: float = 0.0, noise: bool = False):
    """Plant, estimator, pressure_command in lockstep; (wall s, recorder) for ``seconds``."""
    lease = claim_domain()
    plant = {
        'clock': 'sim',
        'lockstep': True,
        'real_time_factor': factor,
        'start_paused': True,
        'pause_at': seconds,
        'marker_rate_hz': 0.0,
    }
    if noise:
        plant.update({'angle_noise_std': 1e-3, 'pressure_noise_std': 100.0, 'seed': 7})
    sim_time = {'use_sim_time': True}
    processes = [
        NodeProcess('plant', plant, lease.domain_id, workdir, NS),
        NodeProcess('estimator', sim_time, lease.domain_id, workdir, NS),
        NodeProcess(
            'pressure_command', {**sim_time, 'lockstep': True}, lease.domain_id, workdir, NS
        ),
    ]
    context = rclpy.Context()
    rclpy.init(
        context=context, domain_id=lease.domain_id, signal_handler_options=SignalHandlerOptions.NO
    )
    recorder = Recorder(context)
    executor = EventsExecutor(context=context)
    executor.add_node(recorder)
    try:
        ready = spin_until(
            executor,
            lambda: (
                recorder.pause.service_is_ready()
                and recorder.count_subscribers('joint_states') >= 3
                and recorder.count_publishers('pressure_command') >= 1
            ),
            START_TIMEOUT,
        )
        assert ready, 'the glove did not start'
        time.sleep(1.0)  # let discovery settle before the clock starts (not measured)
        steps = round(seconds * RATE_HZ)
        start = time.monotonic()
        recorder.pause.call_async(SetBool.Request(data=False))
        assert spin_until(executor, lambda: len(recorder.stamps) >= steps, 30 * seconds + 60)
        wall = recorder.wall[steps - 1] - start
        spin_until(executor, lambda: len(recorder.commands) >= steps, 10.0)
        return wall, recorder
    finally:
        for process in processes:
            process.stop()
        executor.shutdown()
        recorder.destroy_node()
        rclpy.try_shutdown(context=context)
        lease.release()


def burn(stop_at: float) -> None:
    while time.monotonic() < stop_at:
        pass


def lockstep_speed(seconds: float, repeats: int, workdir: Path) -> None:
    factors = []
    for _ in range(repeats):
        wall, recorder = glove_session(seconds, workdir)
        assert len(recorder.stamps) >= seconds * RATE_HZ
        factors.append(seconds / wall)
    print(
        f'1. lockstep, real_time_factor 0, plant + pressure_command (sine) + estimator, '
        f'{seconds:g} simulated s: {", ".join(f"{f:.1f}x" for f in factors)} real time '
        f'(median {statistics.median(factors):.1f}x, wall {seconds / max(factors):.2f}-'
        f'{seconds / min(factors):.2f} s)  [>= 20x, stretch 50x]'
    )


def kit_speed(seconds: float, repeats: int) -> None:
    steps = round(seconds * RATE_HZ)
    factors = []
    for _ in range(repeats):
        with GloveSim() as glove:
            state = glove.reset()
            start = time.monotonic()
            for k in range(steps):
                p = 20e3 * (1.0 - math.cos(2.0 * math.pi * k / 400))
                state = glove.step([p, p, p])
            factors.append(seconds / (time.monotonic() - start))
    print(
        f'2. controller in this process through GloveSim.step, {steps} steps: '
        f'{", ".join(f"{f:.1f}x" for f in factors)} real time  [>= 20x]'
    )
    assert state.q[0] >= 0.0


def stepper_speed(repeats: int) -> None:
    commands = 20e3 * (1.0 - np.cos(2.0 * np.pi * np.arange(6000) / 400))
    single, batch = [], []
    for _ in range(repeats):
        simulation = GloveSimulation()
        rows = [np.full(3, p) for p in commands]
        start = time.perf_counter()
        for row in rows:
            simulation.step(row)
        single.append(len(rows) / (time.perf_counter() - start))
        gloves = GloveSimulation(count=1000)
        scale = np.linspace(0.5, 1.0, 1000)[:, None] * np.ones(3)
        start = time.perf_counter()
        for p in commands[:200]:
            gloves.step(scale * p)
        batch.append(200 * 1000 / (time.perf_counter() - start))
    print(
        '3. GloveSimulation in process: one glove '
        f'{", ".join(f"{s:,.0f}" for s in single)} steps/s  [>= 10,000]; batch of 1,000 '
        f'{", ".join(f"{b:,.0f}" for b in batch)} glove-steps/s  [>= 200,000]'
    )


def determinism(workdir: Path, burners: int) -> None:
    seconds = 60.0
    _, quiet = glove_session(seconds, workdir, noise=True)
    stop_at = time.monotonic() + 3600
    busy = [multiprocessing.Process(target=burn, args=(stop_at,)) for _ in range(burners)]
    for process in busy:
        process.start()
    try:
        _, loaded = glove_session(seconds, workdir, noise=True)
    finally:
        for process in busy:
            process.terminate()
            process.join()
    steps = round(seconds * RATE_HZ)
    differing_states = sum(
        a != b for a, b in zip(quiet.positions[:steps], loaded.positions[:steps], strict=True)
    )
    differing_commands = sum(
        a != b for a, b in zip(quiet.commands[:steps], loaded.commands[:steps], strict=True)
    )
    print(
        f'4. determinism: two seeded {steps}-step lockstep sessions (the second beside '
        f'{burners} busy processes): {differing_states} joint_states positions and '
        f'{differing_commands} commands differ (of {steps} each)  [0]'
    )


def realtime(seconds: float, workdir: Path) -> None:
    _, recorder = glove_session(seconds, workdir, factor=1.0)
    stamps = np.array(recorder.stamps) * 1e-9
    wall = np.array(recorder.wall)
    simulated = stamps - stamps[0]
    elapsed = wall - wall[0]
    worst = np.max(np.abs(simulated - elapsed)[elapsed > 1.0] / elapsed[elapsed > 1.0])
    print(
        f'5. real_time_factor 1 over {seconds:g} s: simulated/wall at the end '
        f'{simulated[-1] / elapsed[-1]:.4f}, largest deviation after the first second '
        f'{100 * worst:.2f} %  [within 1 %]'
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=60.0, help='simulated s of run 1')
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--realtime', type=float, default=30.0, help='wall s of figure 5')
    parser.add_argument('--burners', type=int, default=os.cpu_count() or 2)
    parser.add_argument('--only', type=int, nargs='*', default=[1, 2, 3, 4, 5])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix='bench_sim_') as scratch:
        workdir = Path(scratch)
        if 1 in args.only:
            lockstep_speed(args.seconds, args.repeats, workdir)
        if 2 in args.only:
            kit_speed(args.seconds, args.repeats)
        if 3 in args.only:
            stepper_speed(args.repeats)
        if 4 in args.only:
            determinism(workdir, args.burners)
        if 5 in args.only:
            realtime(args.realtime, workdir)
    sys.stdout.flush()


if __name__ == '__main__':
    main()
