"""The ``exodigit`` command: research tools around the glove model.

Subcommands ``curves``, ``draw``, ``calibrate``, ``calibrate-air``, ``air-excitation``,
``plot``, ``trial`` and ``valves`` (see
``exodigit --help``). Units at this interface are kPa, mm and degrees (labelled in every file and
figure); everything inside is SI. Bad input ends with one line on stderr and a non-zero exit
status, never a traceback.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

import numpy as np

from ..extras import ToolError, progress
from ..physics.model import GloveModel
from ..physics.params import PATIENT_PRESETS, ParameterError, load_params, patient_file
from . import trial_command
from .calibration import FIT_MODES

EXIT_USAGE = 2
"""Exit status for bad input (as argparse uses for a bad command line)."""

EXAMPLES = {
    'curves': 'exodigit curves --out curves --pressures 0:50:10',
    'draw': 'exodigit draw --pressure 50 --out glove.png',
    'calibrate': 'exodigit calibrate docs/example_bench.csv --fit both --out my_glove.yaml',
    'calibrate-air': 'exodigit calibrate-air recording.csv --params my_glove.yaml --out air.yaml',
    'air-excitation': 'exodigit air-excitation --out excitation.csv',
    'plot': 'exodigit plot runs/stairs/bag --out runs/stairs',
    'trial': trial_command.EXAMPLE,
    'valves': 'exodigit valves --out docs/valves.png',
}

SUMMARIES = {
    'curves': "simulate the paper's bench experiments: CSV files and PNG plots",
    'draw': 'draw the finger and the exo-digit at one pressure',
    'calibrate': 'fit the material, finger stiffness and/or layer stiffness to measurements',
    'calibrate-air': "fit each chamber's valves, dead volume and leak to a valve recording",
    'air-excitation': 'the sequence of valve openings that identifies the air (CSV)',
    'plot': 'plot a recorded session (rosbag2 bag)',
    'trial': 'run a controller against a population of virtual patients',
    'valves': 'one glove behind regulators and behind valves, for the same pressure targets',
}

DESCRIPTIONS = {
    'curves': "Simulate the paper's bench experiments (free bending of each module, bending on "
    'the finger, contact forces, segment lengths, tip markers) and write CSV files and PNG '
    'plots.',
    'draw': 'Draw the finger and the exo-digit at one pressure, to scale, with contact forces '
    'and joint angles.',
    'calibrate': 'Fit the Yeoh coefficients, the finger stiffness and/or the axial stiffness of '
    "the segments' bottom layers (E_L, docs/spec/model.md §12) to measured samples and write a "
    'parameter file, with standard errors and a measured-against-model plot.',
    'calibrate-air': 'Fit, per chamber, the sonic conductance C and critical ratio b of the '
    'inlet and the outlet valve, the dead volume and the leak (docs/spec/model.md §14) to a '
    'recording of the glove behind valves (an air-recording CSV or a rosbag2 bag: the openings '
    'applied and the chamber pressures measured, from rest), with the valve stepper as the '
    'model; print each value with its 95 % interval and what the recording cannot identify, '
    'and write a parameter file whose pneumatics section is the fit, with a figure of measured '
    'against fitted pressures (docs/calibrate_air.md).',
    'air-excitation': 'Write the identifying sequence of valve openings (about a minute: fills, '
    'holds, vents, partial openings and pulses, each chamber and then all) as a CSV to play on '
    'a glove at its step rate; with --simulate, the recording the simulated glove of --params '
    'makes of it, sensor noise included (docs/calibrate_air.md).',
    'plot': 'Plot angles, pressures and forces against time from a bag recorded by '
    'exodigit_nodes.nodes.recorder (or ros2 bag record).',
    'trial': trial_command.DESCRIPTION,
    'valves': 'Drive one glove behind pressure regulators and one behind valves (the valve loop '
    "of pressure_command's output:=valves) with the staircase mode's pressure targets; plot "
    'pressures, angles and openings side by side and print settling, overshoot, valve '
    'switches and supply air (docs/valves.md).',
}


def _supply_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """``--supply KPA``: the supply's gauge pressure where ``--params`` leaves it null."""
    parser.add_argument(
        '--supply',
        type=float,
        default=100.0,
        metavar='KPA',
        help=f'{what} where --params leaves it null (pneumatics.supply_pressure), kPa (100)',
    )


