"""The chambers' air behind valves (docs/spec/model.md §14): constants, parameters, functions.

Absolute pressures P = p + P_atm inside (p: the gauge pressures the rest of the package uses);
isothermal air at ``temperature``; chamber i's state is its air mass m_i (kg). The equations
(14.1)-(14.4) and how a step integrates them are in :mod:`.kernels.valves`, whose compiled
functions these wrap. The ``pneumatics`` section of a parameter file
(``default_params.yaml``) becomes :class:`Pneumatics`.

>>> round(mass_flow(5e-10, 0.3, 400e3, ATMOSPHERIC_PRESSURE, 293.15) * 1e6, 3)  # choked, mg/s
237.0
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import (
    ParameterError,
    check_name,
    check_non_negative,
    check_number,
    check_positive,
    check_three,
    set_field,
)
from ..kernels.flow_regions import LAMINAR_RATIO
from .validity import OutsideModelWarning

if TYPE_CHECKING:
    from .model import GloveModel
    from .params import Segment

ATMOSPHERIC_PRESSURE = 101325.0
"""P_atm, Pa: gauge pressure p = P − P_atm."""
GAS_CONSTANT = 287.05
"""R of dry air, J/(kg·K)."""
REFERENCE_DENSITY = 1.185
"""ρ0 of ISO 6358 (ANR), kg/m³."""
REFERENCE_TEMPERATURE = 293.15
"""T0 of ISO 6358, K."""
VALIDATED_AIR = {
    'inlet_conductance': (1e-10, 2e-9, 'm^3/(s Pa)'),
    'outlet_conductance': (1e-10, 2e-9, 'm^3/(s Pa)'),
    'inlet_critical_ratio': (0.05, 0.6, ''),
    'outlet_critical_ratio': (0.05, 0.6, ''),
    'dead_volume': (1e-7, 5e-6, 'm^3'),
    'leak_conductance': (0.0, 1e-11, 'kg/(s Pa)'),
    'supply_pressure': (30e3, 200e3, 'Pa'),
}
"""The box of valves, tubing and supplies the valve mode's stepping is checked in (key: low,
high, unit; docs/valves.md, "Where the bound holds"): within it every pressure lies within
0.5 kPa of the reference at 50, 100 and 200 Hz (tests/test_model_valves_corners.py). A value
outside is taken, with an :class:`~exodigit_model.physics.validity.OutsideModelWarning` naming its
key (:func:`warn_outside_validated`)."""


@dataclass(frozen=True)
class ChamberAir:
    """One chamber's valves, dead volume and leak (docs/spec/model.md §14), SI.

    Attributes
    ----------
    name : str
        Label of the chamber's joint.
    inlet_conductance, outlet_conductance : float
        C of the inlet (from the supply) and outlet (to the atmosphere) valve fully open,
        m³/(s·Pa) (14.3).
    inlet_critical_ratio, outlet_critical_ratio : float
        b of each valve, in [0, 0.999): the pressure ratio at which its flow chokes.
    dead_volume : float
        V_d, the volume of the chamber's tubing and fittings, m³ (14.1).
    leak_conductance : float
        G of (14.4), kg/(s·Pa): the leak to the atmosphere.
    """

    name: str
    inlet_conductance: float
    inlet_critical_ratio: float
    outlet_conductance: float
    outlet_critical_ratio: float
    dead_volume: float
    leak_conductance: float

    def __post_init__(self) -> None:
        set_field(self, 'name', check_name('name', self.name))
        units = {
            'inlet_conductance': 'm^3/(s Pa)',
            'outlet_conductance': 'm^3/(s Pa)',
            'dead_volume': 'm^3',
            'leak_conductance': 'kg/(s Pa)',
        }
        for key, unit in units.items():
            set_field(self, key, check_non_negative(key, getattr(self, key), unit))
        for key in ('inlet_critical_ratio', 'outlet_critical_ratio'):
            value = check_number(key, getattr(self, key))
            if not 0.0 <= value < LAMINAR_RATIO:
                raise ParameterError(f'{key} = {value!r}: must lie in [0, {LAMINAR_RATIO})')
            set_field(self, key, value)


@dataclass(frozen=True)
class Pneumatics:
    """The supply, the air's temperature and the three chambers (MCP, PIP, DIP).

    Attributes
    ----------
    supply_pressure : float or None
        p_s, the supply's gauge pressure, Pa; None: the simulation's ``max_supply_pressure``.
    temperature : float
        T of the (isothermal) air, K.
    chambers : tuple of ChamberAir
        Exactly three, in joint order.
    """

    supply_pressure: float | None
    temperature: float
    chambers: tuple[ChamberAir, ...]

    def __post_init__(self) -> None:
        if self.supply_pressure is not None:
            value = check_non_negative('supply_pressure', self.supply_pressure, 'Pa, or null')
            set_field(self, 'supply_pressure', value)
        set_field(self, 'temperature', check_positive('temperature', self.temperature, 'K'))
        set_field(self, 'chambers', check_three('chambers', self.chambers, ChamberAir))


def flow_function(r: float, critical: float) -> float:
    """ψ(r) of (14.3) for the critical ratio b = ``critical``, 0 ≤ r ≤ 1."""
    from ..kernels.valves import flow_function_of

    return flow_function_of(float(r), float(critical))


def density_factor(temperature: float) -> float:
    """ρ0·√(T0/T), kg/m³: the density that turns a conductance into a mass flow (14.3)."""
    return REFERENCE_DENSITY * math.sqrt(REFERENCE_TEMPERATURE / temperature)


def mass_flow(
    conductance: float, critical: float, upstream: float, downstream: float, temperature: float
) -> float:
    """Q(P_u, P_d) of (14.3), kg/s: absolute pressures (Pa), C in m³/(s·Pa), T in K.

    Antisymmetric: Q(P_d, P_u) = −Q(P_u, P_d).
    """
    from ..kernels.valves import flow_of

    return flow_of(
        float(conductance),
        float(critical),
        float(upstream),
        float(downstream),
        density_factor(temperature),
    )


def cavity_area(segment: Segment) -> float:
    """A_c = 2·r0·h + (π/2)·r0² of (14.1), m²: the chamber's cross-section (inner contour)."""
    r0 = segment.inner_radius
    return 2.0 * r0 * segment.wall_height + 0.5 * math.pi * r0 * r0


