"""pytest plugin of the testing kit: the ``glove_sim`` and ``emulated_glove`` fixtures.

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

The ``emulated_glove`` fixture is the glove on an emulated board behind the ``hardware`` bridge
(:class:`~exodigit_nodes.testing.EmulatedGlove`, on the wall clock), for a controller's test
without a board; its options with ``@pytest.mark.emulated_glove(emulator=['--latency',
'0.01'], bridge={'max_pressure': 50e3})``.
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
    config.addinivalue_line(
        'markers',
        'emulated_glove(**options): options of the emulated_glove fixture (the keyword '
        'arguments of exodigit_nodes.testing.EmulatedGlove: emulator, bridge, timeout)',
    )


def fixture_options(request: pytest.FixtureRequest, name: str, log_dir) -> dict:
    """A kit fixture's options: its markers' (the closest last), then an indirect parameter."""
    options = {}
    for marker in reversed(list(request.node.iter_markers(name))):
        options.update(marker.kwargs)
    options.update(getattr(request, 'param', None) or {})
    options.setdefault('log_dir', log_dir / name)
    return options


@pytest.fixture
def glove_sim(request: pytest.FixtureRequest, tmp_path):
    """A simulated glove in lockstep simulated time, driven by the test (a ``GloveSim``)."""
    from .client import GloveSim

    with GloveSim(**fixture_options(request, 'glove_sim', tmp_path)) as glove:
        yield glove


@pytest.fixture
def emulated_glove(request: pytest.FixtureRequest, tmp_path):
    """The glove on an emulated board behind the hardware bridge (an ``EmulatedGlove``)."""
    from .board import EmulatedGlove

    with EmulatedGlove(**fixture_options(request, 'emulated_glove', tmp_path)) as glove:
        yield glove
