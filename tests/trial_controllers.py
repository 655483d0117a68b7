"""Tiny user controllers for the trial tests, named as ``trial_controllers:<factory>``."""

import numpy as np
from exodigit_model.control import LIMIT_KINDS


class Constant:
    """Every chamber of every glove held at one pressure, Pa; no limiter."""

    def __init__(self, pressure):
        self.pressure = float(pressure)
        self.last = None

    def reset(self, count, rng=None):
        self.count = count

    def command(self, t, dt, state):
        return np.full((self.count, 3), self.pressure)


def full_supply(*, protocol, model, pressure=100e3):
    """The known-unsafe controller: the full supply pressure held from the first step."""
    return Constant(pressure)


def gentle(*, protocol, model, pressure=5e3):
    """A known-gentle controller: a low pressure held."""
    return Constant(pressure)


class Flagging(Constant):
    """Constant, reporting its limiter as acting on the even-numbered gloves at every step."""

    def command(self, t, dt, state):
        acted = np.zeros((self.count, len(LIMIT_KINDS)), bool)
        acted[::2, 0] = True
        self.last = type('Last', (), {'acted': acted})()
        return super().command(t, dt, state)


def flagging(*, protocol, model, pressure=10e3):
    return Flagging(pressure)


def not_a_controller(*, protocol, model):
    return 'nothing'
