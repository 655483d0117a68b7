"""Speed of a virtual patient trial of a ROS node controller through the testing kit.

Issue 17's figure, issues 24's and 37's targets (37: at most 30 s one glove at a time, 20 s two
at once): a ROS-node controller trial of 20 patients × 10 s (100 Hz, 1,000 steps each) through
the kit, wall time printed. Each patient's targets go to the node as one ``joint_trajectory``
before its session, which then runs in lockstep as ``GloveSim.run``. The controller is the built-in
``pressure_command`` node in ``position`` mode with ``lockstep:=true`` on the ``cpm`` protocol
(``KitEngine``, docs/trials.md, "A ROS node as the controller"). Each glove and its node serve
patient after patient, a new session of the plant each (``reset_simulation``), on which the node
starts over; ``--fresh-nodes`` starts both for every patient instead (before issue 24, the only
way). For ``--parallel`` 1 and 2 (gloves at once) it prints the wall time, the glove-steps per
wall second, the mean wall time of one patient's run, and how much of the session's metrics agree
with the in-process ``position`` mode on the same patients (largest difference of the range of
motion, rad). Then it runs the last ``--compare`` patients again, each on a glove and node of its
own, and prints whether their sessions on the kept gloves were the same (every series bit for
bit).

``.venv/bin/python benchmarks/bench_trial_ros.py`` (about two minutes on the 2-core development
VM) or ``--patients 4 --duration 2`` for a quick look. No asserts: figures only (a shared VM:
other work runs beside it).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from exodigit_model.trials import ControllerSpec, TrialSpec, run_trial
from exodigit_nodes.testing.trial_engine import KitEngine, ros_controller

NODE = [sys.executable, '-m', 'exodigit_nodes.nodes.pressure_command']
SERIES = ('q', 'target', 'pressure', 'forces', 'command')
"""What a patient's session is made of: the metrics' series and the node's commands."""


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--patients', type=int, default=20)
    parser.add_argument('--duration', type=float, default=10.0, help='s (10)')
    parser.add_argument('--parallel', type=int, nargs='+', default=[1, 2], help='(1 2)')
    parser.add_argument(
        '--fresh-nodes', action='store_true', help='a glove and node started for every patient'
    )
    parser.add_argument(
        '--compare', type=int, default=2, help='last patients run again on gloves of their own (2)'
    )
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
    gloves = 'a glove and node per patient' if args.fresh_nodes else 'gloves kept for the next'
    print(
        f'{args.patients} patients x {args.duration:g} s at {spec.session().rate_hz:g} Hz '
        f'({steps:,} glove-steps), pressure_command position mode through the kit, {gloves}'
    )
    for parallel in args.parallel:
        with KitEngine(parallel, fresh_nodes=args.fresh_nodes) as engine:
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
    patients = range(max(args.patients - args.compare, 0), args.patients)
    if not patients:
        return
    differing = []
    for patient in patients:
        alone, kept = KitEngine().session(spec, patient), engine.records[patient]
        for series in SERIES:
            ours, theirs = getattr(kept, series), getattr(alone, series)
            if not np.array_equal(ours, theirs):
                differing.append(f'patient {patient} {series} {np.abs(ours - theirs).max():.1e}')
    print(
        f'patients {patients.start}-{patients.stop - 1} again on gloves and nodes of their own: '
        + ('the same sessions, bit for bit' if not differing else '; '.join(differing))
    )


if __name__ == '__main__':
    main()
