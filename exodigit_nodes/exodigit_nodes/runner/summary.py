"""The glove's signals as one picture: latest values, run-record samples and the terminal summary.

Plain Python (numpy), no ROS: `exodigit_nodes.runner.monitor` feeds it from the topics. Values are
SI inside; kPa, degrees and the unit labels appear only in the text this module writes.
"""

import math
from collections import deque
from dataclasses import dataclass
from typing import TextIO

import numpy as np
from exodigit_model.stepping.joining import STALL_TOLERANCE, Joined, Joiner

#: Joint labels in topic order (docs/spec/ros.md: always MCP, PIP, DIP).
JOINT_LABELS = ('MCP', 'PIP', 'DIP')


@dataclass(frozen=True)
class Signal:
    """How one SI signal is shown and recorded.

    Attributes
    ----------
    label : str
        Row label in the terminal summary.
    column : str
        Run-record column stem; the columns are ``<column>_<joint>_<unit_tag>``.
    scale : float
        Factor from SI to the display unit.
    unit : str
        Display unit.
    unit_tag : str
        The unit as it appears in column names and one-line summaries.
    decimals : int
        Decimals shown in the summary.
    """

    label: str
    column: str
    scale: float
    unit: str
    unit_tag: str
    decimals: int = 2

    def columns(self) -> list[str]:
        """The three run-record column names of this signal, MCP, PIP, DIP."""
        return [f'{self.column}_{joint.lower()}_{self.unit_tag}' for joint in JOINT_LABELS]


#: Every signal the summary shows and the run record keeps, by topic name.
SIGNALS = {
    'pressure_command': Signal('command', 'p_cmd', 1e-3, 'kPa', 'kpa'),
    'valve_command': Signal('valves', 'u_net', 100.0, '%', 'pct', decimals=0),
    'chamber_pressure': Signal('chamber', 'p', 1e-3, 'kPa', 'kpa'),
    'joint_states': Signal('angle', 'q', 180.0 / math.pi, 'deg', 'deg'),
    'contact_forces': Signal('force sim', 'f', 1.0, 'N', 'n', decimals=3),
    'estimated_contact_forces': Signal('force est', 'f_est', 1.0, 'N', 'n', decimals=3),
    'estimated_finger_stiffness': Signal('K_H est', 'k_est', 1.0, 'N·m/rad', 'nm_per_rad', 4),
    'estimated_rest_angle': Signal('rest est', 'qr_est', 180.0 / math.pi, 'deg', 'deg'),
}
COMMAND_SIGNALS = ('pressure_command', 'valve_command')
"""The command that drove a step (the plant's ``applied_command``): three pressures of a
regulator or six openings of valves (shown net)."""


#: Openings of a ``valve_command`` (with actuation valves): inlets MCP, PIP, DIP, then outlets.
VALVE_OPENINGS = 6
#: The plant topics a `Sample` joins, in the order the plant publishes them in a step.
STEP_ORDER = ('chamber_pressure', 'joint_states', 'contact_forces')
#: The topics of a step of the ``hardware`` bridge (a board has no contact forces).
BOARD_STEP_ORDER = ('chamber_pressure', 'joint_states')
#: The signal stamped with the stamp of the state it estimates: a `Sample` takes its own step's.
ESTIMATE = 'estimated_contact_forces'
#: Most joined steps held back for their estimates or command.
ESTIMATE_WAIT = 500
#: Seconds without a diagnostic after which a node is shown as silent.
HEALTH_TIMEOUT = 3.0
#: diagnostic_msgs/DiagnosticStatus level names, by level.
LEVELS = ('OK', 'WARN', 'ERROR', 'STALE')


def net_openings(openings) -> np.ndarray | None:
    """Per joint, u_in − u_out of a ``valve_command`` (+ fills, − vents); None if malformed."""
    values = np.asarray(openings, dtype=float)
    if values.shape != (VALVE_OPENINGS,):
        return None
    return values[:3] - values[3:]


@dataclass(frozen=True)
class Sample:
    """One plant step as the glove saw it (SI units).

    Attributes
    ----------
    time : float
        Seconds since the first joint state, from the plant's stamps.
    values : dict[str, numpy.ndarray or None]
        Latest value of each signal of `SIGNALS` (shape (3,)), None before its first message.
    """

    time: float
    values: dict


@dataclass(frozen=True)
class Health:
    """Latest diagnostic of one node: worst level (its name) over its statuses, message, when."""

    level: str
    message: str
    received: float


