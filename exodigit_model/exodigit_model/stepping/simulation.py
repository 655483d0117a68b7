"""Stepping the glove in time (docs/spec/model.md §13): the one stepper behind every simulation.

The model is quasi-static; time enters through the chambers' lag and the sensors. One step of
length Δt = 1/``rate_hz`` from the state at t_{k−1}:

1. chambers: exact zero-order-hold lag toward the command clipped to the supply range
   (:mod:`.chambers`);
2. the coupled solve (eq 36, or 11.4 with the patient's damping and spasticity: q̇ =
   (q − q_prev)/Δt inside the equation) at the new pressures and the patient's effort,
   warm-started from the last converged solution, or from where its smooth motion goes on
   (:func:`.kernels.stepping.predict`); a solve that does not converge keeps the last good state
   and says so;
3. q̇ = (q − q_prev)/Δt, and the measured angles and pressures with seeded Gaussian noise (the
   true state is never noisy).

:class:`GloveSimulation` steps one glove, or ``count`` independent gloves in one vectorised solve
per step, or a population: one glove per patient, the exo-digit shared and each glove on its own
finger (``fingers``). The ROS plant, the in-process API and the Gymnasium environment all use
it, so they cannot disagree.

Behind valves (``actuation='valves'``, docs/spec/model.md §14) the command of a step is six
openings in [0, 1], u_in then u_out (MCP, PIP, DIP), held over the step: step 1 integrates the
chambers' air masses through the valves instead of the lag, and step 2 solves the statics with
the pressures of the gas law at those masses (:mod:`.kernels.valves` has the scheme and its
order). The state then also has the air masses and the chambers' volumes.

>>> from exodigit_model import GloveSimulation
>>> simulation = GloveSimulation(settings=SimulationSettings(pressure_time_constant=0.0))
>>> state = simulation.step([30e3, 30e3, 30e3])
>>> round(state.t, 3), bool(state.q[0] > 0.2)
(0.01, True)
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..kernels.solves import rest_rows
from ..kernels.stepping import run_glove, step_gloves, step_one
from ..kernels.valves import (
    AIR_GAS,
    AIR_VOLUME,
    AIR_VOLUME_PER_ANGLE,
    AIR_VOLUME_PER_STRAIN,
    GAS_MASS,
    GAS_VOLUME,
)
from ..physics.model import VALID_STRETCH, GloveModel, as_joint_rows, as_joint_vector
from ..physics.params import Finger
from ..physics.patient import finger_rows
from ..physics.pneumatics import ATMOSPHERIC_PRESSURE, air_constants
from ..physics.solver import CONVERGED_STEP
from .chambers import Chambers, Saturation
from .settings import (
    ACTUATIONS,
    FIXED_SETTINGS,
    NANOSECONDS,
    OPENINGS,
    SimulationSettings,
    step_time_ns,
)


class GloveState(NamedTuple):
    """The glove (or N gloves) at the end of a step; arrays (3,) or (N, 3), SI units.

    A named tuple: cheap to build at every step. Its arrays are the simulation's own and are
    never changed afterwards (a step makes new ones): read them, do not write to them.

    Attributes
    ----------
    step : int
        k: steps taken since the simulation was made (``reset`` does not rewind it).
    t : float
        Simulated time t_k, s (``time_ns`` · 1e-9).
    time_ns : int
        t_k, ns.
    command : ndarray
        The pressure command the step applied, after saturation, Pa; behind valves the
        openings, after clipping to [0, 1], shape (6,) or (N, 6).
    pressure : ndarray
        True chamber pressures, Pa.
    pressure_measured : ndarray
        Chamber pressures as the sensors report them, Pa.
    q : ndarray
        True joint angles, rad (the last good ones where the solve failed).
    q_measured : ndarray
        Joint angles as the sensors report them, rad.
    qdot : ndarray
        (q − q_prev)/Δt, rad/s.
    forces : ndarray
        Contact forces f (docs/spec/model.md §6), N.
    finger_torque : ndarray
        Torque the exo-digit applies to each finger joint, (J_H*)ᵀ f = τ_H (eq 11.1), N·m.
    lengths : ndarray
        ℓ_k, the segments' bottom-face arc lengths, m (docs/spec/model.md §12).
    effort : ndarray
        The patient's voluntary effort applied in the step, N·m.
    converged : bool or ndarray of bool
        Whether this step's solve converged (per glove for a batch).
    iterations : int or ndarray
        Newton steps of this step's solve.
    residual : float or ndarray
        Residual norm of this step's solve, N·m.
    in_valid_range : bool or ndarray of bool
        Whether every fibre's stretch lies in the model's validated range.
    in_range_of_motion : bool or ndarray of bool
        Whether every joint lies within the finger's range of motion (each glove's own).
    saturated : bool
        Whether the command had to be clipped to [0, max_supply_pressure] in this step (behind
        valves: an opening to [0, 1]).
    mass : ndarray or None
        The chambers' air masses, kg, behind valves (None with regulators).
    volume : ndarray or None
        The chambers' volumes (14.1), m³, behind valves (None with regulators).
    """

    step: int
    t: float
    time_ns: int
    command: NDArray[np.float64]
    pressure: NDArray[np.float64]
    pressure_measured: NDArray[np.float64]
    q: NDArray[np.float64]
    q_measured: NDArray[np.float64]
    qdot: NDArray[np.float64]
    forces: NDArray[np.float64]
    finger_torque: NDArray[np.float64]
    lengths: NDArray[np.float64]
    effort: NDArray[np.float64]
    converged: bool | NDArray[np.bool_]
    iterations: int | NDArray[np.int_]
    residual: float | NDArray[np.float64]
    in_valid_range: bool | NDArray[np.bool_]
    in_range_of_motion: bool | NDArray[np.bool_]
    saturated: bool
    mass: NDArray[np.float64] | None = None
    volume: NDArray[np.float64] | None = None


class GloveSimulation:
    """The glove stepped in time (docs/spec/model.md §13): one glove, or a batch of them.

    Parameters
    ----------
    model : GloveModel, optional
        The glove and finger; the defaults of docs/spec/model.md §10 when omitted.
    settings : SimulationSettings, optional
        Rate, chamber lag, supply, sensor noise and seed; the ROS plant's defaults when omitted.
    count : int, optional
        Number of independent gloves stepped together, all on the model's finger; omitted = one
        glove, whose arrays have shape (3,) (with ``count`` they have shape (count, 3), also for
        ``count=1``).
    fingers : sequence of Finger, optional
        A population: one glove per finger, each the model's exo-digit on that finger (the
        patient of docs/spec/model.md §11, e.g. ``Patients.fingers`` of
        :mod:`exodigit_model.trials`). Glove i steps as
        ``GloveSimulation(GloveModel(replace(model.params, finger=fingers[i])))`` would, bit for
        bit (sensor noise aside, see Notes). ``count`` may be left out; given, it must be
        ``len(fingers)``.
    actuation : str, optional
        One of :data:`ACTUATIONS`: ``'regulator'`` (a pressure command per chamber, §13) or
        ``'valves'`` (six openings, §14, with the model's ``pneumatics`` parameters; a supply
        pressure they leave open is ``max_supply_pressure``).

    Raises
    ------
    ValueError
        For a ``count`` that is not a positive integer, ``fingers`` that is not a non-empty
        sequence of :class:`~exodigit_model.physics.params.Finger`, both that disagree, or an
        unknown ``actuation``.

    Notes
    -----
    Every glove of a batch starts at rest (vented, on its own finger) and receives its own row
    of the command. The noise streams come from ``seed`` (numpy's SeedSequence): angles and
    pressures draw from two independent streams, in that order, every step; a batch draws its
    noise for all its gloves at once from the two streams of the batch, so a noisy glove of a
    batch does not equal a single glove of the same seed.
    """

    def __init__(
        self,
        model: GloveModel | None = None,
        settings: SimulationSettings | None = None,
        *,
        count: int | None = None,
        fingers: Iterable[Finger] | None = None,
        actuation: str = 'regulator',
    ) -> None:
        if actuation not in ACTUATIONS:
            raise ValueError(f'actuation = {actuation!r}: must be one of {", ".join(ACTUATIONS)}')
        if count is not None and (
            isinstance(count, bool) or not isinstance(count, int) or count < 1
        ):
            raise ValueError(f'count = {count!r}: must be a positive integer (or None)')
        self.model = GloveModel() if model is None else model
        self.fingers = None if fingers is None else _population(fingers, count)
        """Each glove's finger when the simulation was given ``fingers``, else None."""
        if self.fingers is not None:
            count = len(self.fingers)
        self.settings = SimulationSettings() if settings is None else settings
        self.count = count
        self.shape = (3,) if count is None else (count, 3)
        self.actuation = actuation
        self.valves = actuation == 'valves'
        self.command_shape = (*self.shape[:-1], OPENINGS) if self.valves else self.shape
        """The shape of a step's command: (3,) or (N, 3) pressures, or (6,) or (N, 6) openings."""
        self._air = self._air_constants()
        self._finger_rows = self._patients()
        rest = rest_rows(self.model.packed, *self._finger_rows, *VALID_STRETCH)
        self._rest = rest if count is not None else tuple(_last(value) for value in rest)
        self.period = self.settings.period
        self.chambers = Chambers(self.settings.chambers, self.period, self.shape)
        angle_stream, pressure_stream = np.random.SeedSequence(self.settings.seed).spawn(2)
        self._angle_noise = np.random.default_rng(angle_stream)
        self._pressure_noise = np.random.default_rng(pressure_stream)
        self.step_count = 0
        self.solver_failures = 0
        """Steps whose solve did not converge (the last good state was kept)."""
        self.state = self._rest_state()

    # -- configuration ---------------------------------------------------------------------

    def configure(self, **changes: float) -> None:
        """Change settings from the next step on (not ``rate_hz`` or ``seed``).

        Raises
        ------
        ValueError
            For an unknown or fixed setting, or a value that breaks its rule.
        """
        fixed = sorted(set(changes) & set(FIXED_SETTINGS))
        if fixed:
            raise ValueError(f'{fixed[0]} is fixed once the simulation exists')
        self.settings = replace(self.settings, **changes)
        self.chambers.configure(self.settings.chambers)
        self._air = self._air_constants()

    def _air_constants(self) -> NDArray[np.float64]:
        """The kernels' pneumatic constants: (3, AIR_COLUMNS) behind valves, else none."""
        if not self.valves:
            return np.empty((0, 3))
        return air_constants(self.model, self.settings.max_supply_pressure)

    # -- stepping --------------------------------------------------------------------------

    def reset(self) -> GloveState:
        """Vent the chambers and return every glove to rest; time goes on (not rewound).

        Returns the state at rest, at the current time (no step is taken).
        """
        self.chambers.reset()
        self.state = self._rest_state()
        return self.state

    def step(self, command: ArrayLike, effort: ArrayLike | None = None) -> GloveState:
        """Advance one step of Δt under the pressure ``command`` (Pa, shape (3,) or (N, 3)).

        Behind valves ``command`` is the six openings of each glove, shape (6,) or (N, 6):
        u_in of MCP, PIP, DIP, then u_out, held over the step and clipped to [0, 1].

        ``effort`` is the patient's voluntary effort u of eq 11.1 during the step (N·m, the
        shape of the command; None: none).

        Returns
        -------
        GloveState
            The state at t_{k+1}. Never raises for a solve that fails to converge: that glove
            keeps its last good state, and ``converged`` says so.

        Raises
        ------
        ValueError
            If ``command`` or ``effort`` has the wrong shape or a non-finite value.
        """
        command = self._openings(command) if self.valves else self._rows('command', command)
        effort = self._zeros if effort is None else self._rows('effort', effort)
        glove = self.model.packed
        gas = None
        if self.count is None and not self.valves:
            block, outcome = step_one(glove, self._block, command, effort, *self._stepping)
            self._block = block
            state, applied, qdot = _state_of(block), block[5, :3], block[6, :3]
            status, iterations, residual, valid, moving_range, below, above = outcome
        else:
            single = self.count is None  # behind valves one glove steps as a batch of one
            state, applied, qdot, status, iterations, residual, flags = step_gloves(
                glove,
                *self._finger_rows,
                self._air,
                self._kernel_state,
                command[None] if single else command,
                effort[None] if single else effort,
                *self._stepping,
            )
            self._kernel_state = state
            valid, moving_range = flags[:, 0], flags[:, 1]
            below, above = flags[:, 2].any(), flags[:, 3].any()
            if single:
                state, applied, qdot = tuple(value[0] for value in state), applied[0], qdot[0]
                status, iterations, residual = status.item(), iterations.item(), residual.item()
                valid, moving_range = valid.item(), moving_range.item()
            gas = state[6] if self.valves else None
        converged = status <= CONVERGED_STEP
        self.chambers.pressure, self.chambers.command = state[2], applied
        self.chambers.record(below, above)
        self.solver_failures += int(np.count_nonzero(~converged)) if self.count else not converged
        self.step_count += 1
        time_ns = step_time_ns(self.step_count, self.settings.rate_hz)
        q = state[0][..., :3]
        self.state = GloveState(
            step=self.step_count,
            t=time_ns / NANOSECONDS,
            time_ns=time_ns,
            command=applied,
            pressure=state[2],
            pressure_measured=self._measured(state[2], self._pressure_noise, 'pressure'),
            q=q,
            q_measured=self._measured(q, self._angle_noise, 'angle'),
            qdot=qdot,
            forces=state[3],
            finger_torque=state[4],
            lengths=self._lengths(state[0]),
            effort=effort,
            converged=converged,
            iterations=iterations,
            residual=residual,
            in_valid_range=valid,
            in_range_of_motion=moving_range,
            saturated=self.chambers.saturated_now,
        )
        if gas is not None:
            self.state = self.state._replace(
                mass=gas[..., GAS_MASS, :], volume=gas[..., GAS_VOLUME, :]
            )
        return self.state

    def run(self, commands: ArrayLike, efforts: ArrayLike | None = None) -> GloveState:
        """Take one step per row of ``commands`` (Pa) inside compiled code; every step's state.

        Exactly what as many calls of :meth:`step` give (the same states, noise and counts),
        without a Python call per step.

        Parameters
        ----------
        commands : array_like, shape (T, 3), or (T, N, 3) for a batch
            The pressure command of each step, Pa; behind valves the openings, (T, 6) or
            (T, N, 6).
        efforts : array_like, shape like ``commands``, optional
            The patient's voluntary effort of each step, N·m (None: none).

        Returns
        -------
        GloveState
            Every field with a leading axis of T (``step``, ``t``, ``time_ns``, ``converged``,
            … as arrays of T); :attr:`state` is the last step's.
        """
        rows = self._steps('commands', commands, self.command_shape)
        steps = (rows.shape[0], *self.shape)
        if efforts is None:
            efforts = np.zeros(steps)
        else:
            efforts = self._steps('efforts', efforts, self.shape)
            if efforts.shape != steps:
                raise ValueError(
                    f'efforts must have the shape {steps} (one row per step), got {efforts.shape}'
                )
        if self.count is not None:
            states = [self.step(rows[t], efforts[t]) for t in range(rows.shape[0])]
            return GloveState(*(_stacked(values) for values in zip(*states, strict=True)))
        if self.valves:
            start = tuple(np.ascontiguousarray(value[0]) for value in self._kernel_state)
        else:
            start = (*_state_of(self._block, contiguous=True), self._air)
        state, record = run_glove(
            self.model.packed, self._air, start, rows, efforts, *self._stepping
        )
        applied, pressure, qdot, forces, torque, x, status, iterations, residual, flags = record[
            :10
        ]
        gas = record[10] if self.valves else None
        if self.valves:
            self._kernel_state = tuple(value[None] for value in state)
        else:
            self._block = _block_of(state)
        self.chambers.pressure, self.chambers.command = state[2], applied[-1]
        self.chambers.saturation = Saturation(
            self.chambers.saturation.below_zero + int(np.count_nonzero(flags[:, 2])),
            self.chambers.saturation.above_supply + int(np.count_nonzero(flags[:, 3])),
        )
        self.chambers.saturated_now = bool(flags[-1, 2] or flags[-1, 3])
        converged = status <= CONVERGED_STEP
        self.solver_failures += int(np.count_nonzero(~converged))
        steps = np.arange(self.step_count + 1, self.step_count + 1 + rows.shape[0])
        self.step_count = int(steps[-1])
        time_ns = step_time_ns(steps, self.settings.rate_hz)
        q = x[:, :3]
        run = GloveState(
            step=steps,
            t=time_ns / NANOSECONDS,
            time_ns=time_ns,
            command=applied,
            pressure=pressure,
            pressure_measured=self._measured(pressure, self._pressure_noise, 'pressure'),
            q=q,
            q_measured=self._measured(q, self._angle_noise, 'angle'),
            qdot=qdot,
            forces=forces,
            finger_torque=torque,
            lengths=self._lengths(x),
            effort=efforts,
            converged=converged,
            iterations=iterations,
            residual=residual,
            in_valid_range=flags[:, 0],
            in_range_of_motion=flags[:, 1],
            saturated=flags[:, 2] | flags[:, 3],
            mass=None if gas is None else gas[:, GAS_MASS],
            volume=None if gas is None else gas[:, GAS_VOLUME],
        )
        self.state = GloveState(*(_last(value) for value in run))
        return run

    def _openings(self, value: ArrayLike) -> NDArray[np.float64]:
        """``value`` checked to the shape of the valves' openings (a ValueError), copied.

        A copy, writable: a read-only array (:data:`.settings.VENT`) would compile the kernels
        anew for its type.
        """
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            array = None
        if array is None or array.shape != self.command_shape:
            got = 'no array of numbers' if array is None else f'shape {array.shape}'
            raise ValueError(
                f'command must have shape {self.command_shape} (openings u_in then u_out of '
                f'MCP, PIP, DIP), got {got}'
            )
        if not np.all(np.isfinite(array)):
            raise ValueError('command must be finite')
        return array

    def _steps(self, name: str, value: ArrayLike, rows: tuple) -> NDArray[np.float64]:
        """``value`` as T >= 1 finite ``rows``, one per step, or a ValueError."""
        shape = ('T', *rows)
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            array = None
        if array is None or array.shape[1:] != rows or array.ndim != len(shape):
            got = 'no array of numbers' if array is None else f'shape {array.shape}'
            raise ValueError(f'{name} must have shape {shape} (one row per step), got {got}')
        if array.shape[0] == 0:
            raise ValueError(f'{name} must have at least one row (one step)')
        if not np.all(np.isfinite(array)):
            raise ValueError(f'{name} must be finite')
        return array

    def _lengths(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bottom-face lengths ℓ (m) of unknowns ``x`` (the rest lengths if inextensible).

        The model's :meth:`~.GloveModel._lengths_of`, except that a step of an inextensible
        glove gets the same read-only array every time instead of a copy.
        """
        if not self.model.extensible and x.shape == self.shape:
            return self._rest_lengths
        return self.model._lengths_of(x)

    def _rows(self, name: str, value: ArrayLike) -> NDArray[np.float64]:
        """``value`` checked to the shape of this simulation's commands."""
        if self.count is None:
            return as_joint_vector(name, value)
        rows = as_joint_rows(name, value)
        if rows.shape != self.shape:
            raise ValueError(f'{name} must have shape {self.shape}, got {rows.shape}')
        return rows

    def _measured(self, true: NDArray[np.float64], rng: np.random.Generator, sensor: str):
        """``true`` plus Gaussian noise of the ``<sensor>_noise_std`` setting from ``rng``.

        A quiet sensor (std 0) draws nothing, so turning one sensor's noise on leaves the
        other's stream untouched.
        """
        std = getattr(self.settings, f'{sensor}_noise_std')
        if std == 0.0:
            return true
        return true + rng.normal(0.0, std, true.shape)

    def _patients(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The kernels' finger constants of every glove: rows of link half lengths and laws."""
        if self.fingers is not None:
            return finger_rows(self.fingers)
        constants, rows = self.model.constants, self.count or 1
        return (
            np.tile(constants.finger_half_lengths, (rows, 1)),
            np.tile(constants.laws, (rows, 1, 1)),
        )

    def _rest_state(self) -> GloveState:
        """Every glove vented and at rest on its finger, at the current time (no step)."""
        zeros = np.zeros(self.shape)
        self._zeros = zeros
        self._rest_lengths = np.broadcast_to(self.model.constants.arc_lengths, self.shape)
        x, forces, torque, status, _, residual, valid, moving_range = self._rest
        q = x[..., :3]
        earlier = np.repeat(q[..., None, :], 2, axis=-2)  # still: the rest, two steps back
        gas = self._vented(x)
        state = (x, q.copy(), zeros, forces, torque, earlier, gas)
        if self.count is None and not self.valves:
            self._block = _block_of(state[:6])
        elif self.count is None:
            self._kernel_state = tuple(np.ascontiguousarray(value[None]) for value in state)
        else:
            self._kernel_state = state
        self.chambers.pressure = zeros
        self.chambers.command = np.zeros(self.command_shape)
        time_ns = step_time_ns(self.step_count, self.settings.rate_hz)
        return GloveState(
            step=self.step_count,
            t=time_ns / NANOSECONDS,
            time_ns=time_ns,
            command=self.chambers.command,
            pressure=zeros,
            pressure_measured=zeros,
            q=q,
            q_measured=q,
            qdot=zeros,
            forces=forces,
            finger_torque=torque,
            lengths=self._lengths(x),
            effort=zeros,
            converged=status <= CONVERGED_STEP,
            iterations=0 if self.count is None else np.zeros(self.count, int),
            residual=residual,
            in_valid_range=valid,
            in_range_of_motion=moving_range,
            saturated=False,
            mass=gas[..., GAS_MASS, :] if self.valves else None,
            volume=gas[..., GAS_VOLUME, :] if self.valves else None,
        )

    def _vented(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The air of gloves vented at unknowns ``x`` (:mod:`.kernels.valves`' ``gas``).

        Behind valves (..., GAS_ROWS, 3): the masses P_atm·V/(R·T) of the volumes (14.1) at
        ``x`` (computed as the kernels do), the volumes, and the same volumes a step before
        (still); with regulators (..., 0, 3).
        """
        if not self.valves:
            return np.empty((*x.shape[:-1], 0, 3))
        air = self._air
        volume = air[:, AIR_VOLUME] + air[:, AIR_VOLUME_PER_ANGLE] * x[..., :3]
        if self.model.extensible:
            volume = volume + air[:, AIR_VOLUME_PER_STRAIN] * x[..., 3:]
        mass = ATMOSPHERIC_PRESSURE * volume / air[:, AIR_GAS]
        return np.stack([mass, volume, volume], axis=-2)

    @property
    def _stepping(self) -> tuple:
        """The kernels' step constants: exp(−Δt/T), supply, 1/Δt and the valid stretch range."""
        return (
            self.chambers.decay,
            self.settings.max_supply_pressure,
            self.settings.rate_hz,
            *VALID_STRETCH,
        )


def _population(fingers: Iterable[Finger], count: int | None) -> tuple[Finger, ...]:
    """``fingers`` as a tuple of one or more Fingers agreeing with ``count``, or a ValueError."""
    try:
        population = tuple(fingers)
    except TypeError:
        population = None
    if not population:
        raise ValueError(
            f'fingers = {fingers!r}: must be a non-empty sequence of Finger, one per glove '
            '(e.g. Patients.fingers)'
        )
    for index, finger in enumerate(population):
        if not isinstance(finger, Finger):
            raise ValueError(
                f'fingers[{index}] = {finger!r}: must be a Finger (exodigit_model.Finger)'
            )
    if count is not None and count != len(population):
        raise ValueError(
            f'count = {count!r}: does not match the {len(population)} fingers (one glove per '
            'finger; count may be left out)'
        )
    return population


def _state_of(block: NDArray[np.float64], contiguous: bool = False) -> tuple:
    """One glove's state (x, q_before, pressure, forces, torque, earlier): views of its block.

    With ``contiguous``, ``earlier`` is C-contiguous (a copy where the block has six columns):
    one argument type for :func:`.kernels.stepping.run_glove`, which then compiles once.
    """
    earlier = np.ascontiguousarray(block[7:, :3]) if contiguous else block[7:, :3]
    return block[0], block[1, :3], block[2, :3], block[3, :3], block[4, :3], earlier


def _block_of(state: tuple) -> NDArray[np.float64]:
    """One glove's state as a block (9, n) (:func:`.kernels.stepping.step_one`)."""
    block = np.zeros((9, state[0].size))
    block[0] = state[0]
    for row, values in enumerate(state[1:5], start=1):
        block[row, :3] = values
    block[7:, :3] = state[5]
    return block


def _stacked(values: tuple):
    """One field of a batch's steps stacked along a leading axis (None where it is None)."""
    return None if values[0] is None else np.array(values)


def _last(value):
    """The last step's entry of one field of a run, as :meth:`GloveSimulation.step` gives it."""
    if value is None:
        return None
    last = value[-1]
    return last.item() if isinstance(last, np.generic) else last
