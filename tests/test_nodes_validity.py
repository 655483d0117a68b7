"""The estimator's bookkeeping: estimates outside the validated model (its /diagnostics WARN)
and the window its stiffness is identified over."""

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_nodes.logic.estimation import Pair
from exodigit_nodes.nodes.estimator import Estimator
from reliability_inprocess import InProcessNode
from sensor_msgs.msg import JointState
from std_msgs.msg import Header
from test_control import stiffer_finger_model

from exodigit_model import GloveModel

MODEL = GloveModel()


def inside_and_outside():
    """An estimate of a state the model reaches at 20 kPa, and one past the MCP's range."""
    p = np.full(3, 20e3)
    q = MODEL.solve(p).q
    past = q.copy()
    past[0] = MODEL.params.finger.joints[0].rom_max + 0.1  # rad, from the parameters
    return MODEL.estimate(q, p), MODEL.estimate(past, p)


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
        for estimate in (outside, inside, outside):
            made.node.publish_estimate(Pair(estimate.q, estimate.pressure, states[0]))
        made.node.report()
        published = made.published['estimated_contact_forces']
        np.testing.assert_allclose(
            [m.effort for m in published[:2]], [inside.forces, outside.forces], rtol=1e-12
        )
        assert [m.header.stamp.sec for m in published[:2]] == [1, 2]  # each its own state's
        first, second, third = (m.status[0] for m in made.published['/diagnostics'])
        assert first.level == DiagnosticStatus.WARN
        assert '1 estimates outside the validated model' in first.message
        assert "a joint is outside the finger's range of motion" in first.message
        assert second.level == DiagnosticStatus.OK
        values = {kv.key: kv.value for kv in second.values}
        assert values['estimates outside the model'] == '1'
        assert third.level == DiagnosticStatus.WARN
        assert '2 estimates outside the validated model since the last report' in third.message
        values = {kv.key: kv.value for kv in third.values}
        assert values['estimates outside the model'] == '3'
    finally:
        made.close()


def test_the_window_identifies_the_finger_stiffness_and_slides(probe):
    """The estimator fits the last identification_window pairs, whichever finger made them."""
    made = InProcessNode(Estimator, {'identification_window': '50'}, probe)
    try:
        made.node.identify()  # nothing to fit yet: no estimate published
        assert 'at least two' in made.node.fit_problem
        state = JointState(name=['mcp', 'pip', 'dip'])
        rng = np.random.default_rng(1)
        fitted = []
        for plant in (MODEL, stiffer_finger_model(2.0)):
            for _ in range(50):
                pressure = rng.uniform(5e3, 50e3, 3)
                made.node.publish_estimate(Pair(plant.solve(pressure).q, pressure, state))
            made.node.identify()
            fitted.append(np.array([j.stiffness for j in plant.params.finger.joints]))
        published = made.published['estimated_finger_stiffness']
        np.testing.assert_allclose([m.data for m in published], fitted, rtol=1e-9)
    finally:
        made.close()
