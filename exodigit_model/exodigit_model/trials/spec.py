"""What a virtual patient trial is: a population, a protocol, a controller and the settings.

A :class:`TrialSpec` holds names, numbers and file paths only, so it pickles to any process
(the shards of a trial run wherever an engine sends them, docs/trials.md, "Runner") and every
process makes the same objects from it: the population, the protocol, the glove, the
simulation and metric settings. Everything is checked when the spec is made, with a
``ValueError`` naming the field and the rule.

>>> from exodigit_model.trials import ControllerSpec, TrialSpec
>>> spec = TrialSpec(population='stroke_mild', patients=200, protocol='grasp',
...                  controller=ControllerSpec('mode', 'position'))
>>> spec.session().steps, spec.shards
(6000, 1)
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import shlex
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from ..control import ValveLoopSettings
from ..physics.params import GloveParams, load_params
from ..physics.populations import Population, load_population
from ..stepping.settings import ACTUATIONS, SimulationSettings
from .metrics import DEFAULT_FORCE_LIMIT, MetricSettings
from .protocols import SessionProtocol, make_protocol

CONTROLLER_KINDS = {
    'mode': 'a built-in mode of pressure_command behind its safety limiter',
    'controller': "a user's BatchController: 'module:attribute' naming its factory",
    'policy': "a Gymnasium policy: 'module:attribute' naming its factory, run by PolicyController",
    'ros': "a ROS node: its command line, run through exodigit_nodes' testing kit (KitEngine)",
}
"""The kinds of controller a trial can step, each with what its ``name`` is."""

DEFAULT_SHARD_SIZE = 1000
"""Patients stepped as one batch by default: 1,000 gloves keep the compiled stepper near its
best speed per glove while a shard's arrays stay small (docs/trials.md, "Runner")."""

Parameters = tuple[tuple[str, Any], ...]
"""Named values as sorted (name, value) pairs: hashable and picklable, unlike a mapping."""


def frozen_parameters(name: str, values: Mapping[str, Any] | Parameters) -> Parameters:
    """``values`` as sorted (name, value) pairs, lists made tuples; a ValueError if not named.

    Parameters
    ----------
    name : str
        The field, for messages.
    values : mapping or sequence of pairs
        Parameter names (str) to values.
    """
    pairs = values.items() if isinstance(values, Mapping) else values
    try:
        items = {key: _frozen(value) for key, value in pairs}
    except (TypeError, ValueError):
        raise ValueError(f'{name} = {values!r}: must map parameter names to values') from None
    for key in items:
        if not isinstance(key, str) or not key.isidentifier():
            raise ValueError(f'{name}: parameter name {key!r} must be an identifier')
    return tuple(sorted(items.items()))


def _frozen(value: Any) -> Any:
    return tuple(_frozen(item) for item in value) if isinstance(value, list | tuple) else value


def load_attribute(reference: str) -> Any:
    """The object ``module:attribute`` names; ``module`` may also be the path of a .py file.

    Raises
    ------
    ValueError
        If the reference is not of that form, the module cannot be imported (with the reason)
        or has no such attribute.
    """
    module_name, _, attribute = reference.rpartition(':')
    if not module_name or not attribute.isidentifier():
        raise ValueError(
            f'{reference!r}: must be module:attribute (e.g. my_package.controllers:make, or '
            'path/to/file.py:make)'
        )
    try:
        if module_name.endswith('.py'):
            location = importlib.util.spec_from_file_location(Path(module_name).stem, module_name)
            if location is None or not Path(module_name).is_file():
                raise ImportError(f'no file {module_name}')
            module = importlib.util.module_from_spec(location)
            location.loader.exec_module(module)
        else:
            module = importlib.import_module(module_name)
    except Exception as error:  # a user's module may raise anything while it loads
        raise ValueError(
            f'{reference!r}: cannot import {module_name}: {type(error).__name__}: {error}'
        ) from None
    if not hasattr(module, attribute):
        raise ValueError(f'{reference!r}: module {module_name} has no attribute {attribute!r}')
    return getattr(module, attribute)


