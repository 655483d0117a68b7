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
microcontrollers run with on/off 2/2 solenoid valves: the glove's chambers are small, so one step
of a fully open valve moves their pressure far. With the defaults of docs/spec/model.md §10 and §14
(supply 100 kPa gauge, C = 5·10⁻¹⁰ m³/(s·Pa)) a chamber at rest holds 2.6 cm³ (DIP) to 5.8 cm³
(MCP), and one 10 ms step of an open inlet raises the default glove's chambers by 13.9 (MCP), 17.9
(PIP) and 28.1 kPa (DIP) from rest, 10-11 kPa at 45-80 kPa; an open outlet lowers them by 3-20 kPa
a step. A fill/hold/vent loop at 100 Hz with a 300 Pa deadband on the default glove is 3.5-8.2 kPa
RMS off the staircase and 5.8-12.2 kPa off the sine (up to 27 kPa), its valves swapping between
fill and vent 17-56 times a second.

An opening in [0, 1] is the share of the step a valve is open (a PWM duty cycle, or a proportional
valve), which the plant holds over the step (zero-order hold): a loop that opens in proportion to
the error moves the pressure by a fraction of that. What is kept of fill/hold/vent is the deadband:
within ``valve_deadband`` of its target a chamber holds (both valves closed: no valve chatters on
sensor noise, and a glove at rest spends no air).

Per joint, error e = target − measured:

* |e| ≤ deadband: hold (both closed), the integral kept;
* else demand s = kp·e + ki·∫e dt clipped to [−1, 1]; s > 0 opens the inlet by s, s < 0 the
  outlet by −s (never both: air through both is air wasted); the integral does not wind up
  against the clip (:class:`.controllers.PIController`, the position and force loops' PI);
* a target of zero vents: outlet fully open, inlet closed, integral cleared (what
  ``output:=pressure`` gets from a zero command, and what the plant's watchdog does).

Defaults (:class:`ValveLoopSettings`). kp = 3·10⁻⁵ /Pa (1/(33 kPa)): the largest change a fully
open inlet makes in one step on the default glove, 28.1 kPa (DIP from rest, above), times kp is
0.84 < 1, so no chamber overshoots within a step (a discrete loop of gain g per step rings for
g > 1, is unstable for g > 2), with a margin for gloves whose chambers fill faster; kp = 1/(20 kPa)
cuts the errors below by another 35-45 %, but DIP's first step from rest overshoots by 40 % of its
error. ki = kp·1 s⁻¹. Deadband 300 Pa: 3 % of the staircase's 10 kPa steps. Measured in process
(GloveSimulation(actuation='valves'), default glove and settings, the built-in modes' default
targets through the default safety limiter, openings from the pressure of the step before), per
chamber MCP, PIP, DIP:

* staircase (20 s): 0.52, 0.40, 0.25 kPa RMS; at most 3.9, 3.1, 1.9 kPa behind while the limiter
  ramps a stair at 100 kPa/s, within the deadband over the last second of every stair, no stair
  overshot by more than 6 Pa; each valve opens 0.22-0.3 times a second;
* sine (8 s): 0.66, 0.48, 0.28 kPa RMS, at most 1.1 kPa; the inlets pulse 7-20 times a second
  while the target rises (a fraction of a step each: the deadband's hold between pulses), and a
  chamber swaps from filling to venting only at the sine's turns (0.25 a second): no chatter;
* against the former kp = 1/(40 kPa) (ki = kp·1 s⁻¹ too): 15-20 % less error (sine 0.81, 0.59,
  0.34 kPa RMS; staircase at most 4.4, 3.6, 2.3 kPa behind), the same air.

The deadband is no filter: with sensor noise (``pressure_noise_std``) a holding chamber leaves it
on noise, and the staircase's chambers swap between filling and venting 1.5-3.3 times a second
with 100 Pa of noise, 0.05-1.9 with 75 Pa, 0.05-1.0 with 50 Pa (the errors as without);
``valve_deadband`` wants several standard deviations of the sensor's noise. A chamber that leaks
(§14's leak conductance) drifts out of the deadband while it holds, and the integral refills it: on
a chamber filled 16 kPa a step and leaking 20 kPa/s the error swings between −1.1 and +0.5 kPa with
a mean inside the deadband, where a P loop (``valve_ki`` 0) holds it 500 Pa low
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
    valve_kp: float = 3e-5
    valve_ki: float = 3e-5

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


LOOP_PARAMETERS = tuple(field.name for field in fields(ValveLoopSettings))
"""The loop's parameters, named as ``pressure_command``'s (``output:=valves``) and a trial's."""


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
