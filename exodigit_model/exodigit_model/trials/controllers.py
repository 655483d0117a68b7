"""The controller of a trial, made from its :class:`~.spec.ControllerSpec` where a shard runs.

Three kinds run in process (docs/trials.md, "Controllers"):

- ``mode``: a built-in mode of ``pressure_command`` behind its safety limiter
  (:class:`~exodigit_model.control.BuiltInMode`), with the node's parameter names and defaults
  (:data:`MODE_PARAMETERS`, :data:`COMMON_PARAMETERS`). The ``position`` mode tracks the
  protocol's targets, as the node tracks a ``joint_trajectory`` (:class:`ProtocolPosition`).
- ``controller``: a user's :class:`~exodigit_model.control.BatchController`, made by the factory
  ``module:attribute`` as ``factory(protocol=..., model=..., **parameters)``.
- ``policy``: a Gymnasium policy made by ``factory(env=..., **parameters)`` for a
  :class:`~exodigit_model.gym.env.GloveEnv` on the nominal glove whose target is the protocol's,
  behind the node's limits (:data:`~exodigit_model.gym.env.NODE_SAFETY`), run by
  :class:`~exodigit_model.gym.env.PolicyController` (needs the ``gym`` extra).

A fourth, ``ros`` (a ROS node's command line), runs through the testing kit of
``exodigit_nodes`` (``KitEngine``, docs/trials.md, "A ROS node as the controller");
:func:`build_controller` refuses it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..checks import check_flag, check_non_negative, check_number, check_positive
from ..control import (
    LIMIT_PARAMETERS,
    LOOP_PARAMETERS,
    MODE_DEFAULTS,
    BatchController,
    BuiltInMode,
    PositionController,
    SafetyLimits,
    ValveLoopSettings,
    mode_controller,
)
from ..physics.model import GloveModel, as_joint_vector
from ..stepping.settings import step_time_ns

if TYPE_CHECKING:
    from ..stepping.settings import SimulationSettings
    from ..stepping.simulation import GloveState
    from .protocols import SessionProtocol
    from .spec import ControllerSpec

Check = Callable[[str, Any], Any]
"""check(name, value) -> the value to use, or a ValueError naming the parameter."""


def _pressures(name: str, value: Any) -> tuple[float, ...]:
    pressures = as_joint_vector(name, value)
    if np.any(pressures < 0.0):
        raise ValueError(f'{name} = {value!r}: pressures must be >= 0 (Pa)')
    return tuple(pressures.tolist())


def _vector(name: str, value: Any) -> tuple[float, ...]:
    return tuple(as_joint_vector(name, value).tolist())


PASCAL = partial(check_non_negative, unit='Pa')
GAIN = partial(check_non_negative, unit='a gain')
SECONDS = partial(check_positive, unit='s')

CHECKS: Mapping[str, Check] = {
    'staircase_step': partial(check_positive, unit='Pa'),
    'staircase_peak': partial(check_positive, unit='Pa'),
    'step_duration': SECONDS,
    'sine_low': PASCAL,
    'sine_high': PASCAL,
    'sine_period': SECONDS,
    'hold_pressure': _pressures,
    'position_kp': GAIN,
    'position_ki': GAIN,
    'force_targets': _vector,
    'force_kp': GAIN,
    'force_ki': GAIN,
    'valve_deadband': PASCAL,
    'valve_kp': GAIN,
    'valve_ki': GAIN,
}
"""How a trial checks each mode parameter of :data:`exodigit_model.control.MODE_DEFAULTS`."""

MODE_PARAMETERS: Mapping[str, Mapping[str, tuple[Any, Check]]] = {
    mode: {name: (default, CHECKS[name]) for name, default in defaults.items()}
    for mode, defaults in MODE_DEFAULTS.items()
}
"""Per built-in mode, its parameters: (default, check). Names, units (SI) and defaults are the
``pressure_command`` node's: both read :data:`exodigit_model.control.MODE_DEFAULTS`."""

