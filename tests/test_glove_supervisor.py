"""The one supervisor (runners and testing kit) with real child processes, and how a process
is asked to stop and how its end is told (plain Python children, no ROS)."""

import os
import signal
import subprocess
import sys

import pytest
from exodigit_nodes.logic.lifetime import StopRequest, exit_status
from exodigit_nodes.runner.supervisor import Child, Supervisor
from exodigit_nodes.testing.processes import NodeProcess
from ros_harness import wait_until

WAIT = 10.0

# A child that logs "<name> stopped <time>" to a shared file when SIGINT arrives, then exits 0.
POLITE = """
import signal, sys, time
name, log = sys.argv[1], sys.argv[2]
def stop(*_):
    with open(log, 'a') as f:
        f.write(f'{name} {time.monotonic()}\\n')
    sys.exit(0)
signal.signal(signal.SIGINT, stop)
print('ready', flush=True)
while True:
    time.sleep(0.01)
"""
# A POLITE child that, told to stop, exits only once the file named by its third argument
# exists: the supervisor's ``idle`` callback creates it while it waits for the child.
WAITS_FOR_IDLE = """
import os, signal, sys, time
name, log, go = sys.argv[1:4]
def stop(*_):
    with open(log, 'a') as f:
        f.write(f'{name} {time.monotonic()}\\n')
    while not os.path.exists(go):
        time.sleep(0.01)
    sys.exit(0)
signal.signal(signal.SIGINT, stop)
print('ready', flush=True)
while True:
    time.sleep(0.01)
"""
# A supervisor of one POLITE child that prints the child's pid and waits to be killed.
PARENT = """
import os, sys, time
from pathlib import Path
from exodigit_nodes.runner.supervisor import Supervisor
log_dir, child_code, order_log = sys.argv[1:]
supervisor = Supervisor(os.environ, log_dir=Path(log_dir))
supervisor.start('plant', [sys.executable, '-c', child_code, 'plant', order_log])
print(supervisor.children['plant'].pid, flush=True)
time.sleep(600)
"""
STARTING = """
import time
print('ready', flush=True)
while True:
    time.sleep(0.01)
"""
# A node that is still importing when SIGINT comes: the import work runs where Python ignores
# exceptions (a weakref callback, as importlib's module locks have), then it handles the stop
# signals as every exodigit process does, and exits 0 at once if a stop was asked, 3 if not.
IMPORTING = """
import sys, time, weakref
from exodigit_nodes.logic.lifetime import StopRequest
class Module: pass
def imports(_):
    time.sleep(1.5)
module = Module()
reference = weakref.ref(module, imports)
print('ready', flush=True)
del module
stop = StopRequest()
deadline = time.monotonic() + 5.0
while not stop.requested and time.monotonic() < deadline:
    time.sleep(0.01)
sys.exit(0 if stop.requested else 3)
"""
STUBBORN = """
import signal, time
signal.signal(signal.SIGINT, signal.SIG_IGN)
print('ready', flush=True)
while True:
    time.sleep(0.01)
"""
# Deaf to SIGINT and SIGTERM: only SIGKILL ends it. It starts a grandchild in its group.
DEAF = """
import signal, subprocess, sys, time
signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.signal(signal.SIGTERM, signal.SIG_IGN)
grandchild = subprocess.Popen(['sleep', '600'])
print('ready', grandchild.pid, flush=True)
while True:
    time.sleep(0.01)
"""


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f'/proc/{pid}/stat') as stat:
        return stat.read().split()[2] != 'Z'


def ready(supervisor, name):
    return 'ready' in supervisor.children[name].log_path.read_text()


