"""A testing kit for glove controllers: a simulated glove in lockstep simulated time.

``GloveSim`` starts a plant (and optionally the estimator) in a private ROS domain and namespace
and drives it: ``step(command)`` for a controller in the test itself, ``run(seconds)`` for a
controller that is its own ROS node. Installed with ``exodigit_nodes``, the pytest plugin
:mod:`exodigit_nodes.testing.plugin` gives every test a ``glove_sim`` fixture (docs/spec/ros.md
Part II, "A testing kit for users' own controllers"). ``EmulatedGlove`` is the glove on an
emulated board behind the ``hardware`` bridge, on the wall clock, for a controller that must
also work on a real board: the ``emulated_glove`` fixture (docs/hardware.md, "Testing without a
board").
"""

from .board import EmulatedGlove, EmulatorError, EmulatorProcess
from .client import GloveSim, GloveSimError
from .processes import DomainLease, claim_domain, ros_environment
from .records import SimRecord, SimState

__all__ = [
    'DomainLease',
    'EmulatedGlove',
    'EmulatorError',
    'EmulatorProcess',
    'GloveSim',
    'GloveSimError',
    'SimRecord',
    'SimState',
    'claim_domain',
    'ros_environment',
]
