"""How the testing kit drives a plant's simulated time: waits, service calls, lockstep runs.

:class:`PlantDriver` is the part of :class:`~.client.GloveSim` that talks to a running plant:
every wait spins the kit's executor, checks that the glove's processes still run and gives up
after ``timeout`` with their last lines of stderr (:class:`GloveSimError`); a service call's
refusal is an error naming it; and :meth:`PlantDriver._lockstep` lets the plant step in
lockstep with a controller node of the user's up to a time, at most a few steps ahead of the
states received (:mod:`..runner.horizon`), then pauses it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .processes import NodeProcess
from .records import SimState

DEFAULT_TIMEOUT = 60.0
"""Longest wall-clock wait for the glove (start-up, a step, a run) before an error, s."""
POLL = 0.05
"""Longest single wait of the client's executor, and how often a wait checks that the glove's
processes still run, s."""


def matched_both_ways(controllers: dict[str, set[str]], said: dict[str, set[str]]) -> bool:
    """Whether the plant ``said`` (``lockstep_controllers``) it has matched ``controllers``.

    Both map a node's name to the ids of its command publishers. By the ids, not the names: the
    plant's word about a namesake that has gone (a test's controller before this one) can still
    be the newest we have when we begin to wait.
    """
    return all(ids <= said.get(name, set()) for name, ids in controllers.items())


class GloveSimError(RuntimeError):
    """The simulated glove did not answer as the lockstep protocol says; the text says what."""


class PlantDriver:
    """Waits and calls on the glove of a :class:`~.client.GloveSim` (module docstring).

    Uses the client's ``_node`` (:class:`~.ros_client.GloveClient`), ``_executor``,
    ``_processes``, ``timeout``, ``namespace``, ``log_dir`` and ``state``.
    """

    _node: Any
    _executor: Any
    _processes: list[NodeProcess]
    timeout: float
    namespace: str
    log_dir: Path
    state: SimState
    _paused = True
    _external_synced = False

    def _set_paused(self, paused: bool) -> None:
        if paused != self._paused:
            self._call(self._node.pause_client, self._node.pause_request(paused), 'set_paused')
            self._paused = paused

    def _wait_matched(self, controllers: dict[str, set[str]]) -> None:
        """Wait until the plant has matched ``controllers``, before the state each is to answer.

        We count their answers as the plant took them (``applied_command``), so our own reader
        need not match them.
        """
        names = ', '.join(controllers)
        self._wait(
            lambda: matched_both_ways(controllers, self._node.lockstep_controllers),
            f'the plant to match {names}',
        )

    def _next_state(self, *, with_estimate: bool = True) -> SimState:
        return self._wait(
            lambda: self._node.take_state(with_estimate=with_estimate), 'the next state'
        )

    def _lockstep(self, end_ns: int, states: list[SimState], steps: int, answers: int) -> None:
        """Let the plant step in lockstep with the user's controller up to ``end_ns``, then pause.

        The plant, paused, gets a ``run_until`` a few steps past the newest state received and
        never past ``end_ns`` (:mod:`..runner.horizon`), then runs; the states it publishes are
        appended to ``states`` until it holds ``steps``, and the plant's ``applied_command`` must
        have ``answers`` entries. Then, or after a :class:`GloveSimError`, the plant is paused
        and its ``run_until`` cleared (:meth:`_release_run_until`).
        """
        node = self._node
        horizon = node.horizon
        horizon.start(end_ns * 1e-9)
        received = states[-1].t if states else self.state.t
        self._wait(lambda: horizon.ready(received), 'the plant to take run_until')
        self._set_paused(False)

        def next_state():  # raises run_until also while waiting (its answer may come late)
            horizon.follow(states[-1].t if states else received)
            return node.take_state(with_estimate=False)

        try:
            while len(states) < steps:
                states.append(self._wait(next_state, 'the next state'))
            self._wait(lambda: node.command_count() >= answers, f'{answers} answers')
        except GloveSimError as error:
            error.add_note(
                f'{len(states)} of {steps} states and {node.command_count()} answers '
                f'heard; {node.command_publishers()}'
            )
            self._release_run_until(error)
            raise
        self._release_run_until()

    def _release_run_until(self, failure: GloveSimError | None = None) -> None:
        """Pause the plant, then clear its ``run_until``, after a :meth:`_lockstep`.

        Paused first: held at the run's end, the plant would step on with the controller's
        answer once the limit is gone; the next step resumes it. After a ``failure`` (the plant
        may have stopped anywhere) a failure to do either becomes a note on it, not a new error.
        """
        try:
            self._set_paused(True)
            self._answered(self._node.horizon.release().answer, 'reset run_until')
        except GloveSimError as error:
            if failure is None:
                raise
            failure.add_note(f'and run_until or the pause stays set: {error}')

    def _call(self, client, request, what: str):
        future = client.call_async(request)
        return self._answered(lambda: future.result() if future.done() else None, what)

    def _answered(self, answer: Callable[[], Any], what: str):
        """The plant's response once ``answer()`` gives it; GloveSimError if it refused."""
        response = self._wait(answer, what)
        if hasattr(response, 'results'):
            ok = all(result.successful for result in response.results)
            reason = '; '.join(result.reason for result in response.results)
        else:
            ok, reason = response.success, response.message
        if not ok:
            raise GloveSimError(f'{what} refused by the plant: {reason}')
        return response

    def _wait(self, condition: Callable[[], Any], what: str):
        started = time.monotonic()
        deadline, next_check = started + self.timeout, started + POLL
        while True:
            value = condition()
            if value:
                return value
            now = time.monotonic()
            if now >= next_check or now > deadline:  # not each poll: a step takes under 1 ms
                self._check_alive(what)
                next_check = now + POLL
            if now > deadline:
                error = GloveSimError(
                    f'waited {self.timeout:g} s for {what} in {self.namespace}; node logs in '
                    f'{self.log_dir}'
                )
                # The logs' ends too: a test harness may delete the directory before anyone
                # reads it (pytest keeps its last three runs).
                for process in self._processes:
                    tail = process.stderr().strip().splitlines()[-5:]
                    error.add_note(f'{process.module}: ' + (' | '.join(tail) or '(no output)'))
                raise error
            self._executor.spin_once(timeout_sec=POLL)

    def _check_alive(self, what: str) -> None:
        for process in self._processes:
            if (exit_ := process.exit()) is not None:
                tail = process.stderr().strip().splitlines()[-5:]
                raise GloveSimError(
                    f'{exit_.describe()} while waiting for {what}: ' + ' | '.join(tail)
                )
