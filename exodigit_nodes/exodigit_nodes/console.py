"""The console scripts (``ros2 run exodigit_nodes plant``): Ctrl-C ends a start-up quietly.

A program of the package takes SIGINT into its own hands (``logic.lifetime.StopRequest``) only
once rclpy, numpy and the model's compiled kernels are imported: a second or more. ``ros2
launch`` stops every node with SIGINT when one of them fails at start, and a node still
importing then printed a 30-line ``KeyboardInterrupt`` traceback. Each console script here
imports its program's module only inside a handler for that, so a Ctrl-C that comes while it
starts ends it with one line and exit status 0, as a Ctrl-C later does. (The runners and the
testing kit start ``python -m`` modules with SIGINT blocked until it is handled.)
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable


def program(name: str, module: str) -> Callable[[], int]:
    """The console script ``name``: ``module``'s ``main()``, imported with Ctrl-C handled."""

    def main() -> int:
        try:
            return importlib.import_module(module).main()
        except KeyboardInterrupt:
            print(f'{name}: stopped while starting', file=sys.stderr)
            return 0

    main.__qualname__ = main.__name__ = name
    main.__doc__ = f'Console script ``{name}``: ``{module}.main()``.'
    main.module = module
    return main


plant = program('plant', 'exodigit_nodes.nodes.plant')
pressure_command = program('pressure_command', 'exodigit_nodes.nodes.pressure_command')
estimator = program('estimator', 'exodigit_nodes.nodes.estimator')
recorder = program('recorder', 'exodigit_nodes.nodes.recorder')
hand_nodes = program('hand_nodes', 'exodigit_nodes.nodes.hand_nodes')
glove = program('glove', 'exodigit_nodes.glove')
hand = program('hand', 'exodigit_nodes.hand')
hardware = program('hardware', 'exodigit_nodes.nodes.hardware')
mcu_emulator = program('mcu_emulator', 'exodigit_nodes.hardware.emulator')
