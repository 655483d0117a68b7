"""``python -m exodigit_nodes.trial``: a virtual patient trial of a ROS node controller.

``exodigit trial`` (exodigit_model, which never imports ROS) with a ROS node as the controller:
the same options (:func:`exodigit_model.tools.trial_command.add_arguments`) except the
in-process controllers and engines, plus ``--ros-controller CMD``, ``--fresh-nodes``,
``--parallel``, ``--timeout`` and ``--node-logs``. The patients run on the testing kit's gloves,
``--parallel`` at once, each glove and its node serving patient after patient
(:class:`~exodigit_nodes.testing.trial_engine.KitEngine`); the printout, the report (``--out``)
and the exit status are the other command's (docs/trials.md, "A ROS node as the controller").
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import sys

from exodigit_model.checks import ParameterError
from exodigit_model.extras import ToolError
from exodigit_model.tools import trial_command
from exodigit_model.trials import ControllerSpec, run_trial
from exodigit_model.trials.ray_engine import ShardError

from .testing.client import DEFAULT_TIMEOUT
from .testing.trial_engine import DEFAULT_PARALLEL, KitEngine, PatientError, kit_shard
from .testing.trial_worker import PatientRun

PROG = 'python -m exodigit_nodes.trial'
ENGINES = ('kit', 'ray')
EXIT_USAGE = 2

EPILOG = f"""examples:
  {PROG} --ros-controller 'ros2 run my_pkg my_node' --patients 20 --protocol grasp \\
      --require 'peak_force_n <= 5 for 99%' --out trial
  {PROG} --ros-controller '{sys.executable} -m exodigit_nodes.nodes.pressure_command' \\
      --param mode=position --param lockstep=true --patients 4 --duration 10

the controller: the kit starts CMD in each glove's domain and namespace, with --ros-args -r
__ns:=<namespace> -p use_sim_time:=true and every --param appended. It must answer each
joint_states with one pressure_command (the lockstep protocol; pressure_command does with
lockstep=true) and may follow the protocol's targets, one point a step, sent as one
joint_trajectory (trajectory_msgs/JointTrajectory, stamped with the session's first state)
before the session starts. A glove and its node serve patient after patient: each patient is a
new session, in which simulated time starts again from zero (/clock and the stamps go back), and
the node must then start over (clear its integrators, filters and the like; keep the latest
trajectory), as pressure_command does. --fresh-nodes starts the node (and its glove) for every
patient instead: a few seconds more a patient. Slower than an in-process trial: about 1 ms a
step.

exit status: 0 every rule passed, 1 a rule failed, 2 bad input or a patient's run failed (one
line on stderr)."""

DESCRIPTION = (
    'Run a ROS node controller against a population of virtual patients through a session '
    'protocol: one simulated glove per patient in lockstep simulated time (the testing kit), '
    'several at once, each in its own ROS domain; the metrics, rules and report of exodigit '
    'trial (docs/trials.md).'
)


def build_parser() -> argparse.ArgumentParser:
    """The command's options: the trial's, and the ROS node's."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    groups = trial_command.add_arguments(parser, in_process=False)
    groups['controller'].add_argument(
        '--ros-controller',
        required=True,
        metavar='CMD',
        help="the command that starts the node, e.g. 'ros2 run my_pkg my_node' (split as a "
        'shell does)',
    )
    groups['controller'].add_argument(
        '--no-targets',
        action='store_true',
        help='the node does not subscribe joint_trajectory (open loop): do not wait for it',
    )
    groups['controller'].add_argument(
        '--fresh-nodes',
        action='store_true',
        help='start the node (and its glove) for every patient, for a node that does not start '
        'over when simulated time goes back (default: each glove and its node serve patient '
        'after patient)',
    )
    groups['running'].add_argument(
        '--parallel',
        type=int,
        default=DEFAULT_PARALLEL,
        metavar='N',
        help=f'gloves at once, each in its own ROS domain ({DEFAULT_PARALLEL})',
    )
    groups['running'].add_argument(
        '--engine',
        choices=ENGINES,
        default=ENGINES[0],
        help='kit: the gloves on this machine; ray: one Ray task per patient, the gloves spread '
        "over a Ray cluster's nodes, --parallel tasks at once (kit)",
    )
    groups['running'].add_argument(
        '--address',
        metavar='ADDR',
        help='Ray cluster address (--engine ray; default: start a local instance on 127.0.0.1)',
    )
    groups['running'].add_argument(
        '--timeout',
        type=float,
        default=DEFAULT_TIMEOUT,
        metavar='S',
        help=f'longest wait for an answer of the glove or the node, wall s ({DEFAULT_TIMEOUT:g})',
    )
    groups['running'].add_argument(
        '--node-logs',
        metavar='DIR',
        help="keep every patient's parameter file in DIR/patient_<i>/, and each glove's node "
        "output in its first patient's (default: discarded)",
    )
    return parser


def run(args: argparse.Namespace) -> int:
    """The trial: 0 when every rule passed, 1 when one failed (ToolError for bad input)."""

    def progress(run: PatientRun) -> None:
        done = len(kit.runs)
        print(f'{run.message} ({done}/{args.patients})', file=sys.stderr, flush=True)

    try:
        parameters = trial_command.parse_assignments('--param', args.param)
        spec = trial_command.trial_spec(
            args, ControllerSpec('ros', args.ros_controller, parameters)
        )
        if args.engine == 'ray':  # a task per patient: the gloves spread over the nodes
            spec = dataclasses.replace(spec, shard_size=1)
        kit = KitEngine(
            args.parallel,
            timeout=args.timeout,
            follows_targets=not args.no_targets,
            fresh_nodes=args.fresh_nodes,
            log_dir=args.node_logs,
            on_patient=None if args.no_progress else progress,
        )
        engine = kit if args.engine == 'kit' else spread(args)
        try:
            result = run_trial(spec, rules=args.require, engine=engine, progress=False)
        finally:
            if engine is not kit:
                engine.close()
    except (ValueError, PatientError, ShardError) as error:
        raise ToolError(str(error)) from None
    for line in trial_command.report_lines(result):
        print(line)
    if args.out is not None:
        from exodigit_model.tools.trial_report import write_report

        worst = kit.records.get(result.worst_patient())
        if worst is None and not args.no_figures:  # a Ray run keeps no records: run it again
            try:
                worst = kit.session(spec, result.worst_patient())
            except PatientError as error:
                raise ToolError(f'the figure of the worst patient: {error}') from None
        try:
            written = write_report(result, args.out, figures=not args.no_figures, record=worst)
        except ValueError as error:
            raise ToolError(f'--out {error}') from None
        print(f'wrote {args.out}/: {", ".join(path.name for path in written)}')
    return result.status


def spread(args: argparse.Namespace):
    """The Ray engine of ``--engine ray``: each task runs a shard's gloves on its node."""
    if args.node_logs is not None:
        raise ToolError('--node-logs is for --engine kit (the gloves run on the Ray nodes)')
    shard = functools.partial(
        kit_shard,
        timeout=args.timeout,
        follows_targets=not args.no_targets,
        fresh_nodes=args.fresh_nodes,
    )
    return trial_command.ray_engine(args.address, workers=args.parallel, shard=shard)


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return run(args)
    except (ToolError, ParameterError) as error:
        print(f'{PROG}: error: {" ".join(str(error).split())}', file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f'{PROG}: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())
