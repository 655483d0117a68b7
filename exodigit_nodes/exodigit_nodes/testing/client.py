"""``GloveSim``: a simulated glove in lockstep simulated time, driven from a test.

It starts a ``plant`` (and, if asked, an ``estimator``) as processes in a private ROS domain and a
fresh namespace, with ``clock:=sim``, ``lockstep:=true``, ``lockstep_timeout:=0`` (the plant waits
for the test however long it takes) and ``real_time_factor:=0``, and talks to them from an rclpy
node of its own (its own context, so it never touches the caller's ``rclpy.init``). Two ways to
drive the glove:

* the test is the controller: :meth:`GloveSim.step` sends one ``pressure_command`` (with
  ``actuation='valves'``: one ``valve_command``, six openings) and returns the state of the step
  it caused (docs/spec/ros.md Part II: one command in, the next state out);
* the controller is a ROS node of the user's, started with :attr:`GloveSim.env` in
  :attr:`GloveSim.namespace`: :meth:`GloveSim.run` lets the plant step in lockstep with it for
  exactly that many simulated seconds and returns the record. Between runs the plant is paused, so
  a slow-starting node costs nothing.

Lockstep makes every result exact and repeatable: the same commands give the same states bit for
bit, however loaded the machine is.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from exodigit_model.physics.params import JOINT_NAMES
from numpy.typing import ArrayLike

from ..logic.inputs import InvalidInputError, valve_openings
from ..logic.pacing import TimeSettings
from ..nodes.catalog import ESTIMATOR_NODE, PLANT_NODE
from ..nodes.dds import use_profile
from ..nodes.run_options import time_parameters
from .driving import DEFAULT_TIMEOUT, GloveSimError, PlantDriver
from .processes import KitPlace, NodeProcess
from .records import SimRecord, SimState, state_arrays

PLANT_DEFAULTS = {'pressure_time_constant': 0.0, 'marker_rate_hz': 0.0}
"""Plant parameters the kit changes from the node's defaults: no chamber lag, no markers."""
KIT_TIME = TimeSettings(
    real_time_factor=0.0, lockstep=True, lockstep_timeout=0.0, start_paused=True
)
"""How the kit runs simulated time: as fast as possible, in lockstep, waiting for the test however
long it takes, paused between the test's calls."""
FIXED_PLANT = time_parameters(PLANT_NODE.executable, 'sim', KIT_TIME)
"""Plant parameters the kit sets itself (they define how it drives the plant)."""
KIT_OPTIONS = ('actuation',)
"""Plant parameters given as :class:`GloveSim`'s own keyword arguments (the client needs them)."""


def patient_parameters(
    params_file: str | os.PathLike | None, plant: Mapping[str, Any] | None
) -> dict[str, Any]:
    """The plant parameters of a glove's patient: its ``params_file`` (absolute) and ``plant``.

    Raises
    ------
    ValueError
        If ``plant`` names a parameter the kit sets itself (:data:`FIXED_PLANT`) or takes as
        its own keyword argument (:data:`KIT_OPTIONS`).
    """
    fixed = sorted(set(plant or {}) & set(FIXED_PLANT))
    if fixed:
        raise ValueError(f'plant parameter {fixed[0]} is set by the testing kit itself')
    own = sorted(set(plant or {}) & set(KIT_OPTIONS))
    if own:
        raise ValueError(f'plant parameter {own[0]} is GloveSim({own[0]}=...), not plant')
    path = '' if params_file is None else str(Path(params_file).resolve())
    return {**(plant or {}), 'params_file': path}


