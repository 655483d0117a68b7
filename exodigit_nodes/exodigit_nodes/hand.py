"""Run a simulated hand from one command, with a live summary and one run record per finger.

The one runner (:mod:`.runner.hand_runner`) with one ``hand_nodes`` process
(:mod:`.nodes.hand_nodes`): every finger's plant, estimator and pressure_command; it shows each
finger's signals on the terminal, writes ``<finger>/signals.csv`` and
``<finger>/signals.png`` into the run directory (and with ``--record`` a rosbag2 bag per finger,
``bag/<finger>``) and stops on Ctrl-C or after ``--duration`` seconds (simulated seconds with
``--clock sim``): every command node sends zero pressure first. Finger f lives in
``<namespace>/<f>`` with joint prefix ``f_`` and the model ``config/hand/<f>.yaml``.

This is what ``make run HAND=1`` calls; on a ROS 2 install ``ros2 launch exodigit_nodes
hand.launch.py`` starts the same process without the summary.
"""

import sys

from exodigit_nodes.runner import hand_runner

HAND = hand_runner.Command(
    name='hand',
    description="Run a simulated hand (every finger's plant, estimator and pressure_command in "
    'one process) with a live summary; write a run record (CSV and PNG) per finger.',
    examples="""examples:
  python -m exodigit_nodes.hand                                  # five fingers until Ctrl-C
  python -m exodigit_nodes.hand --fingers index,middle --duration 20
  python -m exodigit_nodes.hand --clock sim --lockstep --real-time-factor 0 --duration 60
                                                     # 60 simulated s, as fast as the CPU allows
  python -m exodigit_nodes.hand --ros-params fast.yaml  # /**: ros__parameters: rate_hz: 200

ROS_AUTOMATIC_DISCOVERY_RANGE (default LOCALHOST) and ROS_DOMAIN_ID (default 0) are passed on;
see docs/networking.md.""",
)


def build_parser():
    """The command line of ``python -m exodigit_nodes.hand``."""
    return hand_runner.build_parser(HAND)


def main(argv=None) -> int:
    """Run the hand; the exit code (0 clean stop, 1 a process failed, 2 bad input)."""
    return hand_runner.main(HAND, argv)


if __name__ == '__main__':
    sys.exit(main())
