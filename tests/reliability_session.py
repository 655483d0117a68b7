"""A running glove (plant, pressure_command, estimator) in one namespace, watched by the probe.

Used by the fault tests: start or restart any node, kill it with SIGKILL, and wait for the glove
to be *normal*, checked against independent answers: the plant's joint angles are the model's
solve of the chamber pressures it publishes (noise off), the estimator's contact forces agree
with the plant's, the identified finger stiffness is the model's K_H, and every node reports.
"""

from __future__ import annotations

import itertools
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from ros_harness import DISCOVERY_TIMEOUT, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

NODES = ('plant', 'pressure_command', 'estimator')
#: Controller rate and limits, plant supply limit, of sessions (Hz, Pa, Pa/s).
RATE = 100.0
MAX_SUPPLY = 100e3
MAX_PRESSURE = 60e3
MAX_PRESSURE_RATE = 100e3
#: Estimator window (pairs) and identification period (s): one window is WINDOW / RATE s. The
#: estimator fits whatever part of the window it holds (exact on noise-free data), so a
#: (re)started one identifies K_H at its first tick: a short period ends every wait for
#: "normal" within a fifth of a second of data.
WINDOW = 100
IDENTIFICATION_PERIOD = 0.2
#: Time between two /diagnostics reports of every node, s: a wait for "every node reports"
#: takes a fifth of a second, not the default second.
REPORT_PERIOD = 0.2
#: Relative agreement of the identified stiffness with the model's K_H (noise-free data).
STIFFNESS_TOLERANCE = 0.02
#: Agreement of published angles with an independent solve (different warm start), rad.
ANGLE_TOLERANCE = 1e-8
#: Agreement of estimated and simulated contact forces, N (same step, noise free).
FORCE_TOLERANCE = 1e-6
#: A node process needs this long to import, build its model and be discovered, s.
START_TIMEOUT = 20.0 + DISCOVERY_TIMEOUT
#: Rate-limit slack for rounding, Pa.
RATE_SLACK = 1e-6

PARAMETERS = {
    'plant': {
        'pressure_time_constant': 0.02,
        'marker_rate_hz': 0.0,
        'max_supply_pressure': MAX_SUPPLY,
        'diagnostic_period': REPORT_PERIOD,
    },
    'pressure_command': {
        'mode': 'sine',
        'sine_period': 2.0,
        'max_pressure': MAX_PRESSURE,
        'max_pressure_rate': MAX_PRESSURE_RATE,
        'rate_hz': RATE,
        'diagnostic_period': REPORT_PERIOD,
    },
    'estimator': {
        'identification_window': WINDOW,
        'identification_period': IDENTIFICATION_PERIOD,
        'diagnostic_period': REPORT_PERIOD,
    },
}

TOPICS = {
    'joint_states': JointState,
    'chamber_pressure': Float64MultiArray,
    'contact_forces': Float64MultiArray,
    'pressure_command': Float64MultiArray,
    'estimated_contact_forces': JointState,  # stamped with its state
    'estimated_finger_stiffness': Float64MultiArray,
}


def latest_status(diagnostics, name: str, since: float = -1.0):
    """The newest DiagnosticStatus called ``name`` in an Inbox of /diagnostics that arrived
    after ``since`` (a ``time.monotonic()`` value), or None."""
    for arrival, array, _ in reversed(diagnostics.records()):
        if arrival <= since:
            break
        for status in array.status:
            if status.name == name:
                return status
    return None