@dataclass(frozen=True)
class ControllerSpec:
    """The controller of a trial, by name (built where the shard runs).

    Attributes
    ----------
    kind : str
        One of :data:`CONTROLLER_KINDS`: ``mode``, ``controller``, ``policy`` or ``ros``.
    name : str
        A mode of :data:`~.controllers.MODE_PARAMETERS` (``staircase``, ``sine``, ``hold``,
        ``position``, ``force``), ``module:attribute`` naming the factory of a user's
        controller or policy (``module`` may be a ``.py`` file's path), or the command line
        of a ROS node (``ros``, split as a shell does, e.g. ``'ros2 run my_pkg my_node'``).
    parameters : mapping of str to value, or sorted pairs
        A mode's parameters over its defaults (``pressure_command``'s names, SI), the keyword
        arguments of the factory, or the ROS node's parameters (``-p name:=value``). Kept as
        sorted pairs.

    Raises
    ------
    ValueError
        For an unknown kind or mode, a mode parameter unknown or out of its range, a
        factory that cannot be imported or is not callable, or an empty or unbalanced
        command line.

    Notes
    -----
    Only ``exodigit_nodes.testing.trial_engine.KitEngine`` runs a ``ros`` controller (the
    in-process engines step the others and refuse it); this package never imports ROS.
    """

    kind: str = 'mode'
    name: str = 'sine'
    parameters: Parameters = ()

    def __post_init__(self) -> None:
        """Check the kind, the name and (for a mode) the parameters; import a factory."""
        if self.kind not in CONTROLLER_KINDS:
            raise ValueError(
                f'controller kind {self.kind!r}: unknown (known: {", ".join(CONTROLLER_KINDS)})'
            )
        if not isinstance(self.name, str):
            raise ValueError(f'controller name {self.name!r}: must be a string')
        object.__setattr__(
            self, 'parameters', frozen_parameters('controller parameters', self.parameters)
        )
        if self.kind == 'mode':
            from .controllers import mode_settings

            mode_settings(self.name, dict(self.parameters))
        elif self.kind == 'ros':
            self.command()
        else:
            self.factory()

    def command(self) -> list[str]:
        """The argv of a ROS node controller (kind ``ros``): ``name`` split as a shell does."""
        try:
            argv = shlex.split(self.name)
        except ValueError as error:
            raise ValueError(f'ROS controller command {self.name!r}: {error}') from None
        if not argv:
            raise ValueError('ROS controller command: empty; give the command that starts it')
        return argv

    def factory(self) -> Callable[..., Any]:
        """The user's factory named by ``name`` (kinds ``controller`` and ``policy``)."""
        factory = load_attribute(self.name)
        if not callable(factory):
            raise ValueError(f'{self.name!r}: is not callable (it must be a factory)')
        return factory

    def __str__(self) -> str:
        """``kind name key=value ...``, for reports."""
        settings = ''.join(f' {key}={value!r}' for key, value in self.parameters)
        return f'{self.kind} {self.name}{settings}'


