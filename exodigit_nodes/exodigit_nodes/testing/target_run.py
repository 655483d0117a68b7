"""A user's controller node that tracks targets: the kit starts it and steps it target by target.

:class:`TargetGloveSim` is a :class:`~.client.GloveSim` that also starts your controller's
command in the glove's domain and namespace (:meth:`~TargetGloveSim.start_controller`) and runs
it against a sequence of joint targets (:meth:`~TargetGloveSim.run_targets`), one per step,
published on the glove's ``joint_targets`` topic (std_msgs/Float64MultiArray, rad), which the
``pressure_command`` node's ``position`` mode follows. The virtual patient trials of a ROS node
controller (:mod:`.trial_engine`) run every patient this way.

What the kit guarantees (docs/trials.md, "A ROS node as the controller"). Before the run: your
node answers a ``get_parameters`` request (so its executor spins) and, unless ``follows`` is
False, its ``joint_targets`` subscription is matched. Then, step k:

1. the plant has taken your answer to state k − 1 (its ``applied_command``: you are done with
   target k − 1);
2. the kit publishes target k and waits until every matched ``joint_targets`` subscriber has
   acknowledged it (reliable QoS: it is in your node's reader);
3. only then does the kit have the plant take the step (its ``step`` service; the plant stays
   paused) and publish state k, which your node answers.

So target k is in your node before state k is even computed. A node that handles its messages
in the order they arrived (rclpy's ``EventsExecutor``, as ``pressure_command``) therefore always
answers state k holding target k. With rclpy's ``SingleThreadedExecutor`` the same holds unless
the node is still busy (descheduled) when state k arrives too: that executor then takes the
messages waiting together in the order the node created its subscriptions, so create the
``joint_targets`` subscription before the ``joint_states`` one. The kit cannot see what your
node did with a target; it records what it sent. Every step waits for the kit, so a run is
slower than :meth:`~.client.GloveSim.run` (about 2 ms a step on the development VM: the
acknowledged target, a ``step`` call to the plant, the state and your answer).

A run is a session of its own: it starts with the plant's ``reset_simulation`` (the patient of
its parameters, at rest, simulated time back to zero), so a run on a glove that ran before gives
what a fresh glove gives, provided your node starts over when time goes back (docs/spec/ros.md,
"When time goes back"). Target 0 is delivered before that reset: keep the latest target across
it.
"""

from __future__ import annotations

import os
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rclpy.duration import Duration
from std_msgs.msg import Float64MultiArray

from ..logic.lifetime import exit_status
from ..logic.ros_env import ros_args
from ..nodes.dds import PROFILE, PROFILE_VARIABLE
from ..nodes.handshake import Handshake, matched_every_listed
from ..nodes.messages import JOINT_TARGETS, fill, joint_vector_message
from ..nodes.qos import HANDED_OVER_QOS
from ..runner.supervisor import Child
from .client import POLL, GloveSim, GloveSimError
from .records import SimState, StateHistory, state_arrays

KIT_PROFILE = Path(__file__).with_name('fastdds_kit.xml')
"""Fast DDS profile of the kit's process and your controller's during a target run."""


def kit_profile(environ: Mapping[str, str]) -> dict[str, str]:
    """``environ`` naming :data:`KIT_PROFILE` where it names the project's profile or none.

    A profile of your own (``FASTRTPS_DEFAULT_PROFILES_FILE``) is kept: the run is then as
    exact, but each target waits for your profile's heartbeat (the project's: up to 50 ms).
    """
    env = dict(environ)
    if env.get(PROFILE_VARIABLE, str(PROFILE)) == str(PROFILE):
        env[PROFILE_VARIABLE] = str(KIT_PROFILE)
    return env


