"""pytest plugin of the testing kit: the ``glove_sim`` fixture.

Registered through the ``pytest11`` entry point of ``exodigit_nodes``, so installing the package
is enough. Each test that asks for ``glove_sim`` gets its own simulated glove (a plant in
lockstep simulated time, in a free ROS domain and a fresh namespace), torn down after the test
with every process it started. Options are :class:`~exodigit_nodes.testing.GloveSim`'s keyword
arguments, given with a marker::

    @pytest.mark.glove_sim(params_file='my_patient.yaml', estimator=True,
                           plant={'angle_noise_std': 1e-3, 'seed': 4})
    def test_my_controller(glove_sim):
        ...

or by indirect parametrization (``@pytest.mark.parametrize('glove_sim', [{...}],
indirect=True)``). Node logs go to the test's ``tmp_path``.
"""

from __future__ import annotations

import pytest


def pytest_configure(config: pytest.Config) -> None:
    """Declare the ``glove_sim`` marker (so ``--strict-markers`` accepts it)."""
    config.addinivalue_line(
        'markers',
        'glove_sim(**options): options of the glove_sim fixture (the keyword arguments of '
        'exodigit_nodes.testing.GloveSim: params_file, estimator, plant, timeout)',
    )


@pytest.fixture
def glove_sim(request: pytest.FixtureRequest, tmp_path):
    """A simulated glove in lockstep simulated time, driven by the test (a ``GloveSim``)."""
    from .client import GloveSim

    options = {}
    for marker in reversed(list(request.node.iter_markers('glove_sim'))):
        options.update(marker.kwargs)
    options.update(getattr(request, 'param', None) or {})
    options.setdefault('log_dir', tmp_path / 'glove_sim')
    with GloveSim(**options) as glove:
        yield glove
