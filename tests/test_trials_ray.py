"""Trials on Ray (issue 17, item 5): the shards as Ray tasks, the same results as in process.

One Ray instance for the module, started by the engine on 127.0.0.1 with two worker processes
(a few seconds); a second engine with one worker shares its connection. Checked: every
listening socket of the instance is on the loopback address, the per-patient results of 1 and
2 workers equal the local engine's bit for bit, the workers use this process's kernel cache, a
failing shard is named, without Ray the error names the extra, and a ROS node controller's
trial on a Ray worker gives the in-process trial's results.
"""

import ipaddress
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from exodigit_model.kernels import jit
from exodigit_model.trials import METRICS, ControllerSpec, LocalEngine, TrialSpec, run_trial
from exodigit_model.trials.ray_engine import RayEngine, ShardError
from exodigit_nodes.testing.trial_engine import kit_shard, ros_controller
from test_trial_ros import NOT_REPORTED, ROUNDING

from exodigit_model import SimulationSettings

DASHBOARD_PORT = 8265
"""Ray's dashboard port: nothing may listen there."""

LISTEN = '0A'
"""The LISTEN state in /proc/net/tcp{,6}."""


def trial(**changes) -> TrialSpec:
    """12 patients in shards of 4, a 40-step session with sensor noise (seeded per shard)."""
    fields = {
        'population': 'stroke_moderate',
        'patients': 12,
        'seed': 5,
        'shard_size': 4,
        'protocol_parameters': {'duration': 0.4},
        'simulation': SimulationSettings(angle_noise_std=2e-3, pressure_noise_std=200.0),
    }
    return TrialSpec(**(fields | changes))


@pytest.fixture(scope='module')
def engine():
    """The module's Ray instance: two workers, bound to 127.0.0.1, stopped at the end."""
    with RayEngine(workers=2) as started:
        yield started
    assert not sys.modules['ray'].is_initialized()


@pytest.fixture
def ray(engine):
    """Ray, as the engine imported it (importing it first would refuse a local instance)."""
    return sys.modules['ray']


def process_tree(root: int) -> set[int]:
    """``root`` and every process descending from it (read from /proc)."""
    children: dict[int, list[int]] = {}
    for stat in Path('/proc').glob('[0-9]*/stat'):
        try:
            fields = stat.read_text().rsplit(')', 1)[1].split()
        except OSError:  # the process ended
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    tree, frontier = set(), [root]
    while frontier:
        pid = frontier.pop()
        tree.add(pid)
        frontier += children.get(pid, [])
    return tree


def socket_inodes(pids: set[int]) -> dict[str, int]:
    """The socket inodes the processes hold, each with its process."""
    inodes = {}
    for pid in pids:
        for fd in Path(f'/proc/{pid}/fd').glob('*'):
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith('socket:['):
                inodes[target[8:-1]] = pid
    return inodes


def listening_sockets() -> list[tuple[ipaddress.IPv4Address | ipaddress.IPv6Address, int, str]]:
    """Every listening TCP socket of this machine: (address, port, inode)."""
    sockets = []
    for table in ('/proc/net/tcp', '/proc/net/tcp6'):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            local, state, inode = fields[1], fields[3], fields[9]
            if state != LISTEN:
                continue
            host, port = local.split(':')
            # the kernel prints each 32-bit word of the address in the machine's byte order
            words = [bytes.fromhex(host[i : i + 8])[::-1] for i in range(0, len(host), 8)]
            sockets.append((ipaddress.ip_address(b''.join(words)), int(port, 16), inode))
    return sockets


def loopback(address: ipaddress.IPv4Address | ipaddress.IPv6Address) -> bool:
    mapped = getattr(address, 'ipv4_mapped', None)
    return (mapped or address).is_loopback


def assert_same_patients(a, b):
    assert (a.steps, a.settings) == (b.steps, b.settings)
    for metric in METRICS:
        np.testing.assert_array_equal(a.values[metric.name], b.values[metric.name], metric.name)


def test_the_instance_listens_on_127_0_0_1_only(engine):
    engine.map(trial(), [0, 1], lambda *_: None)  # both workers are up and serving
    held = socket_inodes(process_tree(os.getpid()))
    ours = [(address, port) for address, port, inode in listening_sockets() if inode in held]
    # the GCS, the raylet's two servers, this driver's and each worker's gRPC server at least
    assert len(ours) >= 5, ours
    assert [entry for entry in ours if not loopback(entry[0])] == []
    assert DASHBOARD_PORT not in {port for _, port in ours}