@dataclass(frozen=True, kw_only=True)
class TrialSpec:
    """A virtual patient trial: who, what session, which controller, on which glove.

    Attributes
    ----------
    population : str
        A shipped population (:data:`~.populations.POPULATIONS`) or the path of a population
        file (docs/populations.md).
    patients : int
        N, patients drawn from the population (>= 1): patients 0 … N − 1 of
        ``population.sample(N, seed)``.
    seed : int
        Seed of the patients and of the shards' noise and controller generators (>= 0).
    protocol : str
        A session protocol of :data:`~.protocols.PROTOCOLS`.
    protocol_parameters : mapping of str to value, or sorted pairs
        The protocol's parameters over its defaults (``duration``, ``rate_hz``, ...).
    controller : ControllerSpec
        What commands the gloves (default: the ``sine`` mode with the node's defaults).
    params_file : str or None
        A glove parameter file (docs/spec/model.md §10); None: the defaults. Its finger is the
        nominal one the controllers know and lends the patients its link lengths.
    simulation : SimulationSettings or None
        Chamber lag, supply and sensor noise; None: the plant's defaults. Its ``rate_hz`` must
        be the protocol's; its ``seed`` is not used (each shard has its own, see
        :meth:`shard_seeds`).
    force_limit : float
        The force limit of the metric ``time_over_force_s``, N (> 0).
    shard_size : int
        Patients stepped as one batch (>= 1); the last shard takes what is left.
    actuation : str
        How the gloves' chambers are driven, one of
        :data:`~exodigit_model.stepping.simulation.ACTUATIONS`: ``regulator`` (default: the
        controller's pressure commands are the chambers') or ``valves`` (docs/spec/model.md §14:
        they are the targets of :class:`~exodigit_model.control.ValveLoop`, which opens each
        glove's six valves on its measured pressures, as ``pressure_command`` with
        ``output:=valves``; a mode's ``valve_deadband``, ``valve_kp``, ``valve_ki`` set it). In
        process only: a ``ros`` controller is refused.

    Raises
    ------
    ValueError
        Naming the field and what is wrong: an unknown population or protocol, a bad file, a
        parameter outside its rule, a count or seed that is not a whole number in range.
    """

    population: str = 'stroke_moderate'
    patients: int = 100
    seed: int = 0
    protocol: str = 'cpm'
    protocol_parameters: Parameters = ()
    controller: ControllerSpec = field(default_factory=ControllerSpec)
    params_file: str | None = None
    simulation: SimulationSettings | None = None
    force_limit: float = DEFAULT_FORCE_LIMIT
    shard_size: int = DEFAULT_SHARD_SIZE
    actuation: str = 'regulator'

    def __post_init__(self) -> None:
        """Check every field by making what it names."""
        for name, low in (('patients', 1), ('seed', 0), ('shard_size', 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f'{name} = {value!r}: must be a whole number >= {low}')
        if not isinstance(self.controller, ControllerSpec):
            raise ValueError(f'controller = {self.controller!r}: must be a ControllerSpec')
        object.__setattr__(
            self,
            'protocol_parameters',
            frozen_parameters('protocol_parameters', self.protocol_parameters),
        )
        self.load_population()
        self.glove_params()
        protocol = self.session()
        if self.simulation is not None:
            if not isinstance(self.simulation, SimulationSettings):
                raise ValueError(f'simulation = {self.simulation!r}: must be SimulationSettings')
            if not math.isclose(self.simulation.rate_hz, protocol.rate_hz):
                raise ValueError(
                    f'simulation.rate_hz = {self.simulation.rate_hz:g} Hz differs from the '
                    f"protocol's rate_hz = {protocol.rate_hz:g} Hz: the protocol sets the rate"
                )
        self.metric_settings()
        self._check_actuation()

    def _check_actuation(self) -> None:
        """Refuse an unknown actuation, valve parameters without valves, or valves over ROS."""
        if self.actuation not in ACTUATIONS:
            raise ValueError(
                f'actuation = {self.actuation!r}: must be one of {", ".join(ACTUATIONS)}'
            )
        controller = self.controller
        if self.actuation == 'valves' and controller.kind == 'ros':
            raise ValueError(
                "actuation = 'valves': runs in process only, not with a ros controller"
            )
        from .controllers import VALVE_PARAMETERS

        given = [name for name, _ in controller.parameters if name in VALVE_PARAMETERS]
        if self.actuation == 'regulator' and controller.kind == 'mode' and given:
            raise ValueError(
                f"controller parameter {given[0]!r}: a valve loop's, only with actuation 'valves'"
            )

    def valve_loop(self) -> ValveLoopSettings:
        """The valve loop's settings: a mode's valve parameters over the defaults."""
        if self.controller.kind != 'mode':
            return ValveLoopSettings()
        from .controllers import mode_settings

        return mode_settings(self.controller.name, dict(self.controller.parameters)).valve_loop

    @property
    def shards(self) -> int:
        """The number of shards, ⌈patients / shard_size⌉."""
        return -(-self.patients // self.shard_size)

    def load_population(self) -> Population:
        """The population the patients are drawn from."""
        return load_population(self.population)

    def glove_params(self) -> GloveParams:
        """The glove's parameters: the file's over the defaults, or the defaults."""
        return load_params(self.params_file)

    def session(self) -> SessionProtocol:
        """The session protocol with its parameters."""
        return make_protocol(self.protocol, **dict(self.protocol_parameters))

    def simulation_settings(self, seed: int) -> SimulationSettings:
        """The simulation's settings at the protocol's rate, with the noise seed ``seed``."""
        base = SimulationSettings() if self.simulation is None else self.simulation
        return replace(base, rate_hz=self.session().rate_hz, seed=seed)

    def metric_settings(self) -> MetricSettings:
        """The metrics' settings: the protocol's rate and the force limit."""
        return MetricSettings(rate_hz=self.session().rate_hz, force_limit=self.force_limit)

    def summary(self) -> dict[str, Any]:
        """The spec as plain values for JSON (the report's ``spec``)."""
        protocol = self.session()
        return {
            'population': self.population,
            'patients': self.patients,
            'seed': self.seed,
            'protocol': self.protocol,
            'protocol_parameters': dict(self.protocol_parameters),
            'duration_s': protocol.duration,
            'rate_hz': protocol.rate_hz,
            'controller': {
                'kind': self.controller.kind,
                'name': self.controller.name,
                'parameters': dict(self.controller.parameters),
            },
            'params_file': self.params_file,
            'simulation': None if self.simulation is None else asdict(self.simulation),
            'force_limit_n': self.force_limit,
            'shard_size': self.shard_size,
            'actuation': self.actuation,
        }
