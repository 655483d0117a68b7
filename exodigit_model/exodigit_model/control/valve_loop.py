"""The valve pressure loop: pressure targets and measured pressures to six valve openings.

What ``pressure_command`` runs with ``output:=valves`` (docs/spec/ros.md, "Valves"), and what an
in-process trial or figure runs in front of ``GloveSimulation(actuation='valves')``: one loop, so
the two cannot disagree. Like the other closed loops of this package it controls one glove
(arrays (3,) in, (6,) out) or a batch of N gloves ((N, 3) in, (N, 6) out).

With valves (docs/spec/model.md §14) a chamber's pressure is not commanded but made: its inlet
valve lets supply air in, its outlet valve lets it out to the atmosphere, and the pressure is
the mass of air inside over its volume. The loop turns the three pressure targets the modes and
the safety limiter give, and the three measured chamber pressures, into six openings (inlets
MCP, PIP, DIP, then outlets).

Why a duty-cycle PI and not fill/hold/vent by a deadband (bang-bang), which most soft gloves'
microcontrollers run with on/off 2/2 solenoid valves: the glove's chambers are small, so one
step of a fully open valve moves their pressure far. With the defaults of docs/spec/model.md
§10 and §14 (supply 100 kPa gauge, C = 5·10⁻¹⁰ m³/(s·Pa)) a chamber at rest holds 2.6 cm³
(DIP) to 5.8 cm³ (MCP), and an open inlet fills it at ``Q·R·T/V`` ≈ 1.6–3.7 MPa/s: 16–37 kPa in
one 10 ms step, so a bang-bang loop at 100 Hz rings by that much around its target. An opening
in [0, 1] is the share of the step a valve is open (a PWM duty cycle, or a proportional valve),
which the plant holds over the step (zero-order hold): a loop that opens in proportion to the
error moves the pressure by a fraction of that. What is kept of fill/hold/vent is the deadband:
within ``valve_deadband`` of its target a chamber holds (both valves closed: no valve chatters
on sensor noise, and a glove at rest spends no air).

Per joint, error e = target − measured:

* |e| ≤ deadband: hold (both closed), the integral kept;
* else demand s = kp·e + ki·∫e dt clipped to [−1, 1]; s > 0 opens the inlet by s, s < 0 the
  outlet by −s (never both: air through both is air wasted); the integral does not wind up
  against the clip (:class:`.controllers.PIController`, the position and force loops' PI);
* a target of zero vents: outlet fully open, inlet closed, integral cleared (what
  ``output:=pressure`` gets from a zero command, and what the plant's watchdog does).

Defaults (:class:`ValveLoopSettings`), chosen on chambers of fixed volume filled and vented
by eqs (14.3)-(14.4) at 100 Hz: kp = 1/(40 kPa), so that the largest change a fully open inlet
makes in one step, ~37 kPa (DIP), times kp stays below 1 and no chamber overshoots within a step
(a discrete loop of gain g per step rings for g > 1, is unstable for g > 2); MCP's error still
falls by 40 % a step. ki = kp·1 s⁻¹ cuts the lag behind a target ramping at the limiter's
default ``max_pressure_rate`` (100 kPa/s) from 2.2 to 1.3 kPa (MCP), and overshoots a 30 kPa
step by 52 Pa at most; 5 s⁻¹ overshot it by 2.1 kPa. Deadband 300 Pa: 3 % of the staircase's
10 kPa steps, above a pressure sensor's usual noise. A chamber that leaks (§14's leak
conductance) drifts out of the deadband while it holds, and the integral refills it: on a chamber
filled 16 kPa a step and leaking 20 kPa/s the error swings between −1.1 and +0.5 kPa with a mean
inside the deadband, where a P loop (``valve_ki`` 0) holds it 500 Pa low
(tests/test_control_valve_loop.py).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from .controllers import PIController

OUTPUTS = ('pressure', 'valves')
"""What a pressure controller's targets become (``pressure_command``'s ``output`` parameter):
the pressures themselves, for regulators, or this loop's openings, for valves."""


@dataclass(frozen=True)
class ValveLoopSettings:
    """The pressure loop's settings (SI), the ``pressure_command`` parameters of these names.

    Attributes
    ----------
    valve_deadband : float
        Error within which a chamber holds (both valves closed), Pa; >= 0.
    valve_kp : float
        Proportional gain, openings per Pa of error (1/Pa); > 0.
    valve_ki : float
        Integral gain, openings per Pa·s of integrated error (1/(Pa·s)); >= 0.
    """

    valve_deadband: float = 300.0
    valve_kp: float = 1.0 / 40e3
    valve_ki: float = 1.0 / 40e3

    def __post_init__(self) -> None:
        """Refuse values that break a rule, naming the field, the value and the rule."""
        for item in fields(self):
            value = getattr(self, item.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f'{item.name} = {value!r}: must be a number')
            if not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f'{item.name} = {value!r}: must be finite and >= 0')
        if self.valve_kp == 0.0:
            raise ValueError(f'valve_kp = {self.valve_kp!r}: must be > 0 (no loop without it)')


def openings_of(demand: NDArray[np.float64]) -> NDArray[np.float64]:
    """Six openings of three signed demands s in [−1, 1]: inlets max(s, 0), outlets max(−s, 0)."""
    return np.concatenate([np.maximum(demand, 0.0), np.maximum(-demand, 0.0)], axis=-1)


class ValveLoop:
    """Three chambers' pressure loops (module text): targets and measurements in, openings out.

    Parameters
    ----------
    settings : ValveLoopSettings
        Deadband and gains (:meth:`configure` changes them).
    count : int, optional
        Gloves controlled together, each with its own integrators; None: one glove.
    """

    def __init__(self, settings: ValveLoopSettings, *, count: int | None = None) -> None:
        self.count = count
        self.pi = PIController(settings.valve_kp, settings.valve_ki, count=count)
        self.configure(settings)

    def configure(self, settings: ValveLoopSettings) -> None:
        """New deadband and gains from the next step on (the integral is kept)."""
        self.settings = settings
        self.pi.kp, self.pi.ki = settings.valve_kp, settings.valve_ki

    def reset(self) -> None:
        """Empty integrals (a new session)."""
        self.pi.reset(self.count)

    def openings(
        self, target: NDArray[np.float64], measured: NDArray[np.float64], dt: float
    ) -> NDArray[np.float64]:
        """The six openings that move ``measured`` (Pa) toward ``target`` (Pa) over ``dt`` (s).

        ``target`` >= 0, as the safety limiter gives it, shape (3,), or (N, 3) for a batch; the
        result's last axis is inlets MCP, PIP, DIP, then outlets.
        """
        error = target - measured
        vent = target <= 0.0
        active = (np.abs(error) > self.settings.valve_deadband) & ~vent
        raw = self.pi.output(np.zeros(error.shape), np.where(active, error, 0.0), dt)
        demand = np.where(active, np.clip(raw, -1.0, 1.0), 0.0)
        self.pi.commit(raw, demand)
        self.pi.integral = np.where(vent, 0.0, self.pi.integral)
        return openings_of(np.where(vent, -1.0, demand))
