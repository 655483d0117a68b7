"""Speed and determinism of simulated time (issue 8), printed as figures.

1. Lockstep, ``real_time_factor 0``: plant + pressure_command (sine) + estimator over DDS, 60
   simulated seconds at 100 Hz; wall time from resuming the paused plant to its state at 60 s
   (a recorder in this process takes every joint_states and pressure_command).
   [>= 20x real time, stretch 50x] Its time per step against the round trip of a bare rclpy
   echo between two processes, measured in the same run (``bench_nodes.echo_round_trips``).
   [<= 2x]
2. A controller in the benchmark process through ``GloveSim.step``. [>= 20x real time]
3. ``GloveSimulation`` in process, no ROS (issue "The model at compiled speed"; the model's own
   solve figures are in ``benchmarks/bench_model.py``):
   a. one glove through the public ``step``, a 6,000-step sine command 0-40 kPa;
      [>= 100,000 steps/s]
   b. ``run`` of the same 6,000 commands (every step inside compiled code);
      [>= 300,000 steps/s]
   c. a batch of 1,000 gloves, ``GloveSimulation(model, count=1000).step``, each glove its own
      phase of the sine, 200 steps after 20 that settle the chambers.
      [>= 1,000,000 glove-steps/s on one core]
   Rates from CPU time (``process_time``; the machine is a shared VM) and from wall time, each
   measured ``--repeats`` times (median, and the range). Ratios (``Nx``) compare CPU time per
   step with the plain-Python path of the same source, measured in the same run: the script
   runs itself with ``--plain`` under ``EXODIGIT_JIT=0`` in a subprocess, which times the same
   workloads ``--plain-repeats`` times (the batch with 100 gloves, 20 steps) and prints JSON.
   Run ``python -m exodigit_model.tools.warm`` first, so that no kernel compiles here.
   ``--actuation valves`` times the same workloads behind valves (docs/spec/model.md §14: the
   sine's pressure share of 40 kPa as the inlets' opening, the rest as the outlets'); with
   ``--actuation regulator valves`` both, in the same run, and the ratio of their batch rates.
   [valves >= 50 % of the regulator's glove-steps/s]
4. Determinism: two lockstep runs of the same seeded 6,000-step session (sensor noise on), the
   second while ``--burners`` processes keep the cores busy: samples of joint_states positions
   and commands that differ. [0]
5. ``real_time_factor 1`` (lockstep with pressure_command): simulated against wall time over
   ``--realtime`` seconds. [within 1 %]

Run: ``.venv/bin/python benchmarks/bench_sim.py [--seconds 60] [--repeats 3] [--realtime 30]``
(``--only 3``: the in-process figures alone). Every ROS process runs in a domain of its own with
discovery on loopback.
"""

import argparse
import gc
import json
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
from bench_nodes import PINGS, echo_round_trips
from exodigit_model.kernels import jit
from exodigit_nodes.nodes.qos import RECORD_QOS
from exodigit_nodes.testing import GloveSim, claim_domain
from exodigit_nodes.testing.processes import NodeProcess
from plain_path import run_plain
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool

