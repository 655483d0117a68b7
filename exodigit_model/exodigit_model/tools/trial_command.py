"""``exodigit trial``: a controller against a population of virtual patients (docs/trials.md).

Builds a :class:`~exodigit_model.trials.TrialSpec` from the command line, runs it on the local
or the Ray engine, prints each rule's message and the main percentiles, writes the report
(``--out``) and returns 1 when a rule (``--require``) failed.
"""

from __future__ import annotations

import argparse
import contextlib
import math
from typing import Any

import yaml

from ..control import MODES
from ..extras import ToolError
from ..stepping.settings import ACTUATIONS
from ..trials import (
    POPULATIONS,
    PROTOCOLS,
    ControllerSpec,
    Engine,
    LocalEngine,
    TrialResult,
    TrialSpec,
    run_trial,
)
from ..trials.spec import DEFAULT_SHARD_SIZE

EXAMPLE = (
    'exodigit trial --population stroke_moderate --patients 1000 --protocol grasp '
    "--mode position --require 'peak_force_n <= 5 for 99%' --out trial"
)

EPILOG = f"""examples:
  {EXAMPLE}
  exodigit trial --patients 200 --mode sine --param sine_high=50e3 --set period=8 --duration 30
  exodigit trial --controller my_controllers.py:make --param gain=2 --out my_trial
  exodigit trial --patients 10000 --engine ray --address auto --no-figures --out big
  python -m exodigit_nodes.trial --ros-controller 'ros2 run my_pkg my_node' --patients 20

controllers:
  --mode NAME        a built-in mode of pressure_command behind its safety limiter; --param
                     takes the node's parameter names (SI): staircase_step, sine_high,
                     hold_pressure=[20e3,25e3,15e3], position_kp, force_targets, max_pressure,
                     max_contact_force, ... and estimate_forces=true (the limiter then backs off
                     on the nominal force estimate). The position mode tracks the protocol.
  --controller M:A   a factory M:A (module or file.py) called as A(protocol=..., model=...,
                     **params) returning a BatchController (reset(count, rng), command(t, dt,
                     state) -> (N, 3) Pa).
  --policy M:A       a factory called as A(env=GloveEnv, **params) returning policy(obs) ->
                     actions, run through PolicyController (needs the gym extra).
  a ROS node         python -m exodigit_nodes.trial --ros-controller CMD (these options, one
                     glove per patient through the testing kit of exodigit_nodes)

rules (--require, repeatable): METRIC[.JOINT] OP THRESHOLD for SHARE%, e.g.
  'peak_force_n <= 5 for 99%'   'rom_fraction >= 0.8 for 95%'   'time_over_force_s <= 0 for 100%'

exit status: 0 every rule passed, 1 a rule failed, 2 bad input (one line on stderr)."""

DESCRIPTION = (
    'Run a controller against a population of virtual patients through a session protocol, one '
    'glove per patient in batches on the compiled stepper, and report per patient the range of '
    'motion reached, tracking error, contact forces, time above the force limit, pressures, '
    'limiter interventions and solver warnings (docs/trials.md).'
)