class GloveSession:
    """The glove's three nodes in ``namespace``; ``overrides`` change their parameters.

    The probe records the glove's topics from the start, or (``listen=False``) from
    :meth:`listen` on, for a test that has no use for what the glove sends before.
    """

    def __init__(
        self, launcher, probe, namespace: str, overrides: dict | None = None, listen: bool = True
    ) -> None:
        self.launcher = launcher
        self.probe = probe
        self.namespace = namespace
        self.parameters = {n: dict(PARAMETERS[n], **(overrides or {}).get(n, {})) for n in NODES}
        self.processes = {}
        self.inbox = {}
        self.diagnostics = None
        self.model = GloveModel(load_params())
        if listen:
            self.listen()

    def listen(self, diagnostics=None) -> None:
        """Record the glove's topics from now on, and /diagnostics in ``diagnostics`` (an Inbox
        several sessions may share; None: one of its own)."""
        self.inbox = {
            topic: self.probe.subscribe(f'{self.namespace}/{topic}', kind, with_info=True)
            for topic, kind in TOPICS.items()
        }
        if diagnostics is None:
            diagnostics = self.probe.subscribe('/diagnostics', DiagnosticArray)
        self.diagnostics = diagnostics

    def publishes(self, node: str, topic: str) -> bool:
        """Whether the probe has discovered ``node``'s publisher of ``topic`` (the graph)."""
        infos = self.probe.node.get_publishers_info_by_topic(f'{self.namespace}/{topic}')
        return any(
            info.node_name == node and info.node_namespace == self.namespace for info in infos
        )

    def start(self, node: str) -> None:
        """Start (or restart) ``node``."""
        self.processes[node] = self.launcher.start(
            node, self.parameters[node], namespace=self.namespace
        )

    def kill(self, node: str) -> int:
        """SIGKILL ``node``; returns its exit status."""
        return self.processes[node].kill()

    def alive(self, node: str) -> bool:
        return self.processes[node].alive()

    def status(self, node: str, since: float = -1.0):
        """The newest diagnostic status of ``node`` that arrived after ``since``, or None."""
        return latest_status(self.diagnostics, f'{self.namespace}/{node}', since)

    def reported(self, node: str, since: float, timeout: float = START_TIMEOUT) -> bool:
        """Wait until ``node`` has published diagnostics after ``since``."""
        return bool(wait_until(lambda: self.status(node, since) is not None, timeout))

    def flowing(self, topic: str, since: float, count: int = 5, timeout=START_TIMEOUT) -> bool:
        """Wait until ``count`` messages on ``topic`` arrived after ``since``."""
        inbox = self.inbox[topic]
        return bool(wait_until(lambda: len(inbox.messages(since)) >= count, timeout))

    def state_matches_model(self, since: float) -> bool:
        """A joint_states message after ``since`` equals the model's solve of a chamber pressure
        message after ``since`` (the two a plant step publishes together)."""
        pressures = self.inbox['chamber_pressure'].messages(since)[-20:]
        solved = [self.model.solve(np.asarray(m.data)).q for m in pressures]
        return any(
            np.allclose(q, state.position, rtol=0, atol=ANGLE_TOLERANCE)
            for state in self.inbox['joint_states'].messages(since)[-20:]
            for q in solved
        )

    def forces_agree(self, since: float) -> bool:
        """An estimated contact force after ``since`` equals a simulated one (same step)."""
        simulated = [np.asarray(m.data) for m in self.inbox['contact_forces'].messages(since)]
        for estimate in self.inbox['estimated_contact_forces'].messages(since)[-20:]:
            if any(np.allclose(estimate.effort, f, atol=FORCE_TOLERANCE) for f in simulated[-40:]):
                return True
        return False

    def stiffness_identified(self, since: float) -> bool:
        """An identified stiffness after ``since`` within tolerance of the model's K_H."""
        true = np.array([joint.stiffness for joint in self.model.params.finger.joints])
        return any(
            np.allclose(m.data, true, rtol=STIFFNESS_TOLERANCE, atol=0)
            for m in self.inbox['estimated_finger_stiffness'].messages(since)
        )

    def normal(self, since: float, timeout: float = START_TIMEOUT) -> list[str]:
        """Wait for the glove to work normally after ``since``; what is not normal (empty: ok).

        Normal: commands flow and reach the chambers (> 10 kPa), the plant's state is the model's
        solve of its pressures, the estimator's forces equal the plant's, the stiffness is
        identified, and each node reports.
        """
        checks = {
            'commands': lambda: self.flowing('pressure_command', since, timeout=0),
            'pressure above 10 kPa': lambda: any(
                max(m.data) > 10e3 for m in self.inbox['chamber_pressure'].messages(since)
            ),
            'state = model solve': lambda: self.state_matches_model(since),
            'estimated = simulated forces': lambda: self.forces_agree(since),
            'stiffness identified': lambda: self.stiffness_identified(since),
            **{f'{n} reports': (lambda n=n: self.status(n, since) is not None) for n in NODES},
        }
        deadline = time.monotonic() + timeout
        pending = dict(checks)
        while pending and time.monotonic() < deadline:
            pending = {name: check for name, check in pending.items() if not check()}
            time.sleep(0.05)
        return sorted(pending)

    def unsafe_commands(self, since: float, exclude=()) -> list[str]:
        """Commands after ``since`` outside [0, max_pressure] or changing faster than allowed.

        ``exclude`` lists (start, end) windows of source timestamps (ns, system clock) of
        messages that are not the controller's (a test published them). Only meaningful while
        one controller process runs (a restarted one starts from zero).
        """
        commands = [
            np.asarray(message.data)
            for arrival, message, info in self.inbox['pressure_command'].records()
            if arrival > since
            and not any(start <= info['source_timestamp'] <= end for start, end in exclude)
        ]
        step = MAX_PRESSURE_RATE / RATE + RATE_SLACK
        bad = [
            f'{c.tolist()} out of range'
            for c in commands
            if not 0 <= c.min() <= c.max() <= MAX_PRESSURE
        ]
        bad += [
            f'{a.tolist()} -> {b.tolist()} too fast'
            for a, b in itertools.pairwise(commands)
            if np.abs(b - a).max() > step
        ]
        return bad