_LIMITS = SafetyLimits()

VALVE_PARAMETERS = LOOP_PARAMETERS
"""The valve loop's parameters (``pressure_command``'s with ``output:=valves``): a mode's pressure
commands become openings through :class:`~exodigit_model.control.ValveLoop` in a trial with
``actuation='valves'``, which alone takes them."""

_VALVE_LOOP = ValveLoopSettings()

COMMON_PARAMETERS: Mapping[str, tuple[Any, Check]] = {
    **{
        name: (getattr(_LIMITS, field_name), _vector if name.startswith('joint') else check_number)
        for name, field_name in LIMIT_PARAMETERS.items()
    },
    'estimate_forces': (False, check_flag),
}
"""Parameters of every mode: the node's safety limits (SafetyLimits checks them together) and
``estimate_forces``: whether the limiter gets the nominal model's robot-side force estimate
(the ``estimator`` node's; 2 µs per glove and step), so it backs off above
``max_contact_force``. Without it the limiter checks the range of motion only, as the node
without an estimator. The ``force`` mode always estimates (its feedback)."""

VALVE_LOOP_PARAMETERS: Mapping[str, tuple[Any, Check]] = {
    name: (getattr(_VALVE_LOOP, name), CHECKS[name]) for name in VALVE_PARAMETERS
}
"""Parameters of every mode behind valves: the valve loop's (default, check)."""


@dataclass(frozen=True)
class ModeSettings:
    """A built-in mode with every parameter checked and its defaults filled in.

    Attributes
    ----------
    mode : str
        The mode, a key of :data:`MODE_PARAMETERS`.
    values : mapping of str to value
        The mode's parameters and the common ones, SI.
    limits : SafetyLimits
        The limiter's limits.
    estimate_forces : bool
        Whether the limiter (and the force mode) gets the force estimate.
    valve_loop : ValveLoopSettings
        The valve loop's deadband and gains (used behind valves only).
    """

    mode: str
    values: Mapping[str, Any]
    limits: SafetyLimits
    estimate_forces: bool
    valve_loop: ValveLoopSettings


def mode_settings(mode: str, parameters: Mapping[str, Any]) -> ModeSettings:
    """Check a built-in mode's ``parameters`` and fill in the defaults.

    Raises
    ------
    ValueError
        For an unknown mode or parameter (the message lists the known ones), or a value that
        breaks its rule.
    """
    if mode not in MODE_PARAMETERS:
        raise ValueError(f'mode {mode!r}: unknown (known: {", ".join(MODE_PARAMETERS)})')
    known = {**MODE_PARAMETERS[mode], **COMMON_PARAMETERS, **VALVE_LOOP_PARAMETERS}
    unknown = sorted(set(parameters) - set(known))
    if unknown:
        raise ValueError(
            f'mode {mode!r}: unknown parameter {unknown[0]!r} (known: {", ".join(known)})'
        )
    values = {
        name: check(name, parameters[name]) if name in parameters else default
        for name, (default, check) in known.items()
    }
    limits = SafetyLimits(**{field: values[name] for name, field in LIMIT_PARAMETERS.items()})
    loop = ValveLoopSettings(**{name: values[name] for name in VALVE_PARAMETERS})
    return ModeSettings(mode, values, limits, values['estimate_forces'] or mode == 'force', loop)


class ProtocolPosition(BuiltInMode):
    """The ``position`` mode tracking the protocol: answering step k it targets q*(t_k+1).

    Before each command the targets become the protocol's trajectory
    (:meth:`~.protocols.SessionProtocol.trajectory`) sampled at the end of the coming step, as
    ``pressure_command`` samples the ``joint_trajectory`` the testing kit sends it (the one
    interpolation of :mod:`exodigit_model.control.trajectory`); the feed-forward is recomputed.
    """

    def __init__(
        self,
        controller: PositionController,
        limits: SafetyLimits,
        *,
        estimator: GloveModel | None,
        protocol: SessionProtocol,
    ) -> None:
        super().__init__(controller, limits, estimator=estimator)
        self.protocol = protocol
        self.trajectory = protocol.trajectory()

    def command(self, t: float, dt: float, state: GloveState) -> NDArray[np.float64]:
        """Track q*(t_k+1) (``state.step`` = k), then :meth:`BuiltInMode.command`."""
        end = step_time_ns(state.step + 1, self.protocol.rate_hz)
        self.loop.controller.set_targets(self.trajectory.at_ns(end))
        return super().command(t, dt, state)