@pytest.mark.parametrize('workers', [1, 2])
def test_per_patient_results_are_the_local_ones_bit_for_bit(ray, workers):
    spec = trial()
    local = run_trial(spec, progress=False)
    with RayEngine(workers=workers) as sharing:  # the module's connection, `workers` at once
        done = []
        parts = sharing.map(spec, [2, 0, 1], lambda index, part: done.append((index, len(part))))
        remote = run_trial(spec, engine=sharing, progress=False)
    assert ray.is_initialized()  # left open: the engine found it
    assert sorted(done) == [(0, 4), (1, 4), (2, 4)]
    assert [len(part) for part in parts] == [4, 4, 4]
    assert_same_patients(parts[0], LocalEngine().map(spec, [2], lambda *_: None)[0])
    assert_same_patients(remote.metrics, local.metrics)
    assert remote.summary == local.summary


def test_the_workers_use_this_processs_kernel_cache(ray):
    assert jit.JIT
    workers_cache = ray.remote(lambda: jit.cache_directory()).remote()
    assert ray.get(workers_cache) == jit.cache_directory()


def test_a_failing_shard_is_named(engine, ray, tmp_path):
    factory = tmp_path / 'three_only.py'
    factory.write_text(
        textwrap.dedent(
            """
            import numpy as np

            class ThreeOnly:
                def reset(self, count, rng=None):
                    if count != 3:
                        raise ValueError(f'made for 3 gloves, not {count}')

                def command(self, t, dt, state):
                    return np.zeros((3, 3))

            def make(protocol, model):
                return ThreeOnly()
            """
        )
    )
    controller = ControllerSpec('controller', f'{factory}:make')
    spec = trial(patients=8, shard_size=3, controller=controller)
    failed = r'shard 2 \(patients 6 … 7\) failed on Ray: ValueError: made for 3 gloves, not 2'
    with pytest.raises(ShardError, match=failed) as caught:
        engine.map(spec, [0, 1, 2], lambda *_: None)
    assert (caught.value.index, caught.value.patients) == (2, (6, 8))
    assert isinstance(caught.value.__cause__, ray.exceptions.RayTaskError)


def test_bad_arguments_are_refused(engine):
    for workers in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match='workers'):
            RayEngine(workers=workers)
    with pytest.raises(ValueError, match='already initialized'):
        RayEngine(address='127.0.0.1:6379')


def test_without_ray_the_error_names_the_extra():
    script = textwrap.dedent(
        """
        import sys
        import exodigit_model, exodigit_model.trials, exodigit_model.trials.ray_engine
        from exodigit_model.tools import cli
        assert 'ray' not in sys.modules, 'imported ray'
        sys.modules['ray'] = None  # as if it were not installed
        from exodigit_model.trials.ray_engine import RayEngine
        try:
            RayEngine()
        except ModuleNotFoundError as error:
            print(error.name, error)
        """
    )
    result = subprocess.run(
        [sys.executable, '-c', script], capture_output=True, text=True, timeout=120, check=True
    )
    assert result.stdout.strip() == (
        'ray ray is not installed; the Ray engine needs the ray extra: '
        'pip install "./exodigit_model[ray]"'
    )


# The in-process run's position controller warns that a stiff patient's feed-forward is
# beyond the supply: the trial compares the two engines, beyond the supply included.
@pytest.mark.filterwarnings('ignore::exodigit_model.physics.validity.OutsideModelWarning')
def test_a_ros_node_trial_on_a_ray_worker_gives_the_in_process_results(ray):
    # The task runs its shard's glove through the testing kit on the worker's machine
    # (kit_shard). The user's node is pressure_command in position mode, the in-process
    # trial's position mode in a node: the metrics a node can report agree with the in-process
    # trial's to rounding (tests/test_trial_ros.py says why not bit for bit). One patient:
    # how the engine spreads shards over workers is the same for any shard function (above).
    def spec(controller: ControllerSpec) -> TrialSpec:
        return TrialSpec(
            patients=1,
            seed=4,
            protocol='grasp',
            protocol_parameters={'duration': 0.5, 'close_time': 0.3, 'hold_time': 0.1},
            controller=controller,
        )

    node = [sys.executable, '-m', 'exodigit_nodes.nodes.pressure_command']
    ros = spec(ros_controller(node, mode='position', lockstep=True))
    with RayEngine(workers=2, shard=kit_shard) as spread:  # the module's connection
        (kit,) = spread.map(ros, [0], lambda *_: None)
    (local,) = LocalEngine().map(spec(ControllerSpec('mode', 'position')), [0], lambda *_: None)
    assert kit.steps == local.steps
    for metric in METRICS:
        expected = 0 if metric.name in NOT_REPORTED else local.values[metric.name]
        np.testing.assert_allclose(
            kit.values[metric.name], expected, rtol=ROUNDING, atol=ROUNDING, err_msg=metric.name
        )
    assert kit.values['rom_rad'][0, 1] > 0.01  # the finger moved
