"""Hostile input messages for the glove's subscriptions, and what a node may publish in reply.

`hostile_vectors`, `hostile_joint_states` and `hostile_trajectories` cycle through the cases of
issue 4 (wrong lengths 0,
1, 2, 4, 1000; NaN, ±Inf, ±1e308, subnormals, negative and huge values; empty, duplicated and
reordered joint names; position/velocity/effort of different lengths; stamps of zero, in the
future, far in the past and before 1970), mixed with a few well-formed messages so that the valid
path is exercised between the bad ones. Each message comes with ``malformed``: True when
docs/spec/ros.md, "Safety behaviour", says the receiving node must drop it (wrong length or
non-finite; for joint states also wrong names or mismatched arrays). Stamp checks depend on the
node, so stamps do not enter that flag.

`OutputCheck` collects every value a node publishes and every bound it breaks.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from builtin_interfaces.msg import Duration, Time
from reliability_session import (
    MAX_PRESSURE,
    MAX_SUPPLY,
    NODES,
    START_TIMEOUT,
    TOPICS,
    GloveSession,
)
from ros_harness import wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

#: Hostile numbers: non-finite, extreme, subnormal, negative and huge.
HOSTILE_NUMBERS = (
    math.nan,
    math.inf,
    -math.inf,
    1e308,
    -1e308,
    5e-324,
    -5e-324,
    2.2250738585072014e-308,
    -1e5,
    1e9,
    0.0,
    -0.0,
)
#: Wrong lengths for a three-joint vector.
WRONG_LENGTHS = (0, 1, 2, 4, 1000)
#: Joint name lists: empty, short, duplicated, reordered, unknown, too many.
HOSTILE_NAMES = (
    [],
    ['mcp'],
    ['mcp', 'mcp', 'mcp'],
    ['dip', 'pip', 'mcp'],
    ['pip', 'mcp', 'dip'],
    ['a', 'b', 'c'],
    ['mcp', 'pip', 'dip', 'tip'],
    ['', '', ''],
)


def _is_valid_vector(data: list[float]) -> bool:
    return len(data) == 3 and all(math.isfinite(v) for v in data)


def _vector(rng: np.random.Generator, case: int, scale: float) -> list[float]:
    """Data of one Float64MultiArray for case number ``case``."""
    kind = case % 4
    if kind == 0:  # wrong length
        length = WRONG_LENGTHS[(case // 4) % len(WRONG_LENGTHS)]
        return (rng.standard_normal(length) * scale).tolist()
    if kind == 1:  # three values, each from the hostile list
        return [HOSTILE_NUMBERS[i] for i in rng.integers(len(HOSTILE_NUMBERS), size=3)]
    if kind == 2:  # one hostile value among sensible ones
        data = (rng.uniform(0.0, 1.0, 3) * scale).tolist()
        data[int(rng.integers(3))] = HOSTILE_NUMBERS[int(rng.integers(len(HOSTILE_NUMBERS)))]
        return data
    return (rng.uniform(-0.5, 1.5, 3) * scale).tolist()  # well formed, possibly out of range


def hostile_vectors(
    count: int, scale: float, seed: int = 0
) -> Iterator[tuple[Float64MultiArray, bool]]:
    """``count`` Float64MultiArray messages and whether each is malformed.

    Parameters
    ----------
    count : int
        How many.
    scale : float
        Size of a sensible value on the topic (Pa, rad or N).
    seed : int
        Seed of the random choices.
    """
    rng = np.random.default_rng(seed)
    for case in range(count):
        data = _vector(rng, case, scale)
        yield Float64MultiArray(data=data), not _is_valid_vector(data)


def _stamp(rng: np.random.Generator, case: int, now_ns: int) -> Time:
    kind = case % 6
    if kind == 0:
        nanoseconds = 0
    elif kind == 1:
        nanoseconds = now_ns + int(rng.integers(1, 10**6)) * 10**9  # future
    elif kind == 2:
        nanoseconds = int(rng.integers(1, 10**6)) * 10**9  # 1970
    elif kind == 3:
        nanoseconds = -int(rng.integers(1, 10**6)) * 10**9  # before 1970 (sec < 0)
    else:
        nanoseconds = now_ns
    return Time(sec=nanoseconds // 10**9, nanosec=nanoseconds % 10**9)


def hostile_joint_states(
    count: int, prefix: str, now_ns: int, seed: int = 0
) -> Iterator[tuple[JointState, bool]]:
    """``count`` JointState messages for joints ``<prefix>mcp`` etc., and whether malformed.

    ``now_ns`` is the receiving clock's time, ns, for the current, future and ancient stamps.
    """
    rng = np.random.default_rng(seed)
    good_names = [f'{prefix}{joint}' for joint in ('mcp', 'pip', 'dip')]
    for case in range(count):
        kind = case % 4
        names = list(good_names)
        position = rng.uniform(0.0, 1.0, 3).tolist()
        velocity: list[float] = []
        effort: list[float] = []
        if kind == 0:
            names = [prefix + n if n else n for n in HOSTILE_NAMES[(case // 4) % 8]]
            position = position[: len(names)] if names else []
        elif kind == 1:
            position = _vector(rng, case // 4, 1.0)
            velocity = _vector(rng, case // 4 + 1, 1.0)
            effort = _vector(rng, case // 4 + 2, 1.0)
        elif kind == 2:
            velocity = (rng.standard_normal(int(rng.integers(0, 5)))).tolist()
            effort = (rng.standard_normal(int(rng.integers(0, 5)))).tolist()
        order = sorted(range(len(names)), key=lambda i: rng.random())
        message = JointState(
            name=[names[i] for i in order],
            position=[position[i] for i in order] if len(position) == len(names) else position,
            velocity=velocity,
            effort=effort,
        )
        message.header.stamp = _stamp(rng, case, now_ns)
        message.header.frame_id = ''
        suffixes = sorted(n[len(prefix) :] if n.startswith(prefix) else n for n in names)
        malformed = (
            suffixes != ['dip', 'mcp', 'pip']
            or not _is_valid_vector(position)
            or len(velocity) not in (0, 3)
            or len(effort) not in (0, 3)
        )
        yield message, malformed


def hostile_trajectories(count: int, now_ns: int, seed: int = 0) -> Iterator[tuple[object, bool]]:
    """``count`` JointTrajectory messages (names, points, times, stamps of the cases above).

    Malformed: names that are not mcp, pip, dip once each, no points, a point whose positions
    are not three finite values, or times that do not increase from 0.
    """
    rng = np.random.default_rng(seed)
    for case in range(count):
        names = ['mcp', 'pip', 'dip']
        if case % 3 == 0:
            names = list(HOSTILE_NAMES[(case // 3) % len(HOSTILE_NAMES)])
        points, times, malformed = [], [], False
        for k in range(int(rng.integers(0, 4))):
            positions = _vector(rng, case + k, 1.0)
            t_ns = int(rng.integers(-(10**9), 5 * 10**9))
            velocities = (rng.standard_normal(int(rng.choice([0, 3, 3, 5])))).tolist()
            malformed |= not _is_valid_vector(positions) or len(velocities) == 5
            times.append(t_ns)
            points.append(
                JointTrajectoryPoint(
                    positions=positions,
                    velocities=velocities,
                    time_from_start=Duration(sec=t_ns // 10**9, nanosec=t_ns % 10**9),
                )
            )
        increasing = all(b > a for a, b in itertools.pairwise(times))
        malformed |= sorted(names) != ['dip', 'mcp', 'pip'] or not points or not increasing
        malformed |= bool(times) and times[0] < 0
        message = JointTrajectory(joint_names=names, points=points)
        message.header.stamp = _stamp(rng, case, now_ns)
        yield message, malformed


@dataclass
class OutputCheck:
    """Every value a node published, checked against bounds.

    Attributes
    ----------
    bounds : dict
        Topic -> (low, high) inclusive bounds of every published value.
    messages : dict
        Topic -> messages seen.
    violations : list of str
        One line per value that was non-finite or out of bounds (first 20 kept).
    non_finite : int
        Count of non-finite published values.
    """

    bounds: dict[str, tuple[float, float]]
    messages: dict[str, int] = field(default_factory=dict)
    violations: list[str] = field(default_factory=list)
    non_finite: int = 0
    out_of_bounds: int = 0

    def add(self, topic: str, values) -> None:
        """Check the values of one published message on ``topic``."""
        self.messages[topic] = self.messages.get(topic, 0) + 1
        low, high = self.bounds.get(topic, (-math.inf, math.inf))
        for value in values:
            if not math.isfinite(value):
                self.non_finite += 1
            elif low <= value <= high:
                continue
            else:
                self.out_of_bounds += 1
            if len(self.violations) < 20:
                self.violations.append(f'{topic}: {value!r} outside [{low}, {high}]')


# -- a glove under fuzz, over DDS ------------------------------------------------------------

#: Messages per fuzzed topic in the default test run; the full run (bench_fuzz.py, or this
#: variable set to 10000) uses 10,000.
DEFAULT_COUNT = 2000
#: Seconds to wait for a node's diagnostics after a flood (they come every second).
REPORT_TIMEOUT = 10.0
#: The report that counts a flood's rejections is the first one sent this long after the flood
#: (s): the consumer has taken most of what was still in flight by then. Any later report would
#: count as many or more, so the figures are lower bounds of what was dropped, which the checks
#: allow (at least one, at most what was sent); waiting a full second for the rest only made
#: every flood a second longer.
SETTLE = 0.25
#: Output topics and the documented bounds of their values.
OUTPUT_BOUNDS = {
    'joint_states': (-math.inf, math.inf),
    'chamber_pressure': (0.0, MAX_SUPPLY),
    'contact_forces': (-math.inf, math.inf),
    'estimated_contact_forces': (-math.inf, math.inf),
    'estimated_finger_stiffness': (-math.inf, math.inf),
    'pressure_command': (0.0, MAX_PRESSURE),
}
FLOWING = ('joint_states', 'chamber_pressure', 'contact_forces', 'estimated_contact_forces')
"""Outputs that must keep flowing through a flood of another topic."""
FLOW_TIMEOUT = 10.0
"""Seconds to wait for each of them, sent since the flood began: a reader that missed a message
(likely in a flood) holds back the rest until the writer's next heartbeat (3 s in Fast DDS)."""


