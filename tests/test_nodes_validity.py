"""The estimator's tally of estimates outside the validated model (its /diagnostics WARN)."""

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_nodes.logic.estimation import Pair, ValidityTally
from exodigit_nodes.nodes.estimator import Estimator
from reliability_inprocess import InProcessNode
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

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


def test_the_estimator_node_publishes_an_estimate_outside_the_model_and_warns_once(probe):
    inside, outside = inside_and_outside()
    made = InProcessNode(Estimator, {}, probe)
    try:
        states = [
            JointState(
                header=Header(stamp=Time(sec=k + 1)), name=['mcp', 'pip', 'dip'], position=e.q
            )
            for k, e in enumerate((inside, outside))
        ]
        for estimate, state in zip((inside, outside), states, strict=True):
            made.node.publish_estimate(Pair(estimate.q, estimate.pressure, state))
        made.node.report()
        made.node.report()  # nothing outside since the last report
        published = made.published['estimated_contact_forces']
        np.testing.assert_allclose(
            [m.effort for m in published], [inside.forces, outside.forces], rtol=1e-12
        )
        assert [m.header.stamp.sec for m in published] == [1, 2]  # each its own state's
        first, second = (m.status[0] for m in made.published['/diagnostics'])
        assert first.level == DiagnosticStatus.WARN
        assert '1 estimates outside the validated model' in first.message
        assert "a joint is outside the finger's range of motion" in first.message
        assert second.level == DiagnosticStatus.OK
        values = {kv.key: kv.value for kv in second.values}
        assert values['estimates outside the model'] == '1'
    finally:
        made.close()
