"""Tests of the flex controller against a simulated glove (exodigit's ``glove_sim`` fixture).

The fixture comes with ``exodigit_nodes`` (a pytest plugin): each test gets its own plant in
lockstep simulated time, so 3 simulated seconds take a fraction of that and every run gives the
same numbers.
"""

import math
import subprocess
import sys

import numpy as np
import pytest
from my_glove_controller.flex_controller import FlexLaw

TARGETS = [0.3, 0.3, 0.2]  # rad
TOLERANCE = math.radians(1.0)


def test_the_law_reaches_its_targets(glove_sim):
    law = FlexLaw(TARGETS)
    state = glove_sim.reset()
    for _ in range(300):  # 3 simulated seconds at 100 Hz
        state = glove_sim.step(law.command(state.t, state.q))
    np.testing.assert_allclose(state.q, TARGETS, atol=TOLERANCE)


@pytest.mark.glove_sim(plant={'pressure_time_constant': 0.05, 'angle_noise_std': 1e-3})
def test_the_node_reaches_its_targets_with_chamber_lag_and_sensor_noise(glove_sim):
    node = subprocess.Popen(
        [
            sys.executable,
            '-m',
            'my_glove_controller.flex_controller',
            '--ros-args',
            '-r',
            f'__ns:={glove_sim.namespace}',
        ],
        env=glove_sim.env,
    )
    try:
        record = glove_sim.run(4.0)
    finally:
        node.terminate()
        try:
            node.wait(10)
        except subprocess.TimeoutExpired:  # what is checked is the run, not the node's exit
            node.kill()
            node.wait()
    assert record.t[-1] - record.t[0] == pytest.approx(4.0 - 0.01)
    settled = record.q[-50:]  # the last half second
    np.testing.assert_allclose(settled.mean(axis=0), TARGETS, atol=TOLERANCE)
    assert (record.command >= 0.0).all() and (record.command <= 60e3).all()