def volume_coefficients(model: GloveModel) -> NDArray[np.float64]:
    """Per chamber (rows), V_d + A_c·ℓ̂, A_c·ℓ̂ and r_p·A_p: V = row·(1, ε, q) of (14.1).

    ε = ℓ/ℓ̂ − 1 is the bottom face's strain (zero for an inextensible segment); r_p·A_p is
    the pressure torque's coefficient of §4 (``GloveModel.constants.pressure_moments``), so
    that p·∂V/∂q = τ_p.
    """
    segments = model.params.exo_digit.segments
    chambers = model.params.pneumatics.chambers
    along = np.array([cavity_area(s) for s in segments]) * model.constants.arc_lengths
    dead = np.array([chamber.dead_volume for chamber in chambers])
    return np.stack([dead + along, along, model.constants.pressure_moments], axis=1)


def chamber_volume(model: GloveModel, q: ArrayLike, lengths: ArrayLike) -> NDArray[np.float64]:
    """V of (14.1), m³, at angles ``q`` (rad) and bottom-face ``lengths`` ℓ (m), per chamber."""
    rows = volume_coefficients(model)
    strain = np.asarray(lengths, dtype=float) / model.constants.arc_lengths - 1.0
    return rows[:, 0] + rows[:, 1] * strain + rows[:, 2] * np.asarray(q, dtype=float)


