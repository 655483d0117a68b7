"""The console scripts (``ros2 run exodigit_nodes plant``): Ctrl-C ends a start-up quietly.

A program of the package takes SIGINT into its own hands (``logic.lifetime.StopRequest``) only
once rclpy, numpy and the model's compiled kernels are imported: a second or more. ``ros2
launch`` stops every node with SIGINT when one of them fails at start, and a node still
importing then printed a 30-line ``KeyboardInterrupt`` traceback. Each console script here
imports its program's module under a SIGINT handler of its own that ends the process there and
then, with one line and exit status 0, as a Ctrl-C later does. Not Python's KeyboardInterrupt:
raised while the import runs a finaliser (numba's and rclpy's imports collect garbage), it is
only reported as ignored, and the node went on starting with the Ctrl-C lost (two full suite
runs on a loaded machine). Nothing is held yet that an exit would leave behind; from its
``main()`` on, the program handles SIGINT itself. A SIGINT that is ignored (the runners and the
testing kit start ``python -m`` modules with SIGINT blocked until it is handled) stays ignored.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
from collections.abc import Callable


def program(name: str, module: str) -> Callable[[], int]:
    """The console script ``name``: ``module``'s ``main()``, imported with Ctrl-C handled."""
    said = f'{name}: stopped while starting'

    def stopped(signum: int, frame: object) -> None:
        print(said, file=sys.stderr, flush=True)
        os._exit(0)

    def main() -> int:
        handled = signal.getsignal(signal.SIGINT) is not signal.SIG_IGN
        if handled:
            signal.signal(signal.SIGINT, stopped)
        loaded = importlib.import_module(module)
        if handled:
            signal.signal(signal.SIGINT, signal.default_int_handler)
        try:
            return loaded.main()
        except KeyboardInterrupt:  # before the program took SIGINT over
            print(said, file=sys.stderr)
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