from exodigit_model import ACTUATIONS, GloveModel, GloveSimulation

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
RATE_HZ = 100.0
NS = '/bench_sim'
START_TIMEOUT = 60.0
SINE_STEPS = 6000
SINE_PERIOD = 400
"""Figure 3's command: 20 kPa (1 - cos) over a period of 400 steps (0-40 kPa), 6,000 steps."""
BATCH = {'compiled': (1000, 200), 'plain': (100, 20)}
"""Figure 3c's gloves and timed steps, compiled and on the plain-Python path."""
SETTLE_STEPS = 20
"""Untimed steps of figure 3c's batch before the timed ones (four chamber time constants)."""


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
        'run_until': seconds,
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
    lease = claim_domain()
    try:
        echo = statistics.median(echo_round_trips(lease.domain_id, workdir))
    finally:
        lease.release()
    step = 1.0 / (RATE_HZ * statistics.median(factors))  # wall s per simulated step
    print(
        f'   a lockstep step takes {1e3 * step:.2f} ms (median run) = {step / echo:.1f}x the '
        f'round trip of a bare two-process rclpy echo ({1e3 * echo:.2f} ms, median of '
        f'{PINGS})  [<= 2x]'
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


def sine(phase=0.0):
    """Figure 3's command of every step, Pa: (steps,) or (steps, gloves) with ``phase`` rows."""
    k = np.arange(SINE_STEPS)[:, None] if np.ndim(phase) else np.arange(SINE_STEPS)
    return 20e3 * (1.0 - np.cos(2.0 * np.pi * k / SINE_PERIOD + phase))


def workload(pressures: np.ndarray, actuation: str) -> np.ndarray:
    """Figure 3's command rows from the sine's ``pressures`` (Pa), one value per row or glove.

    With regulators the pressure for all three chambers; behind valves six openings: the
    pressure's share of 40 kPa for the inlets, the rest for the outlets.
    """
    if actuation == 'regulator':
        return np.repeat(pressures[..., None], 3, axis=-1)
    share = np.repeat(pressures[..., None] / 40e3, 3, axis=-1)
    return np.concatenate([share, 1.0 - share], axis=-1)


def _clocked(function, arguments: list) -> tuple[float, float]:
    """(CPU s, wall s) of ``function(a)`` for every ``a`` of ``arguments``, the GC off."""
    gc.disable()
    try:
        cpu, wall = time.process_time(), time.perf_counter()
        for argument in arguments:
            function(argument)
        return time.process_time() - cpu, time.perf_counter() - wall
    finally:
        gc.enable()


def stepper_timings(repeats: int, path: str, actuation: str = 'regulator') -> dict:
    """Figure 3 on this process's path: per workload the CPU and wall s per (glove-)step.

    ``path``: 'compiled' or 'plain' (which batch of :data:`BATCH` to time); ``actuation``: one
    of ``ACTUATIONS`` (:func:`workload`).
    """
    model = GloveModel()
    commands = workload(sine(), actuation)
    rows = list(commands)

    def simulation(**options) -> GloveSimulation:
        return GloveSimulation(model, actuation=actuation, **options)

    simulation().step(rows[1])  # loads the compiled kernels (compiles them if stale)
    simulation().run(commands[:5])
    timings = {name: {'cpu': [], 'wall': []} for name in ('step', 'run', 'batch')}

    def record(name: str, seconds: tuple[float, float], steps: int) -> None:
        timings[name]['cpu'].append(seconds[0] / steps)
        timings[name]['wall'].append(seconds[1] / steps)

    failures, same = 0, True
    for _ in range(repeats):
        stepped = simulation()
        record('step', _clocked(stepped.step, rows), SINE_STEPS)
        ran = simulation()
        record('run', _clocked(ran.run, [commands]), SINE_STEPS)
        failures += stepped.solver_failures + ran.solver_failures
        same = same and bool(np.array_equal(stepped.state.q, ran.state.q))

    count, steps = BATCH[path]
    phases = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    batch = np.ascontiguousarray(workload(sine(phases)[:SINE_PERIOD], actuation))
    gloves = simulation(count=count)
    for k in range(SETTLE_STEPS):
        gloves.step(batch[k])
    k = SETTLE_STEPS
    for _ in range(repeats):
        timed = [batch[(k + i) % SINE_PERIOD] for i in range(steps)]
        k += steps
        record('batch', _clocked(gloves.step, timed), steps * count)
    failures += gloves.solver_failures
    return {
        'timings': timings,
        'jit': jit.JIT,
        'failures': failures,
        'same': same,
        'gloves': count,
        'steps': steps,
    }


def _rates(seconds: list[float], unit: str) -> str:
    """Rate from the median s per step: CPU (the range over repeats)."""
    rates = [1.0 / value for value in seconds]
    return (
        f'{1.0 / statistics.median(seconds):,.0f} {unit}/s CPU ({min(rates):,.0f}-'
        f'{max(rates):,.0f} over {len(rates)} repeats)'
    )


def stepper_speed(repeats: int, plain_repeats: int, actuation: str = 'regulator') -> float:
    """Print figure 3 with ``actuation``; the batch's glove-steps/s (median, CPU)."""
    began = time.perf_counter()
    options = ['--actuation', actuation]
    plain = run_plain(__file__, plain_repeats, options) if plain_repeats > 0 else None
    plain_seconds = time.perf_counter() - began
    ours = stepper_timings(repeats, 'compiled' if jit.JIT else 'plain', actuation)

    def figure(name: str, unit: str) -> str:
        timing = ours['timings'][name]
        text = (
            f'{_rates(timing["cpu"], unit)}, {1.0 / statistics.median(timing["wall"]):,.0f}/s wall'
        )
        if plain is not None:
            reference = statistics.median(plain['timings'][name]['cpu'])
            ratio = reference / statistics.median(timing['cpu'])
            text += f'; plain Python {1.0 / reference:,.0f}/s CPU: {ratio:,.1f}x'
        return text

    path = 'compiled' if jit.JIT else 'NOT compiled (numba missing or EXODIGIT_JIT=0)'
    context = f'3. {actuation}: exodigit_model kernels {path}, source digest {jit.source_digest()}'
    if plain is not None:
        context += (
            f'; the plain-Python path (EXODIGIT_JIT=0, a subprocess, {plain_repeats} repeats, '
            f'its batch {plain["gloves"]} gloves x {plain["steps"]} steps): {plain_seconds:.0f} '
            f's, solver failures {plain["failures"]}'
        )
    print(context)
    gloves, steps = ours['gloves'], ours['steps']
    print(
        f'3a. GloveSimulation.step, one glove through the public API, {SINE_STEPS:,}-step sine '
        f'0-40 kPa: {figure("step", "steps")}  [>= 100,000 steps/s]'
    )
    print(
        f'3b. GloveSimulation.run({SINE_STEPS:,} commands), the same sine: '
        f"{figure('run', 'steps')}; its last q equals the stepped one's: {ours['same']}"
        '  [>= 300,000 steps/s]'
    )
    print(
        f'3c. GloveSimulation(model, count={gloves}).step, each glove its own phase of the sine, '
        f'{steps} steps after {SETTLE_STEPS}: {figure("batch", "glove-steps")}; solver failures '
        f'in 3a-3c: {ours["failures"]}  [>= 1,000,000 glove-steps/s on one core]'
    )
    return 1.0 / statistics.median(ours['timings']['batch']['cpu'])


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
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog='The module docstring says what each figure measures and its target.',
    )
    parser.add_argument(
        '--seconds', type=float, default=60.0, help='simulated s of figure 1 (default 60)'
    )
    parser.add_argument(
        '--repeats',
        type=int,
        default=3,
        help='times figures 1, 2 and 3 are measured (default 3)',
    )
    parser.add_argument(
        '--plain-repeats',
        type=int,
        default=1,
        help='times figure 3 is measured on the plain-Python path (EXODIGIT_JIT=0, in a '
        'subprocess) for its "Nx" ratios; 0: skip that path and print no ratios (default 1)',
    )
    parser.add_argument(
        '--realtime', type=float, default=30.0, help='wall s of figure 5 (default 30)'
    )
    parser.add_argument(
        '--burners',
        type=int,
        default=os.cpu_count() or 2,
        help='busy processes beside the second run of figure 4 (default: one per core)',
    )
    parser.add_argument(
        '--only',
        type=int,
        nargs='*',
        default=[1, 2, 3, 4, 5],
        help='the figures to measure, e.g. --only 3 (default: all five)',
    )
    parser.add_argument(
        '--actuation',
        nargs='+',
        choices=ACTUATIONS,
        default=['regulator'],
        help="figure 3's actuation, or several measured in turn (default regulator)",
    )
    parser.add_argument(
        '--plain',
        action='store_true',
        help="internal: time figure 3's workloads on this process's path (--repeats times) and "
        'print the timings as one JSON line; what the script runs in its EXODIGIT_JIT=0 '
        'subprocess',
    )
    args = parser.parse_args()
    if args.repeats < 1 or args.plain_repeats < 0:
        parser.error('--repeats must be >= 1, --plain-repeats >= 0')
    if args.plain:
        print(json.dumps(stepper_timings(args.repeats, 'plain', args.actuation[0])))
        return
    began = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix='bench_sim_') as scratch:
        workdir = Path(scratch)
        if 1 in args.only:
            lockstep_speed(args.seconds, args.repeats, workdir)
        if 2 in args.only:
            kit_speed(args.seconds, args.repeats)
        if 3 in args.only:
            rates = {
                actuation: stepper_speed(args.repeats, args.plain_repeats, actuation)
                for actuation in args.actuation
            }
            if len(rates) == len(ACTUATIONS):
                share = rates['valves'] / rates['regulator']
                print(
                    f'3d. the batch behind valves at {100 * share:.0f} % of its glove-steps/s '
                    'with regulators (CPU, medians of this run)  [>= 50 %]'
                )
        if 4 in args.only:
            determinism(workdir, args.burners)
        if 5 in args.only:
            realtime(args.realtime, workdir)
    print(f'bench_sim.py: {time.perf_counter() - began:.0f} s in all  [no target]')
    sys.stdout.flush()


if __name__ == '__main__':
    main()