def rest_masses(volumes: ArrayLike, temperature: float) -> NDArray[np.float64]:
    """Air masses (kg) of chambers of ``volumes`` (m³) vented: P_atm·V/(R·T) (14.2)."""
    return ATMOSPHERIC_PRESSURE * np.asarray(volumes, dtype=float) / (GAS_CONSTANT * temperature)


def air_constants(model: GloveModel, supply: float) -> NDArray[np.float64]:
    """The kernels' rows of pneumatic constants (:mod:`.kernels.valves`), (3, AIR_COLUMNS).

    ``supply``: the supply's gauge pressure, Pa, where the parameters leave it open (null).
    """
    from ..kernels import valves

    pneumatics = model.params.pneumatics
    if pneumatics.supply_pressure is not None:
        supply = pneumatics.supply_pressure
    warn_outside_validated(pneumatics, supply)
    rows = np.zeros((3, valves.AIR_COLUMNS))
    for k, chamber in enumerate(pneumatics.chambers):
        rows[k, valves.AIR_INLET_CONDUCTANCE] = chamber.inlet_conductance
        rows[k, valves.AIR_INLET_CRITICAL] = chamber.inlet_critical_ratio
        rows[k, valves.AIR_OUTLET_CONDUCTANCE] = chamber.outlet_conductance
        rows[k, valves.AIR_OUTLET_CRITICAL] = chamber.outlet_critical_ratio
        rows[k, valves.AIR_LEAK] = chamber.leak_conductance
    volumes = volume_coefficients(model)
    rows[:, valves.AIR_VOLUME] = volumes[:, 0]
    rows[:, valves.AIR_VOLUME_PER_STRAIN] = volumes[:, 1]
    rows[:, valves.AIR_VOLUME_PER_ANGLE] = volumes[:, 2]
    rows[:, valves.AIR_GAS] = GAS_CONSTANT * pneumatics.temperature
    rows[:, valves.AIR_ATMOSPHERE] = ATMOSPHERIC_PRESSURE
    rows[:, valves.AIR_SUPPLY] = supply + ATMOSPHERIC_PRESSURE
    rows[:, valves.AIR_DENSITY] = density_factor(pneumatics.temperature)
    return rows


def outside_validated(pneumatics: Pneumatics, supply: float) -> list[str]:
    """One sentence per value of ``pneumatics`` outside :data:`VALIDATED_AIR`, naming its key.

    ``supply``: the supply's gauge pressure (Pa) where the parameters leave it open (null), the
    simulation's ``max_supply_pressure``.
    """
    if pneumatics.supply_pressure is None:
        values = [('max_supply_pressure (pneumatics.supply_pressure: null)', 'supply_pressure')]
        values[0] += (supply,)
    else:
        values = [('pneumatics.supply_pressure', 'supply_pressure', pneumatics.supply_pressure)]
    for k, chamber in enumerate(pneumatics.chambers):
        for key in VALIDATED_AIR:
            if key != 'supply_pressure':
                path = f'pneumatics.chambers[{k}].{key} ({chamber.name})'
                values.append((path, key, getattr(chamber, key)))
    sentences = []
    for path, key, value in values:
        low, high, unit = VALIDATED_AIR[key]
        if not low <= value <= high:
            sentences.append(
                f'{path} = {value:g} {unit}'.rstrip()
                + f' is outside the validated range {low:g}..{high:g}'
            )
    return sentences


def warn_outside_validated(pneumatics: Pneumatics, supply: float) -> None:
    """Warn, once per value, of ``pneumatics`` outside :data:`VALIDATED_AIR` (its key named)."""
    for sentence in outside_validated(pneumatics, supply):
        message = (
            f'{sentence}: the valve stepping is checked to 0.5 kPa at 50-200 Hz only inside '
            'it (docs/valves.md, "Where the bound holds")'
        )
        warnings.warn(message, OutsideModelWarning, stacklevel=5)