def test_processes_stop_in_the_given_order_with_sigint_and_idle_runs_meanwhile(tmp_path):
    order_log, go = tmp_path / 'order.log', tmp_path / 'go'
    supervisor = Supervisor(os.environ, log_dir=tmp_path / 'logs')
    for name in ('plant', 'estimator', 'pressure_command'):
        supervisor.start(name, [sys.executable, '-c', WAITS_FOR_IDLE, name, str(order_log), go])
    assert wait_until(lambda: all(ready(supervisor, n) for n in supervisor.children), WAIT)
    pids = [child.pid for child in supervisor.children.values()]
    # each child leads its own session, apart from the test's
    assert all(os.getsid(pid) == pid != os.getsid(0) for pid in pids)
    idle_calls = []

    def idle():
        idle_calls.append(1)
        go.touch()

    exits = supervisor.stop(['pressure_command', 'plant'], idle=idle)
    assert [e.name for e in exits] == ['pressure_command', 'plant', 'estimator']
    assert all(e.clean for e in exits)
    logged = [line.split()[0] for line in order_log.read_text().splitlines()]
    assert logged == ['pressure_command', 'plant', 'estimator']
    assert idle_calls
    assert not any(alive(pid) for pid in pids)
    assert supervisor.running() == []


def test_a_process_still_starting_when_sigint_comes_stops_cleanly(tmp_path):
    # No SIGINT handler of its own yet: Python's default ends it by the signal.
    supervisor = Supervisor(os.environ, log_dir=tmp_path)
    supervisor.start('plant', [sys.executable, '-c', STARTING])
    assert wait_until(lambda: ready(supervisor, 'plant'), WAIT)
    (exit_,) = supervisor.stop(['plant'])
    assert exit_.returncode == -signal.SIGINT
    assert exit_.clean


def test_a_sigint_while_a_node_imports_is_held_until_it_handles_it(tmp_path):
    # A KeyboardInterrupt raised inside the import work would be swallowed and the SIGINT lost.
    supervisor = Supervisor(os.environ, log_dir=tmp_path)
    supervisor.start('plant', [sys.executable, '-c', IMPORTING], defer_sigint=True)
    assert wait_until(lambda: ready(supervisor, 'plant'), WAIT)
    (exit_,) = supervisor.stop(['plant'], grace=WAIT)
    assert exit_.returncode == 0 and not exit_.forced, exit_.describe()