@dataclass(frozen=True)
class TargetRecord(StateHistory):
    """A :meth:`TargetGloveSim.run_targets`: row k is step k + 1 of the run (SI, MCP/PIP/DIP).

    The :class:`~exodigit_nodes.testing.records.StateHistory` fields hold the state at the end
    of each step, as published; ``t`` is the plant's stamp there.

    Attributes
    ----------
    command : ndarray, shape (n, 3)
        The command that drove each step: your answer to the state before, Pa.
    initial : SimState
        The state the run started from (the rest state after the plant's
        ``reset_simulation``, at the first step's time), which your controller answered first.
    target : ndarray, shape (n, 3)
        The target the kit had delivered when your controller answered the state before (the
        target of the step), rad.
    """

    command: NDArray[np.float64]
    initial: SimState
    target: NDArray[np.float64]


class ControllerProcess(Child):
    """Your controller's command, started in the glove's domain and namespace.

    ``command`` gets ``--ros-args -r __ns:=<namespace> -p use_sim_time:=true`` and the
    ``-p`` overrides of ``parameters`` appended; it runs in this process's working directory,
    its output in ``controller.out``/``.err`` of ``log_dir``, and is stopped as every process
    of the kit (:class:`~exodigit_nodes.runner.supervisor.Child`).
    """

    def __init__(
        self,
        command: Sequence[str],
        parameters: Mapping[str, Any],
        *,
        env: Mapping[str, str],
        namespace: str,
        log_dir: Path,
    ) -> None:
        self.command = [*command, *ros_args({'use_sim_time': True, **parameters}, namespace)]
        try:
            super().__init__(
                'your controller',
                self.command,
                env,
                log=Path(log_dir) / 'controller.out',
                errors=Path(log_dir) / 'controller.err',
            )
        except OSError as error:
            raise GloveSimError(
                f'cannot start your controller {shlex.join(command)}: {error.strerror}'
            ) from None

    def failure(self, what: str) -> GloveSimError:
        """The error to raise when it has exited while the kit waited for ``what``."""
        tail = self.errors_path.read_text(errors='replace').strip().splitlines()[-5:]
        return GloveSimError(
            f'your controller {exit_status(self.popen.returncode)} while waiting for {what}'
            + (': ' + ' | '.join(tail) if tail else ' (nothing on stderr)')
            + f'; its output is in {self.log_path.parent}'
        )