class GloveSignals:
    """Latest value of each glove signal, and the samples the plant's steps make of them.

    A `Sample` joins the messages of one plant step (``streams``: topics without a common stamp)
    by when they were sent (DDS source timestamps), with the rule of
    `exodigit_model.stepping.joining`: it never mixes two steps, and a step that lost a message
    is skipped. A step is joined once the next step's pressure has arrived (or at `flush`). It
    takes the estimate of `ESTIMATE` stamped with its angles' stamp (None if the estimator left
    the step out), the command in force when its pressure was sent (:meth:`_command_at`) and the
    identified spring's latest value. A step waits for its estimate and command at most
    `ESTIMATE_WAIT` steps.

    Parameters
    ----------
    nodes : sequence of str
        Node names whose health is shown.
    references : mapping, optional
        Constant values shown beside an identified signal, per topic of `SIGNALS`: label ->
        values (SI), e.g. ``{'estimated_finger_stiffness': {'nominal': k, 'patient': k_true}}``.
    estimated : bool
        An estimator runs: steps wait for their estimates from the first one on (else once one
        has been heard).
    commanded : bool
        Steps wait for their command (the plant's ``applied_command`` starts with its vent, so
        one comes; docs/spec/ros.md, "The session protocol", guarantee 4).
    streams : sequence of str
        The topics a step joins, in the order they are sent: `STEP_ORDER` for the plant,
        `BOARD_STEP_ORDER` for the hardware bridge.
    """

    def __init__(
        self,
        nodes,
        references=None,
        *,
        estimated: bool = False,
        commanded=False,
        streams=STEP_ORDER,
    ):
        self.references = {
            topic: {label: np.asarray(values, dtype=float) for label, values in rows.items()}
            for topic, rows in (references or {}).items()
        }
        self.latest: dict[str, np.ndarray | None] = dict.fromkeys(SIGNALS)
        self.health: dict[str, Health | None] = dict.fromkeys(nodes)
        self.time: float | None = None
        self.stamp: float | None = None
        """Stamp of the latest joined plant step, s (simulated time with clock sim)."""
        self.received_stamp: float | None = None
        """Stamp of the latest joint_states received (its step may not be joined yet), s."""
        self._first_stamp: float | None = None
        self._streams = tuple(streams)
        self._joiner = Joiner(self._streams, tolerance=STALL_TOLERANCE, confirm=True)
        self._estimates: dict[float, np.ndarray] = {}
        """The estimates received for steps not yet handed on, by stamp."""
        self._newest_estimate: float | None = -math.inf if estimated else None
        """The newest estimate's stamp (None: steps need not wait for theirs)."""
        self._held: deque[tuple[float, float, Sample]] = deque()
        """Joined steps waiting for their estimates or command: (stamp, sent, sample)."""
        self._commanded = commanded
        self._commands: deque[tuple[float, str, np.ndarray]] = deque()
        """Commands received, oldest first, from the one in force at the oldest held step on:
        (sent, signal, values)."""

    def update(
        self, signal: str, values, published: float = 0.0, stamp: float | None = None
    ) -> list[Sample]:
        """Record a new value of ``signal``.

        Parameters
        ----------
        signal : str
            A key of `SIGNALS`.
        values : array_like, shape (3,)
            The message's values, SI.
        published : float
            When the message was sent (DDS source timestamp), s; joins plant steps.
        stamp : float, optional
            Header stamp in seconds (``joint_states``: the sample's time; `ESTIMATE`:
            the stamp of the state it belongs to).

        Returns
        -------
        list of Sample
            The plant steps this message completes (usually none or one).
        """
        if signal not in SIGNALS:
            raise ValueError(f'unknown signal {signal!r}; expected one of {", ".join(SIGNALS)}')
        values = np.array(values, dtype=float)
        self.latest[signal] = values
        if signal == ESTIMATE and stamp is not None:
            self._estimates[stamp] = values
            newest = self._newest_estimate
            self._newest_estimate = stamp if newest is None else max(stamp, newest)
            return self._release()
        if signal in COMMAND_SIGNALS:
            self._commands.append((published, signal, values))
            return self._release()
        if signal not in self._streams:
            return []
        if signal == 'joint_states':
            self.received_stamp = stamp
        value = (values, stamp) if signal == 'joint_states' else values
        return self._samples(self._joiner.add(signal, published, value))

    @property
    def unjoined(self) -> int:
        """Plant messages joined into no step so far: a step that lost one of them is left out."""
        return self._joiner.unpaired

    def flush(self) -> list[Sample]:
        """Join what has arrived when no more plant messages will come (the end of a run)."""
        return self._samples(self._joiner.flush()) + self._release(every=True)

    def _samples(self, steps: list[Joined]) -> list[Sample]:
        """Hold the `Sample` of each joined step (timed by its angles' stamp); :meth:`_release`."""
        for step in steps:
            angles, stamp = step.values['joint_states']
            if self._first_stamp is None:
                self._first_stamp = stamp
            self.stamp = stamp
            self.time = stamp - self._first_stamp
            values = {**self.latest, **step.values, 'joint_states': angles}
            self._held.append((stamp, step.time, Sample(self.time, values)))
        return self._release()

    def _release(self, *, every: bool = False) -> list[Sample]:
        """The held samples, oldest first, whose estimate and command are in or will not come."""
        samples = []
        while self._held:
            stamp, sent, sample = self._held[0]
            known = self._command_at(sent, sample)
            hold = not every and len(self._held) <= ESTIMATE_WAIT
            newest = self._newest_estimate
            waiting = newest is not None and newest < stamp and stamp not in self._estimates
            if hold and (waiting or (self._commanded and not known)):
                break
            self._held.popleft()
            sample.values[ESTIMATE] = self._estimates.pop(stamp, None)
            for older in [s for s in self._estimates if s < stamp]:  # of steps never joined
                del self._estimates[older]
            samples.append(sample)
        return samples

    def _command_at(self, sent: float, sample: Sample) -> bool:
        """Put in ``sample`` the last command sent before ``sent`` (s); whether there is one."""
        while len(self._commands) > 1 and self._commands[1][0] <= sent:
            self._commands.popleft()
        if not self._commands or self._commands[0][0] > sent:
            sample.values.update(dict.fromkeys(COMMAND_SIGNALS))
            return False
        _, signal, values = self._commands[0]
        sample.values[signal] = values
        return True

    def update_health(self, node: str, level: int, message: str, now: float) -> None:
        """Record a diagnostic status of ``node`` received at ``now`` (monotonic seconds)."""
        if node in self.health:
            self.health[node] = Health(LEVELS[min(int(level), len(LEVELS) - 1)], message, now)

    def health_text(self, now: float) -> list[str]:
        """``name LEVEL (message)`` per node; silent nodes say how long they have been."""
        texts = []
        for node, health in self.health.items():
            if health is None:
                texts.append(f'{node} (no diagnostics yet)')
            elif now - health.received > HEALTH_TIMEOUT:
                texts.append(f'{node} SILENT for {now - health.received:.0f} s')
            elif health.level == 'OK':
                texts.append(f'{node} OK')
            else:
                texts.append(f'{node} {health.level} ({health.message})')
        return texts

    def table(self, now: float, title: str) -> str:
        """The multi-line summary for a terminal: one row per signal, one column per joint."""
        rows = [('', ' '.join(f'{joint:>9}' for joint in JOINT_LABELS), '')]
        for topic, signal in SIGNALS.items():
            rows.append((signal.label, _cells(self.latest[topic], signal, 9), signal.unit))
            for label, values in self.references.get(topic, {}).items():
                row = f'{signal.label.split()[0]} {label}'
                rows.append((row, _cells(values, signal, 9), signal.unit))
        width = max(len(label) for label, _, _ in rows)
        clock = '-' if self.time is None else f'{self.time:7.2f} s'
        return '\n'.join(
            [
                f'{title}   t = {clock}',
                *(f'{label:<{width}} {cells}  {unit}'.rstrip() for label, cells, unit in rows),
                'nodes: ' + ', '.join(self.health_text(now)),
            ]
        )

    def line(self, now: float) -> str:
        """The one-line summary for logs: ``t=… command_kPa=[…] angle_deg=[…] … nodes: …``."""
        clock = '-' if self.time is None else f'{self.time:.2f}s'
        parts = [f't={clock}']
        for topic, signal in SIGNALS.items():
            cells = _cells(self.latest[topic], signal, 0)
            parts.append(f'{signal.column}_{signal.unit_tag}=[{cells}]')
        return ' '.join(parts) + ' nodes: ' + '; '.join(self.health_text(now))


