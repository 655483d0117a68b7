"""How a node process ends: its starter dies (lifetime.py), or its embedder shuts rclpy down."""

import os
import signal
import subprocess
import sys

import pytest
from ros_harness import ros_environment, wait_until

#: Starts the plant as ``ros2 launch`` does (a plain child, no pre-exec hook of ours), prints
#: its pid and waits; the test kills this starter.
STARTER = """
import subprocess, sys
log = open(sys.argv[1], 'w')
plant = [sys.executable, '-m', 'exodigit_nodes.nodes.plant']
node = subprocess.Popen(plant, stderr=log, stdout=log)
print(node.pid, flush=True)
node.wait()
"""


def running(pid):
    """Whether ``pid`` is a live process (a zombie counts as gone)."""
    try:
        with open(f'/proc/{pid}/stat') as stat:
            return stat.read().rsplit(')', 1)[1].split()[0] != 'Z'
    except FileNotFoundError:
        return False


def test_a_node_stops_when_the_process_that_started_it_is_killed(ros_domain, tmp_path):
    log = tmp_path / 'plant.log'
    starter = subprocess.Popen(
        [sys.executable, '-c', STARTER, str(log)],
        env=ros_environment(ros_domain),
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        text=True,
    )
    node = int(starter.stdout.readline())
    try:
        assert wait_until(lambda: 'plant running' in log.read_text(), 30.0), log.read_text()
        starter.kill()  # SIGKILL: the starter cannot pass anything on
        starter.wait()
        assert wait_until(lambda: not running(node), 10.0), 'the plant outlived its starter'
    finally:
        if running(node):
            os.kill(node, signal.SIGKILL)


#: Runs one finger of ``hand_nodes`` in a program that shuts rclpy down itself (as code embedding
#: the nodes may): half a second after the nodes are built, between callbacks (``timer``);
#: inside the plant's first publish, so that the publish finds the context gone (``callback``);
#: or, after a SIGINT, as the command node starts its last words, so that its zero pressure
#: finds the context gone (``last words``).
EMBEDDER = """
import os, signal, threading, rclpy
from exodigit_nodes.nodes import hand_nodes
from exodigit_nodes.nodes.plant import Plant
from exodigit_nodes.nodes.pressure_command import PressureCommand
build = hand_nodes.build_hand
def build_then_shut_down(*args):
    nodes = build(*args)
    if WHERE == 'timer':
        threading.Timer(0.5, rclpy.shutdown).start()
    if WHERE == 'last words':
        threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
    return nodes
publish_state = Plant.publish_state
def shut_down_then_publish(self, state, stamp):
    if WHERE == 'callback' and self.cycles > 10:
        rclpy.shutdown()
    publish_state(self, state, stamp)
on_shutdown = PressureCommand.on_shutdown
def shut_down_then_say(self):
    rclpy.shutdown()
    on_shutdown(self)
hand_nodes.build_hand = build_then_shut_down
Plant.publish_state = shut_down_then_publish
if WHERE == 'last words':
    PressureCommand.on_shutdown = shut_down_then_say
raise SystemExit(hand_nodes.main(['--fingers', 'index']))
"""


@pytest.mark.parametrize('where', ['timer', 'callback', 'last words'])
def test_nodes_shut_down_by_their_embedder_stop_without_last_words(ros_domain, tmp_path, where):
    # The command node's last words publish zero pressure; with the context gone that raised.
    # A callback that publishes as the context goes raised out of the spin loop.
    done = subprocess.run(
        [sys.executable, '-c', f'WHERE = {where!r}' + EMBEDDER],
        env=ros_environment(ros_domain),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert 'Traceback' not in done.stderr, done.stderr