@dataclass(frozen=True)
class FuzzTarget:
    """One subscribed topic: who consumes it, what to send, the controller mode that reads it."""

    topic: str
    consumers: tuple[str, ...]
    scale: float
    mode: str = 'sine'


TARGETS = (
    FuzzTarget('pressure_command', ('plant',), 5e4),
    FuzzTarget('joint_states', ('pressure_command', 'estimator'), 1.0, 'position'),
    FuzzTarget('chamber_pressure', ('estimator',), 5e4),
    FuzzTarget('estimated_contact_forces', ('pressure_command',), 1.0, 'force'),
    FuzzTarget('joint_targets', ('pressure_command',), 1.0, 'position'),
    FuzzTarget('joint_trajectory', ('pressure_command',), 1.0, 'position'),
)


@dataclass
class FloodFigures:
    """What one flood of one topic did."""

    topic: str
    sent: int = 0
    malformed: int = 0
    seconds: float = 0.0
    rejections: dict[str, int] = field(default_factory=dict)
    log_lines: dict[str, int] = field(default_factory=dict)
    levels: dict[str, bytes | None] = field(default_factory=dict)
    alive: dict[str, bool] = field(default_factory=dict)
    tracebacks: list[str] = field(default_factory=list)
    outputs: OutputCheck | None = None
    unsafe_commands: list[str] = field(default_factory=list)