def built_in_mode(
    settings: ModeSettings, *, protocol: SessionProtocol, model: GloveModel
) -> BuiltInMode:
    """The built-in mode of ``settings`` behind its limiter, on the nominal ``model``."""
    controller = mode_controller(
        settings.mode, settings.values, lambda: model, protocol.targets(0.0)
    )
    estimator = model if settings.estimate_forces else None
    if settings.mode == 'position':
        return ProtocolPosition(
            controller, settings.limits, estimator=estimator, protocol=protocol
        )
    return BuiltInMode(controller, settings.limits, estimator=estimator)


def build_controller(
    spec: ControllerSpec,
    *,
    protocol: SessionProtocol,
    model: GloveModel,
    settings: SimulationSettings,
) -> BatchController:
    """The trial's controller (not yet reset): a built-in mode, a user's, or a policy's.

    Parameters
    ----------
    spec : ControllerSpec
        Which controller, with its parameters.
    protocol : SessionProtocol
        The session: its targets are the position mode's and a policy's.
    model : GloveModel
        The nominal glove, the one a controller knows (not the patients').
    settings : SimulationSettings
        The simulation's settings (a policy's environment observes with them).

    Raises
    ------
    ValueError
        If a factory raises, or does not return a BatchController (or a callable policy), or
        for a ``ros`` controller (it runs through exodigit_nodes' KitEngine).
    """
    parameters = dict(spec.parameters)
    if spec.kind == 'ros':
        raise ValueError(
            f'{spec.name!r} is a ROS node: it runs through the testing kit of exodigit_nodes '
            '(exodigit_nodes.testing.trial_engine.KitEngine, python -m exodigit_nodes.trial), '
            'not in process'
        )
    if spec.kind == 'mode':
        return built_in_mode(mode_settings(spec.name, parameters), protocol=protocol, model=model)
    factory = spec.factory()
    if spec.kind == 'controller':
        controller = _call(spec, factory, protocol=protocol, model=model, **parameters)
        if not isinstance(controller, BatchController):
            raise ValueError(
                f'{spec.name}: returned {type(controller).__name__}, not a BatchController '
                '(an object with reset(count, rng) and command(t, dt, state))'
            )
        return controller
    try:
        from ..gym.env import NODE_SAFETY, GloveEnv, PolicyController
    except ImportError:
        raise ValueError('a policy needs Gymnasium: pip install "./exodigit_model[gym]"') from None
    env = GloveEnv(model, settings=settings, target=protocol.targets, safety=NODE_SAFETY)
    return PolicyController(_call(spec, factory, env=env, **parameters), env)


def _call(spec: ControllerSpec, factory: Callable[..., Any], **arguments: Any) -> Any:
    """``factory(**arguments)``, its failure a ValueError naming the factory."""
    try:
        return factory(**arguments)
    except Exception as error:  # a user's factory may raise anything
        raise ValueError(f'{spec.name}: failed: {type(error).__name__}: {error}') from error


def limiter_acted(controller: BatchController, count: int) -> NDArray[np.bool_] | bool:
    """Whether the controller's safety limiter changed each glove's last command, (N,).

    A controller reports it as the built-in ones do: ``controller.last.acted``, (N, k) bools
    (a limit per column). One without it (``last`` missing or None) reports no intervention.
    """
    acted = getattr(getattr(controller, 'last', None), 'acted', None)
    if acted is None:
        return False
    acted = np.asarray(acted, dtype=bool)
    return acted.reshape(count, -1).any(axis=1)
