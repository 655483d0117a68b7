"""Run the whole simulated glove from one command, with a live summary and a run record.

A glove is the hand of one finger with no finger level (:mod:`.runner.hand_runner`): its nodes
``plant``, ``estimator`` and ``pressure_command`` run as separate processes in one namespace
(and the rosbag2 ``recorder`` with ``--record``); the runner shows their signals on the
terminal, writes ``signals.csv`` and ``signals.png`` into the run directory and stops everything
on Ctrl-C or after ``--duration`` seconds: the command node first, so the chambers get zero
pressure.

With ``--clock sim`` the plant owns simulated time (``/clock``) and every other node runs with
``use_sim_time``; ``--real-time-factor`` paces it (0 = as fast as possible) and ``--lockstep``
keeps one step in flight, so a session gives the same result on a loaded machine as on an idle
one. ``--duration`` then counts simulated seconds.

With ``--hardware`` the glove runs on a board (docs/hardware.md): the ``hardware`` bridge takes
the plant's place behind valves, on ``mcu_emulator`` (``--hardware emulated``: the simulated
patient behind an emulated board) or on a board's serial port (``--hardware /dev/ttyACM0``).

This is what ``make run`` calls; on a ROS 2 install ``ros2 launch exodigit_nodes
glove.launch.py`` starts the same nodes without the summary.
"""

import sys

from exodigit_nodes.runner import hand_runner

GLOVE = hand_runner.Command(
    name='glove',
    description='Run the simulated soft glove (plant, estimator, pressure_command) with a\n'
    'live summary; write a run record (CSV and PNG) of the published signals.\n'
    'Switches (--lockstep, --record) take true or false; alone they mean true.',
    examples="""examples:
  python -m exodigit_nodes.glove                      # sine session until Ctrl-C
  python -m exodigit_nodes.glove --duration 20        # 20 s, then stop and exit 0
  python -m exodigit_nodes.glove --mode staircase --record --out runs/stairs
  python -m exodigit_nodes.glove --params-file my_glove.yaml --namespace /left/index
  python -m exodigit_nodes.glove --clock sim --real-time-factor 0 --lockstep --duration 60
                                                      # 60 simulated s, as fast as the CPU allows
  python -m exodigit_nodes.glove --hardware emulated  # through the bridge and an emulated board
  python -m exodigit_nodes.glove --hardware /dev/ttyACM0 --mode hold
                                                      # on a real board (docs/hardware.md)

ROS_AUTOMATIC_DISCOVERY_RANGE (default LOCALHOST) and ROS_DOMAIN_ID (default 0) are passed to
every node; see docs/networking.md.""",
)


def build_parser():
    """The command line of ``python -m exodigit_nodes.glove``."""
    return hand_runner.build_parser(GLOVE)


def main(argv=None) -> int:
    """Run the glove; return the exit code (0 clean stop, 1 a node failed, 2 bad input)."""
    return hand_runner.main(GLOVE, argv)


if __name__ == '__main__':
    sys.exit(main())
