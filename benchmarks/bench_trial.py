"""Speed of a virtual patient trial in process: glove-steps per second, controller and metrics in.

Issue 17's figure: 10,000 patients × 60 s at 100 Hz (60 million glove-steps) with a built-in
controller in <= 90 s on one core, >= 700,000 glove-steps/s. This runs ``run_trial`` on the
local engine (the shards one after the other, each one batch on the compiled stepper), prints
the wall and CPU time and the glove-steps per second of each repeat, then splits one shard's
step into its parts (``--profile``): the controller's command, the stepper's step and the
metrics' update, timed separately over the same steps.

Run ``python -m exodigit_model.tools.warm`` first (``make bench`` does), then
``.venv/bin/python benchmarks/bench_trial.py`` (the full figure, about two minutes a repeat) or
``--patients 1000 --duration 10`` for a quick look. No asserts: figures only (a shared 2-core
VM: other work runs beside it; compare the CPU time with the wall time).

``--ray`` (the ``ray`` extra) then gives issue 17's Ray figure: the same trial on a local Ray
instance (``RayEngine``, bound to 127.0.0.1) of 1 worker and of 2 workers, each started and its
workers warmed up (the package imported, the kernels loaded) before the clock starts; the wall
time, the speed-up of 2 workers over 1 (target >= 1.6x on two cores), and whether every
patient's metrics equal the in-process run's bit for bit.
"""

from __future__ import annotations

import argparse
import gc
import time
from dataclasses import replace

import numpy as np
from exodigit_model.trials import (
    METRICS,
    ControllerSpec,
    MetricAccumulator,
    PatientMetrics,
    TrialSpec,
    run_trial,
    shard_patients,
)
from exodigit_model.trials.controllers import build_controller, limiter_acted

from exodigit_model import GloveModel, GloveSimulation


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--patients', type=int, default=10_000)
    parser.add_argument('--duration', type=float, default=60.0, help='s (60)')
    parser.add_argument('--rate', type=float, default=100.0, help='Hz (100)')
    parser.add_argument('--mode', default='sine', help='built-in mode (sine)')
    parser.add_argument('--estimate-forces', action='store_true', help='limiter force feedback')
    parser.add_argument('--shard-size', type=int, default=1000)
    parser.add_argument('--repeats', type=int, default=2)
    parser.add_argument('--profile', type=int, default=300, metavar='STEPS', help='0: none')
    parser.add_argument('--ray', action='store_true', help='also on Ray: 1 worker against 2')
    return parser.parse_args()


def spec_of(args: argparse.Namespace) -> TrialSpec:
    parameters = {'estimate_forces': True} if args.estimate_forces else {}
    return TrialSpec(
        population='stroke_moderate',
        patients=args.patients,
        protocol='cpm',
        protocol_parameters={'duration': args.duration, 'rate_hz': args.rate},
        controller=ControllerSpec('mode', args.mode, parameters),
        shard_size=args.shard_size,
    )


def whole_trial(spec: TrialSpec, repeats: int) -> PatientMetrics:
    """The in-process figure; the per-patient metrics of the last run."""
    steps = spec.patients * spec.session().steps
    print(
        f'trial: {spec.patients:,} patients x {spec.session().steps:,} steps = {steps:,} '
        f'glove-steps, shards of {spec.shard_size:,}, {spec.controller}'
    )
    for repeat in range(repeats):
        gc.collect()
        wall, cpu = time.perf_counter(), time.process_time()
        metrics = run_trial(spec, progress=False).metrics
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        print(
            f'  run {repeat + 1}: wall {wall:7.1f} s, CPU {cpu:7.1f} s: '
            f'{steps / wall:10,.0f} glove-steps/s (wall), {steps / cpu:10,.0f} (CPU)'
        )
    return metrics


def on_ray(spec: TrialSpec, repeats: int, local: PatientMetrics) -> None:
    """Issue 17's Ray figure: a local instance of 2 workers against one of 1, same trial."""
    from exodigit_model.trials.ray_engine import RayEngine

    steps = spec.patients * spec.session().steps
    best = {}
    for workers in (1, 2):
        print(f'ray, a local instance of {workers} worker(s), {spec.shards} shards:')
        with RayEngine(workers=workers) as engine:
            warm_up = replace(spec, patients=workers, shard_size=1)
            run_trial(warm_up, engine=engine, progress=False)
            for repeat in range(repeats):
                wall = time.perf_counter()
                metrics = run_trial(spec, engine=engine, progress=False).metrics
                wall = time.perf_counter() - wall
                same = all(
                    np.array_equal(metrics.values[metric.name], local.values[metric.name])
                    for metric in METRICS
                )
                print(
                    f'  run {repeat + 1}: wall {wall:7.1f} s: {steps / wall:10,.0f} '
                    f'glove-steps/s; per patient as in process, bit for bit: {same}'
                )
                best[workers] = min(best.get(workers, wall), wall)
    print(f'speed-up of 2 workers over 1 (best runs): {best[1] / best[2]:.2f}x')


def profile(spec: TrialSpec, steps: int) -> None:
    """One shard's step split into controller, stepper and metrics, CPU µs per glove-step."""
    patients = shard_patients(spec, 0)
    count, protocol = len(patients), spec.session()
    model = GloveModel(spec.glove_params())
    settings = spec.simulation_settings(0)
    simulation = GloveSimulation(model, settings, fingers=patients.fingers)
    controller = build_controller(
        spec.controller, protocol=protocol, model=model, settings=settings
    )
    controller.reset(count)
    metrics = MetricAccumulator(count, spec.metric_settings())
    targets = protocol.targets(protocol.times()[:steps])
    spent = dict.fromkeys(('controller', 'stepper', 'metrics'), 0.0)
    state = simulation.state
    gc.disable()
    for target in targets:
        start = time.process_time()
        command = controller.command(state.t, simulation.period, state)
        middle = time.process_time()
        state = simulation.step(command)
        stepped = time.process_time()
        metrics.update(
            q=state.q,
            target=target,
            forces=state.forces,
            pressure=state.pressure,
            limited=limiter_acted(controller, count),
            solver_warning=~state.converged,
            outside_model=~(state.in_valid_range & state.in_range_of_motion),
        )
        end = time.process_time()
        spent['controller'] += middle - start
        spent['stepper'] += stepped - middle
        spent['metrics'] += end - stepped
    gc.enable()
    total = sum(spent.values())
    print(f'one shard of {count:,} gloves, {len(targets)} steps (CPU per glove-step):')
    for part, seconds in spent.items():
        micro = seconds / (count * len(targets)) * 1e6
        print(f'  {part:10s} {micro:6.3f} us  {100 * seconds / total:5.1f} %')
    print(
        f'  {"all":10s} {total / (count * len(targets)) * 1e6:6.3f} us  '
        f'= {count * len(targets) / total:,.0f} glove-steps/s'
    )
    print(f'  (iterations per solve in the last step: mean {np.mean(state.iterations):.2f})')


def main() -> None:
    args = arguments()
    spec = spec_of(args)
    if args.profile:
        profile(spec, min(args.profile, spec.session().steps))
    local = whole_trial(spec, args.repeats)
    if args.ray:
        on_ray(spec, args.repeats, local)


if __name__ == '__main__':
    main()