def add_arguments(
    parser: argparse.ArgumentParser, *, in_process: bool = True
) -> dict[str, argparse._ArgumentGroup]:
    """The options of ``exodigit trial``; the groups, by name, for a caller to add to.

    ``in_process=False`` leaves out the in-process controllers (``--mode``, ``--controller``,
    ``--policy``) and engines (``--engine``, ``--address``, ``--shard-size``): what
    ``python -m exodigit_nodes.trial`` (a ROS node as the controller) takes.
    """
    who = parser.add_argument_group('patients and session')
    who.add_argument(
        '--population',
        metavar='NAME|FILE',
        default='stroke_moderate',
        help=f'a shipped population ({", ".join(POPULATIONS)}) or a population YAML '
        '(docs/populations.md); stroke_moderate',
    )
    who.add_argument('--patients', type=int, default=100, metavar='N', help='patients (100)')
    who.add_argument('--seed', type=int, default=0, help='seed of patients and noise (0)')
    who.add_argument(
        '--protocol', choices=tuple(PROTOCOLS), default='cpm', help='session protocol (cpm)'
    )
    who.add_argument(
        '--set',
        action='append',
        default=[],
        metavar='KEY=VALUE',
        help='a protocol parameter, SI (e.g. period=8, high=[1.2,1.5,1.1]); repeatable',
    )
    who.add_argument('--duration', type=float, metavar='S', help='session length, s (60)')
    who.add_argument('--rate', type=float, metavar='HZ', help='steps per second, Hz (100)')
    who.add_argument(
        '--params-file', metavar='FILE', help='glove parameter YAML; the defaults when omitted'
    )

    if in_process:
        who.add_argument(
            '--actuation',
            choices=ACTUATIONS,
            default='regulator',
            help='how the chambers are driven: pressure regulators, or valves opened by the '
            "valve loop on the controller's pressures (--param valve_kp=..., docs/trials.md); "
            'regulator',
        )

    control = parser.add_argument_group(
        'controller (one of; default --mode sine)' if in_process else 'controller'
    )
    if in_process:
        which = control.add_mutually_exclusive_group()
        which.add_argument('--mode', choices=tuple(MODES), help='a built-in mode')
        which.add_argument(
            '--controller', metavar='MODULE:ATTR', help="a user's controller factory"
        )
        which.add_argument('--policy', metavar='MODULE:ATTR', help='a Gymnasium policy factory')
    control.add_argument(
        '--param',
        action='append',
        default=[],
        metavar='KEY=VALUE',
        help="a controller parameter (the mode's or the factory's keyword)"
        if in_process
        else 'a ROS parameter of the node (-p KEY:=VALUE; YAML values, e.g. mode=position, '
        'rate_hz=100.0)',
    )

    judge = parser.add_argument_group('judging and output')
    judge.add_argument(
        '--force-limit', type=float, metavar='N', help='force limit of time_over_force_s, N (10)'
    )
    judge.add_argument(
        '--require', action='append', default=[], metavar='RULE', help='a rule; repeatable'
    )
    judge.add_argument(
        '--out', metavar='DIR', help='report folder: new or empty (no report when omitted)'
    )
    judge.add_argument('--no-figures', action='store_true', help='CSV and JSON only')

    run = parser.add_argument_group('running')
    if in_process:
        run.add_argument('--engine', choices=('local', 'ray'), default='local', help='(local)')
        run.add_argument('--address', metavar='ADDR', help='Ray cluster address (ray engine)')
        run.add_argument(
            '--shard-size',
            type=int,
            default=DEFAULT_SHARD_SIZE,
            metavar='N',
            help=f'patients per batch ({DEFAULT_SHARD_SIZE:,})',
        )
    run.add_argument('--no-progress', action='store_true', help='no progress bar')
    return {'patients': who, 'controller': control, 'judging': judge, 'running': run}


def parse_assignments(option: str, items: list[str]) -> dict[str, object]:
    """``KEY=VALUE`` items as a dict, each value read as YAML (numbers, lists, true/false).

    Numbers in any form float() reads (``50e3``, which YAML would leave as text) are numbers.
    """
    values = {}
    for item in items:
        key, sep, text = item.partition('=')
        if not sep or not key.strip():
            raise ToolError(f'{option} {item!r}: expected KEY=VALUE')
        try:
            values[key.strip()] = _numbers(yaml.safe_load(text))
        except yaml.YAMLError:
            raise ToolError(f'{option} {item!r}: cannot read the value {text!r}') from None
    return values