def _cells(values, signal: Signal, width: int) -> str:
    if values is None:
        return ' '.join(f'{"-":>{width}}' for _ in JOINT_LABELS)
    return ' '.join(f'{signal.scale * v:{width}.{signal.decimals}f}' for v in values)


class SummaryDisplay:
    """Writes the summary: redrawn in place on a terminal, one line per period otherwise.

    Parameters
    ----------
    stream : TextIO
        Where to write (stdout).
    interactive : bool
        True to redraw a block in place (a TTY); False to append plain lines (CI logs, pipes).
    line_period : float
        Seconds between two lines in the non-interactive form.
    """

    def __init__(self, stream: TextIO, interactive: bool, line_period: float = 1.0):
        self._stream = stream
        self._interactive = interactive
        self._line_period = line_period
        self._drawn_lines = 0
        self._next_line = -math.inf

    def show(self, gloves: list[tuple[GloveSignals, str]], now: float) -> None:
        """Show each (signals, title): a block each, or a line each (titled if several)."""
        if self._interactive:
            text = '\n\n'.join(signals.table(now, title) for signals, title in gloves)
            # Move the cursor up over the previous block and clear to the end of the screen.
            erase = f'\x1b[{self._drawn_lines}F\x1b[J' if self._drawn_lines else ''
            self._stream.write(erase + text + '\n')
            self._drawn_lines = text.count('\n') + 1
        elif now >= self._next_line:
            for signals, title in gloves:
                prefix = f'{title}: ' if len(gloves) > 1 else ''
                self._stream.write(prefix + signals.line(now) + '\n')
            self._next_line = now + self._line_period
        self._stream.flush()

    def message(self, text: str) -> None:
        """Print a line below the summary (it is not redrawn over)."""
        self._stream.write(text + '\n')
        self._stream.flush()
        self._drawn_lines = 0
