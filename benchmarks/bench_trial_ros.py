"""Speed of a virtual patient trial of a ROS node controller through the testing kit.

Issue 17's figure: a ROS-node controller trial of 20 patients × 10 s (100 Hz, 1,000 steps each)
through the kit, wall time printed. The controller is the built-in ``pressure_command`` node in
``position`` mode with ``lockstep:=true``, started by the kit for every patient
(``KitEngine``, docs/trials.md, "A ROS node as the controller"), on the ``cpm`` protocol. For
``--parallel`` 1 and 2 (gloves at once) it prints the wall time, the glove-steps per wall second,
the mean wall time of one patient's run (start of plant and controller, the session, the stop)
and how much of the session's metrics agree with the in-process ``position`` mode on the same
patients (largest difference of the range of motion, rad).

``.venv/bin/python benchmarks/bench_trial_ros.py`` (about five minutes on the 2-core
development VM) or ``--patients 4 --duration 2`` for a quick look. No asserts: figures only
(a shared VM: other work runs beside it).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from exodigit_model.trials import ControllerSpec, TrialSpec, run_trial
from exodigit_nodes.testing.trial_engine import KitEngine, ros_controller

NODE = [sys.executable, '-m', 'exodigit_nodes.nodes.pressure_command']


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--patients', type=int, default=20)
    parser.add_argument('--duration', type=float, default=10.0, help='s (10)')
    parser.add_argument('--parallel', type=int, nargs='+', default=[1, 2], help='(1 2)')
    return parser.parse_args()


def main() -> None:
    args = arguments()
    common = {
        'patients': args.patients,
        'protocol': 'cpm',
        'protocol_parameters': {'duration': args.duration},
    }
    spec = TrialSpec(controller=ros_controller(NODE, mode='position', lockstep=True), **common)
    reference = run_trial(TrialSpec(controller=ControllerSpec('mode', 'position'), **common))
    steps = args.patients * spec.session().steps
    print(
        f'{args.patients} patients x {args.duration:g} s at {spec.session().rate_hz:g} Hz '
        f'({steps:,} glove-steps), pressure_command position mode through the kit'
    )
    for parallel in args.parallel:
        with KitEngine(parallel) as engine:
            start = time.perf_counter()
            result = run_trial(spec, engine=engine)
            wall = time.perf_counter() - start
        per_patient = np.mean([run.wall_s for run in engine.runs])
        rom = 'rom_rad'
        difference = np.abs(result.metrics.values[rom] - reference.metrics.values[rom]).max()
        print(
            f'parallel {parallel}: {wall:6.1f} s wall, {steps / wall:6.0f} glove-steps/s, '
            f'{per_patient:5.1f} s a patient, ROM vs in process {difference:.1e} rad'
        )


if __name__ == '__main__':
    main()