def drop_log_lines(text: str) -> int:
    """Log lines about dropped input messages."""
    return sum('dropped' in line for line in text.splitlines())


class GloveUnderFuzz(GloveSession):
    """The glove in namespace ``/fuzz`` (a `GloveSession`), flooded topic by topic."""

    def __init__(self, launcher, probe) -> None:
        super().__init__(launcher, probe, '/fuzz')
        for node in NODES:
            self.start(node)
        self.publishers = {}
        self.flood_windows: dict[str, list[tuple[int, int]]] = {}
        self.restarted: set[str] = set()

    def wait_running(self, timeout: float) -> bool:
        """Every output flows and every node has reported."""
        return all(
            self.flowing(topic, -1.0, count=1, timeout=timeout)
            for topic in ('joint_states', 'pressure_command', 'estimated_contact_forces')
        ) and all(self.reported(node, -1.0, timeout) for node in NODES)

    def rejections(self, node: str, topic: str, since: float) -> int | None:
        """``node``'s count of dropped ``topic`` messages in a report newer than ``since``."""
        status = self.status(node, since)
        if status is None:
            return None
        prefix = f'rejected {topic}:'
        return sum(int(kv.value) for kv in status.values if kv.key.startswith(prefix))

    def set_mode(self, mode: str) -> None:
        """Switch the controller's mode (the one that reads the fuzzed topic)."""
        results = self.probe.set_parameters(f'{self.namespace}/pressure_command', {'mode': mode})
        assert results[0].successful, results[0].reason

    def rss(self) -> dict[str, int]:
        """Resident memory of each running node, bytes."""
        return {name: node.rss_bytes() for name, node in self.processes.items() if node.alive()}

    def publisher(self, topic: str):
        """The probe's publisher on ``topic`` (kept: destroying one races its executor)."""
        if topic not in self.publishers:
            kind = JointTrajectory if topic == 'joint_trajectory' else TOPICS.get(topic)
            kind = kind or Float64MultiArray
            self.publishers[topic] = self.probe.publisher(f'{self.namespace}/{topic}', kind)
        return self.publishers[topic]

    def revive(self, timeout: float) -> None:
        """Restart any node a previous flood killed, so one crash does not hide the next."""
        since = time.monotonic()
        dead = [node for node in NODES if not self.alive(node)]
        for node in dead:
            self.start(node)
            self.restarted.add(node)
        assert all(self.reported(node, since, timeout) for node in dead), f'{dead} not back'

    def flood(self, target: FuzzTarget, count: int, seed: int) -> FloodFigures:
        """Send ``count`` hostile messages on ``target.topic`` at full speed; measure."""
        self.revive(REPORT_TIMEOUT + START_TIMEOUT)
        figures = FloodFigures(target.topic)
        self.set_mode(target.mode)
        publisher = self.publisher(target.topic)
        # Every subscriber the graph lists, not just one: the probe's own reader of an output
        # matches at once, and a flood sent before the consumer's reader matched never reaches
        # it (fresh clone fc13, seed 11: pressure_command counted 0 of a flood of estimates).
        topic = publisher.topic_name
        matched = wait_until(
            lambda: publisher.get_subscription_count() >= self.probe.node.count_subscribers(topic),
            REPORT_TIMEOUT,
        )
        assert matched, f'{topic}: not every subscriber the graph lists has matched'
        stderr = {name: self.processes[name].stderr for name in target.consumers}
        logs = {name: drop_log_lines(read()) for name, read in stderr.items()}
        before = {name: self.rejections(name, target.topic, -1.0) or 0 for name in NODES}
        if target.topic == 'joint_states':
            messages = hostile_joint_states(count, '', time.time_ns(), seed)
        elif target.topic == 'joint_trajectory':
            messages = hostile_trajectories(count, time.time_ns(), seed)
        elif TOPICS.get(target.topic) is JointState:  # an estimate: its values are its effort
            vectors = hostile_vectors(count, target.scale, seed)
            messages = ((JointState(effort=m.data), bad) for m, bad in vectors)
        else:
            messages = hostile_vectors(count, target.scale, seed)
        started, started_ns = time.monotonic(), time.time_ns()
        for message, malformed in messages:
            publisher.publish(message)
            figures.sent += 1
            figures.malformed += malformed
        finished = time.monotonic()
        self.flood_windows.setdefault(target.topic, []).append((started_ns, time.time_ns()))
        figures.seconds = finished - started
        for name in target.consumers:
            counted = wait_until(
                lambda n=name: self.rejections(n, target.topic, finished + SETTLE), REPORT_TIMEOUT
            )
            figures.rejections[name] = (counted or 0) - before[name]
            report = self.status(name, finished + SETTLE)  # None: the node died
            figures.levels[name] = None if report is None else report.level
            figures.log_lines[name] = drop_log_lines(stderr[name]()) - logs[name]
        figures.alive = {name: self.alive(name) for name in NODES}
        figures.tracebacks = [n for n in NODES if 'Traceback' in self.processes[n].stderr()]
        flowing = [topic for topic in FLOWING if topic != target.topic]
        wait_until(lambda: all(self.sent_since(t, started_ns) for t in flowing), FLOW_TIMEOUT)
        figures.outputs = self.check_outputs(target.topic, started)
        if target.topic != 'pressure_command':  # else the probe's own commands are in there
            ours = self.flood_windows.get('pressure_command', [])
            figures.unsafe_commands = self.unsafe_commands(started, exclude=ours)
        return figures

    def sent_since(self, topic: str, since_ns: int) -> bool:
        """Whether a message on ``topic`` sent at or after ``since_ns`` (system clock) arrived."""
        return any(
            info['source_timestamp'] >= since_ns for _, _, info in self.inbox[topic].records()
        )

    def check_outputs(self, fuzzed: str, since: float) -> OutputCheck:
        """Bounds of every output since ``since``, leaving out what the probe sent itself (the
        fuzzed topic, and messages of earlier floods still arriving)."""
        check = OutputCheck(OUTPUT_BOUNDS)
        for topic in OUTPUT_BOUNDS:
            if topic == fuzzed:
                continue
            windows = self.flood_windows.get(topic, [])
            for arrival, message, info in self.inbox[topic].records():
                stamp = info['source_timestamp']
                if arrival <= since or any(start <= stamp <= end for start, end in windows):
                    continue
                if isinstance(message, JointState):
                    values = [*message.position, *message.velocity, *message.effort]
                else:
                    values = message.data
                check.add(topic, values)
        return check
