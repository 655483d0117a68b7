"""One row of the node table (:mod:`.catalog`); no rclpy until :meth:`NodeEntry.node_class`."""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from ..logic.parameters import ParamSpec, ParamTable

PACKAGE = 'exodigit_nodes'
DIAGNOSTIC_PERIOD = ParamSpec(
    'diagnostic_period',
    1.0,
    'Time between two /diagnostics reports, s (of the node clock; a plant with clock sim '
    'reports on wall time)',
    low=0.01,
    high=3600.0,
    read_only=True,
)
"""Every node's report period: one row, in each node's table."""


@dataclass(frozen=True)
class NodeEntry:
    """One node executable of the glove.

    Attributes
    ----------
    executable : str
        Console script (``ros2 run exodigit_nodes <executable>``), the node's default name, and
        the name of its module (:attr:`module`) and parameter file (:attr:`config_file`).
    class_name : str
        Its :class:`~.node_base.GloveNode` subclass in ``module``.
    summary : str
        What the node is, a few words.
    table : ParamTable
        Its declared parameters, with their defaults.
    """

    executable: str
    class_name: str
    summary: str
    table: ParamTable

    @property
    def module(self) -> str:
        """The module that runs it (``python -m exodigit_nodes.nodes.plant``): its ``main``."""
        return f'{PACKAGE}.nodes.{self.executable}'

    @property
    def config_file(self) -> str:
        """Name of its ROS parameter file in the package's ``config`` directory."""
        return f'{self.executable}.yaml'

    def node_class(self) -> type:
        """The node class (imports its module, and with it rclpy)."""
        return getattr(importlib.import_module(self.module), self.class_name)