def _numbers(value: object) -> object:
    """``value`` with every text float() reads made a number, in lists too."""
    if isinstance(value, list):
        return [_numbers(item) for item in value]
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def trial_spec(args: argparse.Namespace, controller: ControllerSpec | None = None) -> TrialSpec:
    """The spec the command line describes (with ``controller`` instead of its own, if given)."""
    protocol = parse_assignments('--set', args.set)
    for option, key in (('duration', 'duration'), ('rate', 'rate_hz')):
        if getattr(args, option) is not None:
            protocol[key] = getattr(args, option)
    if controller is None:
        parameters = parse_assignments('--param', args.param)
        if args.controller is not None:
            controller = ControllerSpec('controller', args.controller, parameters)
        elif args.policy is not None:
            controller = ControllerSpec('policy', args.policy, parameters)
        else:
            controller = ControllerSpec('mode', args.mode or 'sine', parameters)
    extra = {} if args.force_limit is None else {'force_limit': args.force_limit}
    return TrialSpec(
        population=args.population,
        patients=args.patients,
        seed=args.seed,
        protocol=args.protocol,
        protocol_parameters=protocol,
        controller=controller,
        params_file=args.params_file,
        shard_size=getattr(args, 'shard_size', DEFAULT_SHARD_SIZE),
        actuation=getattr(args, 'actuation', 'regulator'),
        **extra,
    )


def engine(args: argparse.Namespace) -> Engine:
    """The engine of ``--engine`` (the Ray one imported, and started, only when asked for)."""
    if args.engine == 'local':
        if args.address is not None:
            raise ToolError('--address is for --engine ray')
        return LocalEngine()
    return ray_engine(args.address)


def ray_engine(address: str | None, **options: Any) -> Engine:
    """``RayEngine(address, **options)``, its failures to start as one-line ToolErrors."""
    from ..trials.ray_engine import RayEngine

    try:
        return RayEngine(address=address, **options)
    except ModuleNotFoundError as error:
        if error.name and error.name.split('.')[0] == 'ray':
            raise ToolError(
                'ray is not installed; install the extra with: pip install "./exodigit_model[ray]"'
            ) from None
        raise ToolError(f'the ray engine is not available: {error}') from None
    except RuntimeError as error:  # it would not listen on loopback alone, or cannot connect
        raise ToolError(f'--engine ray: {error}') from None


def run(args: argparse.Namespace) -> int:
    """``exodigit trial``: 0 when every rule passed, 1 when one failed."""
    from ..trials.ray_engine import ShardError

    try:
        spec = trial_spec(args)
        chosen = engine(args)
        try:
            result = run_trial(
                spec,
                rules=args.require,
                engine=chosen,
                progress=False if args.no_progress else None,
            )
        finally:
            if isinstance(chosen, contextlib.AbstractContextManager):
                chosen.__exit__(None, None, None)
    except (ValueError, ShardError) as error:
        raise ToolError(str(error)) from None
    for line in report_lines(result):
        print(line)
    if args.out is not None:
        from .trial_report import write_report

        try:
            written = write_report(result, args.out, figures=not args.no_figures)
        except ValueError as error:
            raise ToolError(f'--out {error}') from None
        print(f'wrote {args.out}/: {", ".join(path.name for path in written)}')
    return result.status


def report_lines(result: TrialResult) -> list[str]:
    """What the command prints: the main percentiles, each rule, the outcome."""
    metrics = result.summary['metrics']
    lines = [f'{result.spec.patients:,} patients, {result.metrics.steps:,} steps each:']
    for column, label, factor, unit in (
        ('peak_force_n', 'peak contact force', 1.0, 'N'),
        ('time_over_force_s', 'time over the force limit', 1.0, 's'),
        ('rom_fraction', "range of motion / target's", 1.0, ''),
        ('overall_tracking_rmse_rad', 'tracking RMSE', math.degrees(1.0), 'deg'),
    ):
        p = metrics[column]['percentiles']
        values = ' '.join(f'{key} {p[key] * factor:.3g}' for key in ('p5', 'p50', 'p95', 'p99'))
        lines.append(f'  {label} ({unit or "1"}): {values}')
    lines += [outcome.message for outcome in result.rules]
    lines.append(result.message)
    return lines