class GloveSim(PlantDriver):
    """A plant in lockstep simulated time, and the client that drives it.

    Parameters
    ----------
    params_file : str or Path, optional
        The plant's model / patient parameter file (docs/spec/model.md §10); the built-in
        defaults when omitted.
    estimator : bool
        Also start the ``estimator`` node (its estimate of each step is in
        :attr:`SimState.estimated_forces`).
    actuation : str
        The plant's ``actuation``: ``'regulator'`` (commands are three pressures,
        ``pressure_command``) or ``'valves'`` (six openings in [0, 1], inlets MCP, PIP, DIP then
        outlets, ``valve_command``; docs/spec/model.md §14).
    plant : mapping, optional
        More plant parameters (e.g. ``{'pressure_time_constant': 0.05, 'angle_noise_std':
        1e-3, 'seed': 3, 'rate_hz': 200.0}``). The kit's own (clock, lockstep, pacing) cannot be
        changed.
    namespace : str, optional
        Absolute namespace of the glove; a fresh ``/glove_sim_<n>`` when omitted.
    domain_id : int, optional
        ROS_DOMAIN_ID; a free one is claimed (and held until :meth:`close`) when omitted.
    log_dir : str or Path, optional
        Where the nodes' output goes (``<node>.out``/``.err``); a temporary folder by default.
    timeout : float
        Longest wall-clock wait for any answer from the glove, s.

    Examples
    --------
    >>> with GloveSim() as glove:                           # doctest: +SKIP
    ...     state = glove.reset()
    ...     for _ in range(100):
    ...         state = glove.step([30e3, 30e3, 30e3])
    >>> with GloveSim(actuation='valves') as glove:      # doctest: +SKIP
    ...     state = glove.step([0.2, 0.2, 0.2, 0.0, 0.0, 0.0])  # inlets 20 % open
    """

    def __init__(
        self,
        params_file: str | os.PathLike | None = None,
        *,
        estimator: bool = False,
        actuation: str = 'regulator',
        plant: Mapping[str, Any] | None = None,
        namespace: str | None = None,
        domain_id: int | None = None,
        log_dir: str | os.PathLike | None = None,
        timeout: float = DEFAULT_TIMEOUT,
    ) -> None:
        if not timeout > 0.0:
            raise ValueError(f'timeout = {timeout!r}: must be > 0 s')
        self.timeout = timeout
        self._place = KitPlace('glove_sim', namespace, domain_id, log_dir)
        self.namespace = self._place.namespace
        self.domain_id = self._place.domain_id
        self.env = self._place.env
        """The environment for a controller process of yours: this process's, with the glove's
        ROS_DOMAIN_ID and loopback-only discovery."""
        self.log_dir = self._place.log_dir

        self.actuation = PLANT_NODE.table['actuation'].check(actuation)
        parameters = {
            **PLANT_DEFAULTS,
            **patient_parameters(params_file, plant),
            'actuation': self.actuation,
            **FIXED_PLANT,
        }
        self.rate_hz = float(parameters.get('rate_hz', 100.0))
        self.joint_names = [parameters.get('joint_prefix', '') + name for name in JOINT_NAMES]
        """The names on ``joint_states`` (the plant's ``joint_prefix``), MCP, PIP, DIP."""
        self._processes: list[NodeProcess] = []
        self._node = None
        try:
            self._start('plant', parameters)
            if estimator:
                estimator_parameters = time_parameters(ESTIMATOR_NODE.executable, 'sim', KIT_TIME)
                if params_file is not None:  # else the nominal model, as the plant's
                    estimator_parameters['params_file'] = parameters['params_file']
                self._start('estimator', estimator_parameters)
            self._connect(estimator)
            self.state = self._reset(with_estimate=False)  # the estimator may join only now
        except BaseException:
            self.close()
            raise

    # -- life cycle ------------------------------------------------------------------------

    def _start(self, module: str, parameters: Mapping[str, Any]) -> None:
        self._processes.append(
            NodeProcess(module, parameters, self.domain_id, self.log_dir, self.namespace)
        )

    def _connect(self, estimator: bool) -> None:
        import rclpy
        from rclpy.experimental import EventsExecutor
        from rclpy.signals import SignalHandlerOptions

        from .ros_client import GloveClient

        use_profile()
        self._context = rclpy.Context()
        rclpy.init(
            context=self._context,
            domain_id=self.domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )
        self._node = GloveClient(
            self.namespace,
            self._context,
            estimator=estimator,
            rate_hz=self.rate_hz,
            valves=self.actuation == 'valves',
        )
        self._executor = EventsExecutor(context=self._context)
        self._executor.add_node(self._node)
        self._wait(self._node.connected, 'the glove to start and match our readers')
        # the vent the plant applied before any command (its record starts with it): no
        # command of ours
        self._wait(lambda: self._node.command_count() >= 1, "the plant's first applied_command")

    def close(self) -> None:
        """Stop every process the kit started and release the domain (idempotent)."""
        if self._node is not None:
            self._executor.shutdown()
            self._node.destroy_node()
            import rclpy

            rclpy.try_shutdown(context=self._context)
            self._node = None
        for process in self._processes:
            process.stop()
        self._processes = []
        self._place.close()

    def __enter__(self) -> GloveSim:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    # -- driving the glove from the test ---------------------------------------------------

    def reset(self) -> SimState:
        """Zero pressure and rest angles (the plant's ``reset``); returns that state.

        Simulated time goes on: the rest state is published as the next step.
        """
        return self._reset(with_estimate=True)

    def reset_simulation(self) -> SimState:
        """A new session (the plant's ``reset_simulation``); returns its rest state, step 1.

        The plant is built anew from its parameters (a patient set with :meth:`set_patient`)
        and simulated time goes back to zero: a node of yours started before sees ``/clock``
        jump back and must start over (docs/spec/ros.md, "When time goes back").
        """
        return self._reset(with_estimate=True, new_session=True)

    def set_patient(
        self, params_file: str | os.PathLike | None = None, plant: Mapping[str, Any] | None = None
    ) -> None:
        """The plant's next patient, taken at the next :meth:`reset_simulation`.

        ``params_file`` (None: the built-in defaults) and ``plant`` as for the constructor:
        ``params_file`` and ``seed`` take effect at the next :meth:`reset_simulation`, the
        other parameters at once; ``rate_hz``, if given, must be the glove's.

        Raises
        ------
        ValueError
            For a parameter the kit sets itself, or another ``rate_hz``.
        GloveSimError
            If the plant refuses a value (a ``params_file`` that does not load).
        """
        values = patient_parameters(params_file, plant)
        rate_hz = values.pop('rate_hz', self.rate_hz)
        if rate_hz != self.rate_hz:
            raise ValueError(f'rate_hz = {rate_hz!r}: this glove steps at {self.rate_hz:g} Hz')
        request = self._node.parameters_request(values)
        self._call(self._node.parameter_client, request, 'set the patient')

    def _reset(self, *, with_estimate: bool, new_session: bool = False) -> SimState:
        node = self._node
        node.clear_commands()
        if new_session:
            self._call(node.reset_simulation_client, node.trigger(), 'reset_simulation')
        else:
            self._call(node.reset_client, node.trigger(), 'reset')
        self.state = self._next_state(with_estimate=with_estimate)
        self._external_synced = False
        return self.state

    def step(self, command: ArrayLike) -> SimState:
        """Send one command; return the state of the step it causes.

        After a :meth:`run` the plant first takes the step of your controller's answer to the
        run's last state (the record's last command), so the state returned is one step later.

        The command is three pressures (Pa, MCP, PIP, DIP), or with ``actuation='valves'`` six
        openings in [0, 1] (inlets MCP, PIP, DIP, then outlets).

        Raises
        ------
        ValueError
            If ``command`` is not three finite numbers (valves: six in [0, 1]).
        GloveSimError
            If another node publishes this glove's commands (use :meth:`run` for that), or the
            glove does not answer within ``timeout``.
        """
        values = np.asarray(command, dtype=float)
        if self.actuation == 'valves':
            try:
                values = valve_openings(values.ravel().tolist(), 'command')
            except InvalidInputError as error:
                raise ValueError(f'{error} (got {command!r})') from None
        elif values.shape != (3,) or not np.isfinite(values).all():
            raise ValueError(f'command must be three finite pressures in Pa, got {command!r}')
        if self._node.other_controllers():
            raise GloveSimError(
                f'another node publishes {self.namespace}/{self._node.command_topic}: a test '
                'cannot step the glove beside it; use run() for an external controller'
            )
        self._set_paused(False)
        if self._external_synced:  # the plant took the run's last answer: it steps with it first
            self._next_state()
        self._node.send(values)
        self.state = self._next_state()
        # the plant's record of our command, which a later run must not count as an answer
        self._wait(
            lambda: self._node.command_count() >= 1, 'the plant to report the command it applied'
        )
        self._node.clear_commands()
        self._external_synced = False
        return self.state

    # -- an external controller node -------------------------------------------------------

    def run(self, seconds: float) -> SimRecord:
        """Step in lockstep with your controller node for exactly ``seconds`` simulated seconds.

        The controller must answer every ``joint_states`` with one command (``pressure_command``,
        or ``valve_command`` with valves). The
        first run after :meth:`reset` or :meth:`step` starts with a fresh state (one step with
        the latest command) so that a node started since sees a state to answer; later runs go
        on exactly where the last one stopped. Start your node after ``reset()``. The plant
        runs at most 400 steps ahead of the states this client has received (its ``run_until``,
        :mod:`exodigit_nodes.runner.horizon`), so no state is lost on a loaded machine.

        Returns
        -------
        SimRecord
            The ``round(seconds · rate_hz)`` steps of the run and the commands the plant took
            in answer (``applied_command``: a refused answer leaves the command before).

        Raises
        ------
        GloveSimError
            If the controller or the plant does not go on within ``timeout``; the plant's
            ``run_until`` is reset and the plant paused first, so this client can go on stepping
            it (also past the end the run was to have).
        """
        steps = round(seconds * self.rate_hz)
        if not (math.isfinite(seconds) and steps >= 1):
            raise ValueError(f'seconds = {seconds!r}: must give at least one step')
        controllers = self._wait(
            self._node.other_controllers,
            f'your controller to publish {self._node.command_topic}',
        )
        self._set_paused(True)
        synced, self._external_synced = self._external_synced, False  # until this run is whole
        if not synced:
            self._wait_matched(controllers)
        end_ns = self._node.time_ns(self.state.t) + round(steps * 1e9 / self.rate_hz)
        states = []
        self._node.clear_commands()
        if not synced:
            self._call(self._node.step_client, self._node.trigger(), 'step')
            states.append(self._next_state(with_estimate=False))
        self._lockstep(end_ns, states, steps, answers=steps)
        commands = self._node.take_commands(steps)
        self._external_synced = True
        self.state = states[-1]
        return SimRecord(
            **state_arrays(states),
            command=np.array(commands),
        )
