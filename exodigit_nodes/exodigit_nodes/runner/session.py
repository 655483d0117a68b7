"""One runner loop for a glove or a hand: node processes, live summary, run records, clean stop.

:mod:`.hand_runner` builds the :class:`Session` of a glove or a hand, :func:`run_session` runs
it: a :class:`.monitor.GloveMonitor` per glove feeds its summary and run record.
"""

from __future__ import annotations

import functools
import sys
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from ..logic.backlog import take_backlog
from ..logic.lifetime import StopRequest
from ..nodes.dds import use_profile
from .run_record import RunRecord
from .summary import STEP_ORDER, GloveSignals, SummaryDisplay
from .supervisor import Supervisor

#: Seconds between two refreshes of the terminal summary.
REFRESH_PERIOD = 0.25
#: Lines of a dead process's log shown when it exits unexpectedly.
LOG_TAIL_LINES = 8


@dataclass(frozen=True)
class WatchedGlove:
    """One glove of a session: what the summary shows and where its record goes.

    Attributes
    ----------
    title : str
        Its heading in the summary.
    namespace : str
        Its ROS namespace (absolute).
    record : RunRecord
    references : dict
        Constant values beside its identified signals (`GloveSignals`).
    """

    title: str
    namespace: str
    record: RunRecord
    references: dict


@dataclass(frozen=True)
class Session:
    """What a runner starts and watches.

    Attributes
    ----------
    program : str
        The runner's name, in its messages.
    processes : tuple of (str, list of str)
        Name and command line of each process, in start order.
    stop_order : tuple of str
        Process names in stop order (the rest after them).
    runs : dict of str to tuple of str
        Per process, the glove nodes it runs (their /diagnostics say it has started).
    nodes : tuple of str
        The node names each glove's summary shows the health of.
    gloves : tuple of WatchedGlove
    pause_service : str
        ``set_paused`` of the simulated time, absolute.
    simulated : bool
        Simulated time: the plants start paused and are held at ``duration`` (``run_until``).
    duration : float
        Seconds to run (simulated with ``simulated``); 0 until stopped.
    log_dir : Path
        Where the processes' logs go.
    listeners : tuple of str
        Nodes (fully qualified) whose ``~/ready`` must say true before the plants resume: the
        recorder and the estimators (docs/spec/ros.md, "The session protocol", guarantee 2).
    streams : tuple of str
        The topics a glove's step joins in the summary and the record (`.summary.STEP_ORDER`;
        a board's: `.summary.BOARD_STEP_ORDER`).
    """

    program: str
    processes: tuple[tuple[str, list[str]], ...]
    stop_order: tuple[str, ...]
    runs: dict[str, tuple[str, ...]]
    nodes: tuple[str, ...]
    gloves: tuple[WatchedGlove, ...]
    pause_service: str
    simulated: bool
    duration: float
    log_dir: Path
    listeners: tuple[str, ...] = ()
    streams: tuple[str, ...] = STEP_ORDER


def identification_references(nominal_files: list[str], plant_files: list[str] | None) -> dict:
    """Nominal and simulated patient's stiffness and rest angle, to show beside the estimate.

    ``plant_files`` None: no simulated patient (a real board's), the nominal finger alone.
    """
    from exodigit_model import load_params

    files = {'nominal': nominal_files, 'patient': plant_files}
    joints = {
        label: load_params(paths).finger.joints
        for label, paths in files.items()
        if paths is not None
    }
    fields = {'estimated_finger_stiffness': 'stiffness', 'estimated_rest_angle': 'rest_angle'}
    return {
        topic: {label: [getattr(j, field) for j in rows] for label, rows in joints.items()}
        for topic, field in fields.items()
    }


def run_session(session: Session, env: dict) -> int:
    """Start, watch, stop and report one session; the exit code (0 clean, 1 a process failed)."""
    stop = StopRequest()  # from here on, Ctrl-C means a clean stop
    import rclpy
    from rclpy.experimental import EventsExecutor
    from rclpy.signals import SignalHandlerOptions

    from ..nodes.catalog import ESTIMATOR_NODE
    from .monitor import GloveMonitor

    stop.install()  # again: loading rclpy's C extension takes the signals over
    supervisor = Supervisor(env, log_dir=session.log_dir)
    display = SummaryDisplay(sys.stdout, sys.stdout.isatty() and env.get('TERM') != 'dumb')
    estimated = ESTIMATOR_NODE.executable in session.nodes
    signals = [
        GloveSignals(
            session.nodes,
            glove.references,
            estimated=estimated,
            commanded=True,
            streams=session.streams,
        )
        for glove in session.gloves
    ]
    titled = [(s, glove.title) for s, glove in zip(signals, session.gloves, strict=True)]
    executor = None
    monitors = []
    failures, stops = [], []
    try:
        for name, command in session.processes:
            supervisor.start(name, command, defer_sigint=True)  # exodigit nodes, recorder
        use_profile()
        rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
        executor = EventsExecutor()
        for glove, glove_signals in zip(session.gloves, signals, strict=True):
            monitors.append(GloveMonitor(glove_signals, glove.namespace, glove.record.write))
            executor.add_node(monitors[-1])
        spin = functools.partial(executor.spin_once, timeout_sec=0.02)
        failures = _watch(session, stop, supervisor, monitors, signals, spin, display, titled)
        display.show(titled, time.monotonic())
        unit = 'simulated s' if session.simulated else 's'
        reason = stop.signal_name or (
            'a process exited' if failures else f'{session.duration:g} {unit} elapsed'
        )
        display.message(f'stopping ({reason}): {", ".join(supervisor.running())}')
        stops = supervisor.stop(session.stop_order, idle=spin)
        take_backlog(spin, lambda: sum(monitor.taken for monitor in monitors))
        for glove, glove_signals in zip(session.gloves, signals, strict=True):
            for sample in glove_signals.flush():  # the nodes are gone: the last step is complete
                glove.record.write(sample)
    finally:
        supervisor.stop(session.stop_order)  # after an error above: no process is left behind
        if executor is not None:
            executor.shutdown()
        for monitor in monitors:
            monitor.destroy_node()
        rclpy.try_shutdown()
        for glove in session.gloves:
            glove.record.close()
    return _report(session, supervisor, signals, failures, stops)


