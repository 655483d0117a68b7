"""A user's controller node that tracks targets: the kit starts it and runs it on a trajectory.

:class:`TargetGloveSim` is a :class:`~.client.GloveSim` that also starts your controller's
command in the glove's domain and namespace (:meth:`~TargetGloveSim.start_controller`) and runs
it on a trajectory of joint targets (:meth:`~TargetGloveSim.run_trajectory`, or one target a
step with :meth:`~TargetGloveSim.run_targets`), sent whole as one ``joint_trajectory``
(trajectory_msgs/JointTrajectory, docs/spec/ros.md "Trajectories"), which the
``pressure_command`` node's ``position`` mode follows. The virtual patient trials of a ROS node
controller (:mod:`.trial_engine`) run every patient this way.

A run is a session of its own. What the kit guarantees (docs/trials.md, "A ROS node as the
controller"): your node answers a ``get_parameters`` request (so its executor spins) and,
unless ``follows`` is False, its ``joint_trajectory`` subscription is matched; then the kit
publishes the trajectory, stamped with the time of the session's first state, and waits until
every matched subscriber has acknowledged it (reliable QoS: it is in your node's reader); only
then does it start the session with the plant's ``reset_simulation`` (the patient of its
parameters, at rest, simulated time back to zero), whose first state your node answers, and let
the plant step in lockstep with your node (as :meth:`~.client.GloveSim.run`) for the run's
steps. So the whole trajectory is in your node before the first state exists, and a node that
starts over when time goes back (docs/spec/ros.md, "When time goes back") keeps a trajectory
stamped in the new session's time, as ``pressure_command`` does. The kit cannot see what your
node did with the trajectory; the record holds its targets at each step's time.
"""

from __future__ import annotations

import math
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from exodigit_model.control import Trajectory
from exodigit_model.stepping.settings import NANOSECONDS, step_time_ns
from numpy.typing import ArrayLike, NDArray
from rclpy.duration import Duration
from trajectory_msgs.msg import JointTrajectory

from ..logic.lifetime import exit_status
from ..logic.ros_env import ros_args
from ..nodes.handshake import Handshake, matched_every_listed
from ..nodes.messages import JOINT_TRAJECTORY, trajectory_message
from ..nodes.qos import STREAM_QOS
from ..runner.supervisor import Child
from .client import GloveSim
from .driving import POLL, GloveSimError
from .records import SimState, StateHistory, state_arrays


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
        The trajectory's target at the time of each step, from the session's first state: what
        your controller, answering the state before, aims at, rad.
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
    _trajectories = None

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
            env=self.env,
            namespace=self.namespace,
            log_dir=self.log_dir,
        )
        return self._controller

    def close(self) -> None:
        """Stop your controller, then everything :class:`GloveSim` started (idempotent)."""
        if self._controller is not None:
            self._controller.stop()
        super().close()

    def _check_alive(self, what: str) -> None:
        super()._check_alive(what)
        if self._controller is not None and not self._controller.alive():
            raise self._controller.failure(what)

    def run_targets(self, targets: ArrayLike, *, follows: bool = True) -> TargetRecord:
        """A session of ``len(targets)`` steps, row k (rad) the target of step k + 1.

        :meth:`run_trajectory` of the trajectory with row k at the time of step k + 1 from the
        session's start, which your controller answering the state before step k + 1 aims at.

        Raises
        ------
        ValueError
            If ``targets`` is not an (n, 3) array of finite angles, n >= 1.
        """
        targets = np.array(targets, dtype=float)
        if targets.ndim != 2 or targets.shape[1:] != (3,) or len(targets) < 1:
            raise ValueError(f'targets: shape {targets.shape}, expected (n, 3) with n >= 1')
        steps = len(targets)
        times = [step_time_ns(k, self.rate_hz) / NANOSECONDS for k in range(1, steps + 1)]
        return self.run_trajectory(
            Trajectory(times, targets), steps / self.rate_hz, follows=follows
        )

    def run_trajectory(
        self, trajectory: Trajectory, seconds: float, *, follows: bool = True
    ) -> TargetRecord:
        """A new session of the glove, ``seconds`` long, with your controller on ``trajectory``.

        ``trajectory``'s times count from the session's first state (the rest state after the
        plant's ``reset_simulation``), which your controller answers first (module text). Your
        controller must publish ``pressure_command`` (start it with :meth:`start_controller`;
        this waits for it) and answer every ``joint_states`` with one command. With ``follows``
        (default) the run also waits until its ``joint_trajectory`` subscription is matched;
        ``follows=False`` for a controller that does not subscribe (an open-loop one): the
        trajectory is still sent and its targets recorded.

        Returns
        -------
        TargetRecord
            The ``round(seconds · rate_hz)`` steps, each with the trajectory's target at its
            time.

        Raises
        ------
        ValueError
            If ``seconds`` gives no step.
        GloveSimError
            If your controller exits, or it or the plant does not go on within ``timeout``.
        """
        steps = round(seconds * self.rate_hz)
        if not (math.isfinite(seconds) and steps >= 1):
            raise ValueError(f'seconds = {seconds!r}: must give at least one step')
        node = self._node
        controllers = self._wait(node.other_controllers, 'your controller to publish')
        self._set_paused(True)
        self._wait_matched(controllers)
        # A node publishes (and its reader acknowledges) before its executor spins; an
        # executor that starts with a trajectory and a state waiting may take the state first.
        # A node that answers the session protocol's handshake spins (and has matched our
        # readers).
        handshake = Handshake(node, controllers)
        self._wait(lambda: not handshake.silent(), f'{", ".join(controllers)} to spin')
        handshake.destroy()
        if self._trajectories is None:
            self._trajectories = node.create_publisher(
                JointTrajectory, JOINT_TRAJECTORY, STREAM_QOS
            )
        publisher = self._trajectories
        # Seeing the controller's publisher says nothing of its subscriptions: DDS announces
        # readers and writers on separate streams (a run here found the graph without the
        # targets' reader, and the first target unheard). So a controller that follows the
        # trajectory must be matched, and every other subscriber the graph shows too.
        wanted = f'your controller to subscribe {JOINT_TRAJECTORY}' + (
            ' (follows=False for a controller that does not)' if follows else ''
        )
        self._wait(lambda: matched_every_listed(node, publisher, least=int(follows)), wanted)
        start = step_time_ns(1, self.rate_hz)  # the new session's first state
        publisher.publish(trajectory_message(trajectory, start, self.joint_names))
        self._wait(
            lambda: publisher.wait_for_all_acked(Duration(seconds=POLL)),
            'your controller to acknowledge the trajectory',
        )
        initial = self.reset_simulation()  # the rest state, which your controller answers
        states: list[SimState] = []
        end = node.time_ns(initial.t) + round(steps * NANOSECONDS / self.rate_hz)
        # every answer, the last one's too: none of this session's may count in the next
        self._lockstep(end, states, steps, answers=steps + 1)
        commands = node.take_commands(steps)
        node.clear_commands()
        self.state = states[-1]
        self._external_synced = True
        origin = node.time_ns(initial.t)
        return TargetRecord(
            initial=initial,
            **state_arrays(states),
            command=np.array(commands),
            target=np.array([trajectory.at_ns(node.time_ns(s.t) - origin) for s in states]),
        )
