"""The testing kit's emulated board, used as a user's CI test would use it (docs/hardware.md,
"Testing without a board"): a controller process of its own, started in the fixture's namespace
and domain, drives the board through the hardware bridge; the test reads the board without ROS.

The controller here is the package's ``pressure_command`` (output valves), run exactly as it
drives the simulated plant: nothing of it knows there is a board.
"""

import subprocess
import sys

import pytest

HOLD = (20e3, 15e3, 10e3)
"""Pa: what the controller holds (``pressure_command`` hold mode)."""
BAND = 300.0 + 50.0
"""Pa: the controller's hold deadband plus the emulated sensor's quantum."""


def start_controller(glove) -> subprocess.Popen:
    """The user's controller, as a user would start theirs: its own process, the glove's
    environment (domain, discovery) and namespace."""
    command = [
        *(sys.executable, '-m', 'exodigit_nodes.nodes.pressure_command', '--ros-args'),
        *('-r', f'__ns:={glove.namespace}'),
        *('-p', 'output:=valves', '-p', 'mode:=hold'),
        *('-p', f'hold_pressure:=[{", ".join(f"{p:.1f}" for p in HOLD)}]'),
    ]
    log = open(glove.log_dir / 'controller.log', 'wb')  # noqa: SIM115 (closed with the process)
    return subprocess.Popen(command, env=glove.env, stdout=log, stderr=subprocess.STDOUT)


def holding(board) -> bool:
    return all(abs(p - target) <= BAND for p, target in zip(board.pressures, HOLD, strict=True))


def held(glove, readings: int = 10):
    """The status once the board has held the pressures on ``readings`` readings in a row
    (asked every 50 ms), None if it never does within a minute."""
    streak = []

    def steady(board) -> bool:
        streak.append(holding(board))
        return all(streak[-readings:]) and len(streak) >= readings

    return glove.wait_for(steady, timeout=60.0)


@pytest.mark.emulated_glove(bridge={'max_pressure': 60e3})
def test_a_controller_holds_its_pressures_on_the_emulated_board_and_after_an_unplug(
    emulated_glove,
):
    board = emulated_glove.status()
    assert board.streaming and board.openings == (0.0, 0.0, 0.0, 1.0, 1.0, 1.0)  # vented
    controller = start_controller(emulated_glove)
    try:
        assert held(emulated_glove) is not None, (emulated_glove.status(), emulated_glove.log_dir)
        # the cable out for a second: the board is silent and vented, then the bridge starts a
        # new session (vented first) and the controller's next commands fill it again
        emulated_glove.fault('unplug 1')
        off = emulated_glove.wait_for(lambda b: not b.streaming, timeout=10.0)
        assert off is not None
        assert held(emulated_glove) is not None, (emulated_glove.status(), emulated_glove.log_dir)
    finally:
        controller.terminate()
        controller.wait(10.0)