def _watch(session: Session, stop, supervisor, monitors, signals, spin, display, titled) -> list:
    """Show the gloves until a stop request, a process that exited (returned) or the duration.

    In simulated time, hold the plants meanwhile to docs/spec/ros.md, "The session protocol",
    guarantees 3 and 6 (:class:`.horizon.Horizon`), never past the duration.
    """
    from std_srvs.srv import SetBool

    from ..nodes.catalog import PLANT_NODE
    from ..nodes.handshake import Handshake, ReadyWatch, glove_nodes
    from .horizon import Horizon

    if session.simulated:
        node = monitors[0]  # after every monitor's readers (the handshake's rule)
        namespaces = [glove.namespace for glove in session.gloves]
        handshake = Handshake(node, glove_nodes(namespaces, session.nodes))
        listeners = ReadyWatch(node, session.listeners)
        pause = node.create_client(SetBool, session.pause_service)
        horizon = Horizon(node, f'{namespaces[0].rstrip("/")}/{PLANT_NODE.executable}')
        horizon.start(session.duration)
    started = time.monotonic()
    next_refresh = started
    paused = session.simulated
    failures = []
    while not stop.requested:
        spin()
        now = time.monotonic()
        if paused:
            present = listeners.ready() and not handshake.silent()
            if present and horizon.ready() and pause.service_is_ready():
                pause.call_async(SetBool.Request(data=False))
                paused = False
        elif session.simulated:
            horizon.follow(_earliest(s.stamp for s in signals))
        failures = supervisor.exited()
        if session.simulated:
            elapsed = _earliest(s.received_stamp for s in signals) or 0.0
        else:
            elapsed = now - started
        if failures or (session.duration and elapsed >= session.duration):
            break
        if now >= next_refresh:
            display.show(titled, now)
            for glove in session.gloves:
                glove.record.flush()
            next_refresh = now + REFRESH_PERIOD
    return failures


def _earliest(stamps: Iterable[float | None]) -> float | None:
    """The earliest of the gloves' stamps, s; None until each has one."""
    stamps = list(stamps)
    return None if None in stamps else min(stamps)


def _report(session: Session, supervisor: Supervisor, signals, failures, stops) -> int:
    """Print failures (with their logs' tails), records and plots; the exit code."""
    failed_names = {exit_.name for exit_ in failures}
    unclean = [s for s in stops if not s.clean and s.name not in failed_names]

    def reported(name: str) -> bool:
        return any(s.health[node] is not None for s in signals for node in session.runs[name])

    # A process stopped by SIGINT before any of its nodes reported was still importing: Ctrl-C
    # that early can end it with any code, and that is no failure of the session.
    starting = [
        s for s in unclean if not s.forced and session.runs.get(s.name) and not reported(s.name)
    ]
    for exit_ in starting:
        print(f'{session.program}: {exit_.name} was stopped while starting ({exit_.describe()})')
    bad = failures + [s for s in unclean if s not in starting]
    for exit_ in bad:
        print(f'{session.program}: {exit_.describe()}', file=sys.stderr)
        log = supervisor.children[exit_.name].log_path
        lines = log.read_text(errors='replace').splitlines() if log and log.is_file() else []
        for line in lines[-LOG_TAIL_LINES:]:
            print(f'  {exit_.name}| {line}', file=sys.stderr)
    for glove, glove_signals in zip(session.gloves, signals, strict=True):
        plot = glove.record.plot(glove.references)
        print(f'run record: {glove.record.csv_path} ({glove.record.rows} samples)')
        if session.simulated and glove_signals.unjoined:  # every step is whole in simulated time
            print(f'  {glove_signals.unjoined} plant messages joined no step: steps are missing')
        print(f'plot: {plot}' if plot else 'plot: none (no sample was received)')
    print(f'node logs: {session.log_dir}/')
    return 1 if bad else 0
