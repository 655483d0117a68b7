"""The estimator's tally of estimates outside the validated model (its /diagnostics WARN)."""

import numpy as np
from exodigit_nodes.logic.estimation import ValidityTally

from exodigit_model import GloveModel

MODEL = GloveModel()


def inside_and_outside():
    """An estimate of a state the model reaches at 20 kPa, and one past the MCP's range."""
    p = np.full(3, 20e3)
    q = MODEL.solve(p).q
    past = q.copy()
    past[0] = MODEL.params.finger.joints[0].rom_max + 0.1  # rad, from the parameters
    return MODEL.estimate(q, p), MODEL.estimate(past, p)


def test_an_estimate_outside_the_model_warns_until_a_report_has_said_so():
    inside, outside = inside_and_outside()
    tally = ValidityTally()
    tally.add(inside)
    assert tally.report() == ([], {'estimates outside the model': '0'})
    tally.add(outside)
    tally.add(inside)
    tally.add(outside)
    problems, values = tally.report()
    assert len(problems) == 1
    assert problems[0].startswith('2 estimates outside the validated model')
    assert "a joint is outside the finger's range of motion" in problems[0]
    assert values == {'estimates outside the model': '2'}
    assert tally.report() == ([], {'estimates outside the model': '2'})  # said once