def _params_argument(parser: argparse.ArgumentParser, *, patient: bool = True) -> None:
    parser.add_argument(
        '--params',
        metavar='FILE',
        help='model parameter YAML (docs/spec/model.md §10); built-in defaults when omitted',
    )
    if patient:
        parser.add_argument(
            '--patient',
            metavar='NAME|FILE',
            help=f'the finger (docs/spec/model.md §11): a preset ({", ".join(PATIENT_PRESETS)}) '
            'or a patient YAML merged over --params; the nominal finger when omitted',
        )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``exodigit`` and its subcommands."""
    examples = '\n'.join(f'  {line}' for line in EXAMPLES.values())
    parser = argparse.ArgumentParser(
        prog='exodigit',
        description='Research tools for the exodigit glove model (units: kPa, mm, degrees).',
        epilog=f'examples:\n{examples}\n\nexodigit SUBCOMMAND --help for details.',
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    commands = parser.add_subparsers(dest='command', metavar='SUBCOMMAND', required=True)

    def command(name: str, epilog: str | None = None) -> argparse.ArgumentParser:
        return commands.add_parser(
            name,
            help=SUMMARIES[name],
            description=textwrap.fill(DESCRIPTIONS[name], 79),
            epilog=epilog or f'example:\n  {EXAMPLES[name]}',
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )

    curves = command('curves')
    _params_argument(curves)
    curves.add_argument('--out', metavar='DIR', default='curves', help='output folder (curves)')
    curves.add_argument(
        '--pressures',
        metavar='START:STOP:STEP',
        default='0:50:10',
        help="pressure sweep in kPa, STOP included (0:50:10, the paper's 10 kPa steps)",
    )

    draw = command('draw')
    _params_argument(draw)
    draw.add_argument(
        '--pressure',
        metavar='KPA[,KPA,KPA]',
        required=True,
        help='chamber pressure in kPa: one value for all three chambers, or MCP,PIP,DIP',
    )
    draw.add_argument('--out', metavar='FILE', default='glove.png', help='PNG file (glove.png)')

    calibrate = command('calibrate')
    calibrate.add_argument(
        'data',
        metavar='DATA.csv',
        help='samples: p_mcp_kpa,p_pip_kpa,p_dip_kpa,q_mcp_deg,q_pip_deg,q_dip_deg '
        '[,f_mcp_n,f_pip_n,f_dip_n] [,l_mcp_mm,l_pip_mm,l_dip_mm] [,condition (free|finger)]; '
        'empty cells are not measured',
    )
    _params_argument(calibrate, patient=False)
    calibrate.add_argument(
        '--fit',
        choices=tuple(FIT_MODES),
        default='both',
        metavar='WHAT',
        help='what to fit (docs/tools.md): Yeoh c1,c2,c3 (material), one factor on them (scale), '
        'finger k_H (stiffness), material and stiffness (both, the default), E_L of the '
        'segments with length data (layer), or E_L with the material (layer+material, '
        'layer+scale)',
    )
    calibrate.add_argument(
        '--out',
        metavar='FILE.yaml',
        default='calibrated.yaml',
        help='fitted parameter file (calibrated.yaml); the plot goes next to it (*_fit.png)',
    )

    air = command('calibrate-air')
    air.add_argument(
        'data',
        metavar='RECORDING',
        help='an air-recording CSV (time_s, u_in_mcp..u_out_dip, p_mcp_kpa..p_dip_kpa '
        '[, q_mcp_deg..q_dip_deg]; one row per step) or a rosbag2 bag folder of a plant with '
        'actuation:=valves (chamber_pressure, applied_command or valve_command, joint_states)',
    )
    _params_argument(air, patient=False)
    air.add_argument(
        '--rate',
        type=float,
        metavar='HZ',
        help="a bag's plant step rate, Hz (100, the plant's default); a CSV has its own",
    )
    _supply_argument(air, "the supply's gauge pressure")
    air.add_argument(
        '--out',
        metavar='FILE.yaml',
        default='air.yaml',
        help='fitted parameter file (air.yaml); the figure goes next to it (*_fit.png)',
    )

    excite = command('air-excitation')
    _params_argument(excite, patient=False)
    excite.add_argument('--out', metavar='FILE.csv', default='excitation.csv', help='CSV file')
    excite.add_argument('--rate', type=float, default=100.0, metavar='HZ', help='step rate (100)')
    excite.add_argument(
        '--simulate',
        action='store_true',
        help='write the recording the simulated glove of --params makes (an air recording)',
    )
    _supply_argument(excite, 'with --simulate, the supply')
    excite.add_argument(
        '--pressure-noise',
        type=float,
        default=0.3,
        metavar='KPA',
        help='with --simulate, the pressure sensor noise (standard deviation), kPa (0.3)',
    )
    excite.add_argument(
        '--angle-noise',
        type=float,
        default=0.5,
        metavar='DEG',
        help='with --simulate, the angle sensor noise (standard deviation), degrees (0.5)',
    )
    excite.add_argument('--seed', type=int, default=0, help='with --simulate, the noise seed')

    plot = command('plot')
    plot.add_argument('bag', metavar='BAG', help='rosbag2 folder (MCAP) from the recorder')
    plot.add_argument('--out', metavar='DIR', default='.', help='output folder (.)')

    trial_command.add_arguments(command('trial', trial_command.EPILOG))

    valves = command('valves')
    _params_argument(valves)
    valves.add_argument('--out', metavar='FILE', default='valves.png', help='PNG (valves.png)')
    valves.add_argument(
        '--duration', type=float, default=20.0, help='seconds of the staircase (20: one cycle)'
    )
    return parser


def _model(args: argparse.Namespace) -> GloveModel:
    files = [] if args.params is None else [args.params]
    patient = getattr(args, 'patient', None)
    if patient in PATIENT_PRESETS:
        files.append(patient_file(patient))
    elif patient is not None:
        if not Path(patient).is_file():
            raise ToolError(
                f'--patient {patient}: neither a preset ({", ".join(PATIENT_PRESETS)}) nor a file'
            )
        files.append(patient)
    return GloveModel(load_params(files))


def _out_dir(path: str) -> Path:
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise ToolError(f'--out {path}: exists and is not a folder')
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def parse_pressure(text: str) -> np.ndarray:
    """Chamber pressures, Pa, from ``KPA`` (all chambers) or ``KPA,KPA,KPA``."""
    try:
        values = [float(v) for v in text.split(',')]
    except ValueError:
        raise ToolError(f'--pressure {text!r}: expected KPA or KPA,KPA,KPA (numbers)') from None
    if len(values) == 1:
        values *= 3
    if len(values) != 3:
        raise ToolError(f'--pressure {text!r}: give one value or three (MCP,PIP,DIP), kPa')
    if not all(np.isfinite(values)) or min(values) < 0:
        raise ToolError(f'--pressure {text!r}: pressures must be finite and >= 0 kPa')
    return np.array(values) * 1e3


def run_curves(args: argparse.Namespace) -> None:
    """``exodigit curves``."""
    from . import curves, figures

    pressure = curves.parse_pressures(args.pressures)
    model = _model(args)
    folder = _out_dir(args.out)
    steps = progress(total=6, desc='curves', unit='step')
    sweeps = curves.simulate(model, pressure)
    steps.update()
    markers = {
        (sweep.experiment, sweep.condition): curves.sweep_markers(model, sweep)
        for sweep in sweeps
        if sweep.experiment != 'all'
    }
    curves.write_angles_csv(sweeps, folder / 'angles.csv')
    curves.write_lengths_csv(sweeps, folder / 'lengths.csv')
    curves.write_markers_csv(markers, pressure, folder / 'markers.csv')
    steps.update()
    figures.angle_figure(sweeps, folder / 'angles.png')
    steps.update()
    figures.force_figure(sweeps, folder / 'forces.png')
    steps.update()
    figures.length_figure(sweeps, model.constants.arc_lengths, folder / 'lengths.png')
    steps.update()
    figures.marker_figure(markers, pressure, folder / 'markers.png')
    steps.update()
    steps.close()
    for line in curves.summary(sweeps):
        print(line, file=sys.stderr)
    print(
        f'wrote {folder}/angles.csv, lengths.csv, markers.csv, angles.png, forces.png, '
        f'lengths.png, markers.png ({pressure.size} pressures, '
        f'{pressure[0] / 1e3:g}-{pressure[-1] / 1e3:g} kPa)'
    )


def run_draw(args: argparse.Namespace) -> None:
    """``exodigit draw``."""
    from .drawing import draw

    pressure = parse_pressure(args.pressure)
    out = Path(args.out)
    if out.suffix.lower() != '.png':
        raise ToolError(f'--out {args.out}: the picture is a PNG, name it *.png')
    if not out.parent.is_dir():
        raise ToolError(f'--out {args.out}: folder {out.parent} does not exist')
    drawing = draw(_model(args), pressure, out)
    for problem in drawing.solution.warnings():
        print(
            f'warning: {problem} (residual {drawing.solution.residual:.3g} N·m): this state '
            'is outside what the model describes',
            file=sys.stderr,
        )
    print(f'wrote {out}: {drawing.caption}')


def run_calibrate(args: argparse.Namespace) -> None:
    """``exodigit calibrate``."""
    from .calibration import calibrate_command

    calibrate_command(args.data, args.params, args.fit, Path(args.out))


def run_calibrate_air(args: argparse.Namespace) -> None:
    """``exodigit calibrate-air``."""
    from .air_calibration import calibrate_air_command

    calibrate_air_command(args.data, args.params, Path(args.out), args.rate, args.supply * 1e3)


def run_air_excitation(args: argparse.Namespace) -> None:
    """``exodigit air-excitation``."""
    from .air_recording import excitation_command

    excitation_command(
        Path(args.out),
        args.rate,
        params_path=args.params,
        simulate=args.simulate,
        supply=args.supply * 1e3,
        pressure_noise=args.pressure_noise * 1e3,
        angle_noise=np.radians(args.angle_noise),
        seed=args.seed,
    )


def run_plot(args: argparse.Namespace) -> None:
    """``exodigit plot``."""
    from .bag import plot_command

    plot_command(Path(args.bag), _out_dir(args.out))


def run_valves(args: argparse.Namespace) -> None:
    """``exodigit valves``."""
    from ..stepping.settings import SimulationSettings
    from . import valves

    settings = SimulationSettings()
    steps = round(args.duration * settings.rate_hz)
    if steps < 2:
        raise ToolError(f'--duration {args.duration!r}: must be at least two steps (0.02 s)')
    model = _model(args)
    comparison = valves.compare(model, valves.staircase_targets(steps, settings), settings)
    valves.figure(comparison, Path(args.out))
    for line in valves.summary(comparison):
        print(line)
    print(f'wrote {args.out}')


COMMANDS = {
    'curves': run_curves,
    'draw': run_draw,
    'calibrate': run_calibrate,
    'calibrate-air': run_calibrate_air,
    'air-excitation': run_air_excitation,
    'plot': run_plot,
    'trial': trial_command.run,
    'valves': run_valves,
}


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``exodigit`` console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        status = COMMANDS[args.command](args)
    except (ToolError, ParameterError) as error:
        reason = ' '.join(str(error).split())  # one line, whatever the message's source
        print(f'exodigit {args.command}: error: {reason}', file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        reason = error.strerror or str(error)
        print(f'exodigit {args.command}: error: {reason}: {error.filename}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f'exodigit {args.command}: interrupted', file=sys.stderr)
        return 130
    return status or 0


if __name__ == '__main__':
    sys.exit(main())