class TargetGloveSim(GloveSim):
    """A :class:`~.client.GloveSim` that starts your controller node and feeds it targets.

    Takes :class:`~.client.GloveSim`'s arguments. :meth:`close` stops your controller first
    (it may send a last command), then the glove.
    """

    _controller: ControllerProcess | None = None
    _targets = None

    def start_controller(
        self, command: Sequence[str], parameters: Mapping[str, Any] | None = None
    ) -> ControllerProcess:
        """Start ``command`` (argv) as your controller, in this glove's domain and namespace.

        Its exit is then noticed by every wait of the kit (a :class:`GloveSimError` with the
        exit status and its last lines of stderr).
        """
        if self._controller is not None:
            raise GloveSimError('a controller was started already')
        if not command:
            raise ValueError('command: empty; give the argv of your controller')
        self._controller = ControllerProcess(
            command,
            parameters or {},
            env=kit_profile(self.env),
            namespace=self.namespace,
            log_dir=self.log_dir,
        )
        return self._controller

    def close(self) -> None:
        """Stop your controller, then everything :class:`GloveSim` started (idempotent)."""
        if self._controller is not None:
            self._controller.stop()
        super().close()

    def _connect(self, estimator: bool) -> None:
        """:meth:`GloveSim._connect` with :data:`KIT_PROFILE` for this process's participant.

        Fast DDS reads the profile once, when a process makes its first participant: a process
        that made one before keeps the profile it read (slower targets, same results).
        """
        before = os.environ.get(PROFILE_VARIABLE)
        os.environ[PROFILE_VARIABLE] = kit_profile(os.environ)[PROFILE_VARIABLE]
        try:
            super()._connect(estimator)
        finally:
            if before is None:
                del os.environ[PROFILE_VARIABLE]
            else:
                os.environ[PROFILE_VARIABLE] = before

    def _check_alive(self, what: str) -> None:
        super()._check_alive(what)
        if self._controller is not None and not self._controller.alive():
            raise self._controller.failure(what)

    def run_targets(self, targets: ArrayLike, *, follows: bool = True) -> TargetRecord:
        """A new session of the glove, stepped once per row of ``targets`` with your controller.

        Row k (rad, MCP/PIP/DIP) is delivered on ``joint_targets`` before the state your
        controller answers with the command that drives step k + 1 (see the module's text for
        what is guaranteed). Your controller must publish ``pressure_command`` (start it with
        :meth:`start_controller`; this waits for it) and answer every ``joint_states`` with
        one command. With ``follows`` (default) the run also waits until its ``joint_targets``
        subscription is matched; ``follows=False`` for a controller that does not subscribe
        (an open-loop one): the targets are still sent and recorded.

        Returns
        -------
        TargetRecord
            The ``len(targets)`` steps.

        Raises
        ------
        ValueError
            If ``targets`` is not an (n, 3) array of finite angles, n >= 1.
        GloveSimError
            If your controller exits, or it or the plant does not go on within ``timeout``.
        """
        targets = np.array(targets, dtype=float)
        if targets.ndim != 2 or targets.shape[1:] != (3,) or len(targets) < 1:
            raise ValueError(f'targets: shape {targets.shape}, expected (n, 3) with n >= 1')
        if not np.isfinite(targets).all():
            raise ValueError('targets: must be finite angles, rad')
        node = self._node
        controllers = self._wait(node.other_controllers, 'your controller to publish')
        self._set_paused(True)
        self._wait_matched(controllers)
        # A node publishes (and its reader acknowledges) before its executor spins; an
        # executor that starts with a target and a state waiting may take the state first (a
        # run here answered state 0 with the node's default target). A node that answers the
        # session protocol's handshake spins (and has matched our readers).
        handshake = Handshake(node, controllers)
        self._wait(lambda: not handshake.silent(), f'{", ".join(controllers)} to spin')
        handshake.destroy()
        if self._targets is None:
            self._targets = node.create_publisher(
                Float64MultiArray, JOINT_TARGETS, HANDED_OVER_QOS
            )
        publisher, message = self._targets, joint_vector_message()
        # Seeing the controller's publisher says nothing of its subscriptions: DDS announces
        # readers and writers on separate streams (a run here found the graph without the
        # joint_targets reader, and target 0 unheard). So a controller that follows targets
        # must be matched, and every other subscriber the graph shows too.
        wanted = f'your controller to subscribe {JOINT_TARGETS}' + (
            ' (follows=False for a controller that does not)' if follows else ''
        )
        self._wait(
            lambda: matched_every_listed(node, publisher, least=int(follows)),
            wanted,
        )

        def deliver(k: int) -> None:
            publisher.publish(fill(message, targets[k]))
            self._wait(
                lambda: publisher.wait_for_all_acked(Duration(seconds=POLL)),
                f'your controller to acknowledge target {k}',
            )

        deliver(0)
        initial = self.reset_simulation()  # the rest state, answered with target 0
        states: list[SimState] = []
        # The plant stays paused; its `step` takes each step with the answer the kit has heard
        # from the plant itself (applied_command: the plant has taken it).
        for k in range(len(targets)):
            self._wait(lambda k=k: node.command_count() > k, f'your answer to step {k}')
            if k + 1 < len(targets):
                deliver(k + 1)
            self._call(node.step_client, node.trigger(), 'step')
            states.append(self._next_state(with_estimate=False))
        # the last answer too: none of this session's may be counted in the next
        self._wait(lambda: node.command_count() > len(targets), 'your last answer')
        commands = node.take_commands(len(targets))
        node.clear_commands()
        self.state = states[-1]
        self._external_synced = True
        return TargetRecord(
            initial=initial,
            **state_arrays(states),
            command=np.array(commands),
            target=targets,
        )