def test_children_are_interrupted_when_the_supervisor_is_killed(tmp_path):
    order_log = tmp_path / 'order.log'
    parent = subprocess.Popen(
        [sys.executable, '-c', PARENT, str(tmp_path), POLITE, str(order_log)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        child = int(parent.stdout.readline())
        assert wait_until(lambda: (tmp_path / 'plant.log').exists(), WAIT)
        assert wait_until(lambda: 'ready' in (tmp_path / 'plant.log').read_text(), WAIT)
        parent.kill()
        parent.wait()
        assert wait_until(lambda: not alive(child), WAIT)
        assert order_log.read_text().split()[0] == 'plant'  # it stopped through its SIGINT handler
    finally:
        parent.kill()
        parent.stdout.close()


def test_a_process_that_ignores_sigint_is_terminated_and_reported(tmp_path):
    supervisor = Supervisor(os.environ, log_dir=tmp_path)
    supervisor.start('stubborn', [sys.executable, '-c', STUBBORN])
    assert wait_until(lambda: ready(supervisor, 'stubborn'), WAIT)
    (exit_,) = supervisor.stop(['stubborn'], grace=0.5)
    assert exit_.forced and not exit_.clean
    assert exit_.returncode == -signal.SIGTERM  # SIGTERM ended it: SIGKILL was not needed
    assert 'killed by SIGTERM (did not stop on SIGINT)' in exit_.describe()


def test_a_child_takes_sigint_though_the_thread_that_started_it_blocks_it(tmp_path):
    # A Ray worker blocks SIGINT, and a child inherits the signals blocked where it was forked:
    # the testing kit's gloves in a Ray task waited out the grace period for SIGTERM.
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        supervisor = Supervisor(os.environ, log_dir=tmp_path)
        supervisor.start('plant', [sys.executable, '-c', POLITE, 'plant', str(tmp_path / 'x')])
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
    assert wait_until(lambda: ready(supervisor, 'plant'), WAIT)
    (exit_,) = supervisor.stop(['plant'], grace=WAIT)
    assert exit_.clean and exit_.returncode == 0, exit_.describe()


def test_an_unexpected_exit_is_seen_with_its_code_and_log(tmp_path):
    supervisor = Supervisor(os.environ, log_dir=tmp_path)
    supervisor.start('plant', [sys.executable, '-c', 'print("bad params_file"); exit(3)'])
    supervisor.start('estimator', [sys.executable, '-c', STUBBORN])
    assert wait_until(supervisor.exited, WAIT)
    (exit_,) = supervisor.exited()
    assert (exit_.name, exit_.returncode) == ('plant', 3)
    assert exit_.describe() == 'plant exited with code 3'
    assert 'bad params_file' in supervisor.children['plant'].log_path.read_text()
    assert supervisor.running() == ['estimator']
    supervisor.stop(['estimator'], grace=0.5)
    assert supervisor.running() == []


def test_a_process_deaf_to_sigint_and_sigterm_is_killed_with_its_group(tmp_path):
    child = Child('deaf', [sys.executable, '-c', DEAF], os.environ, log=tmp_path / 'deaf.log')
    assert wait_until(lambda: 'ready' in child.log_path.read_text(), WAIT)
    grandchild = int(child.log_path.read_text().split()[1])
    exit_ = child.stop(grace=0.2)
    assert exit_.returncode == -signal.SIGKILL
    assert exit_.forced and not exit_.clean
    assert exit_.describe() == 'deaf was killed by SIGKILL (did not stop on SIGINT)'
    assert wait_until(lambda: not alive(grandchild), WAIT)  # it went with the group
    assert child.stop() is exit_  # stopped once; asking again changes nothing


def test_a_child_can_keep_stderr_apart_and_run_in_a_directory(tmp_path):
    code = 'import os, sys; print(os.getcwd()); print("oops", file=sys.stderr)'
    child = Child(
        'split',
        [sys.executable, '-c', code],
        os.environ,
        log=tmp_path / 'logs' / 'split.out',
        errors=tmp_path / 'logs' / 'split.err',
        cwd=tmp_path,
    )
    assert child.wait(WAIT) == 0
    assert child.exit().clean
    assert child.log_path.read_text().strip() == str(tmp_path)
    assert child.errors_path.read_text().strip() == 'oops'


def test_the_testing_kit_starts_its_nodes_with_the_runners_supervisor(tmp_path):
    # A node that cannot start (no such module) ends at once; the kit tells how as a runner does.
    node = NodeProcess('no_such_node', None, domain_id=1, workdir=tmp_path)
    assert isinstance(node, Child)
    assert node.wait(WAIT) == 1
    assert node.exit().describe() == 'no_such_node exited with code 1'
    assert 'No module named' in node.stderr()


@pytest.mark.parametrize(
    ('returncode', 'words'),
    [
        (0, 'exited with code 0'),
        (2, 'exited with code 2'),
        (-9, 'was killed by SIGKILL'),
        (-2, 'was killed by SIGINT'),
        (-200, 'was killed by signal 200'),
    ],
)
def test_an_exit_status_is_told_in_words(returncode, words):
    assert exit_status(returncode) == words


def test_a_stop_request_unblocks_the_stop_signals_it_handles():
    # In a process of one thread, started with SIGINT blocked (a child of a Ray worker, started
    # by something else than our supervisor, e.g. ros2 launch): the StopRequest still hears it.
    script = """
import os, signal, time
from exodigit_nodes.logic.lifetime import StopRequest
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
stop = StopRequest()
os.kill(os.getpid(), signal.SIGINT)
deadline = time.monotonic() + 5.0
while not stop.requested and time.monotonic() < deadline:
    time.sleep(0.01)
print(stop.signal_name or 'nothing')
"""
    result = subprocess.run(
        [sys.executable, '-c', script], capture_output=True, text=True, timeout=60, check=True
    )
    assert result.stdout.strip() == 'SIGINT', result.stderr


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_stop_signal_sets_the_stop_request_and_nothing_is_raised(signum):
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        stop = StopRequest()
        assert not stop.requested
        os.kill(os.getpid(), signum)
        assert wait_until(lambda: stop.requested, WAIT)
        assert stop.signal_name == signal.Signals(signum).name
        stop.ignore()
        assert signal.getsignal(signum) == signal.SIG_IGN
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)
