"""The suite runs in a shell where ROS 2 is sourced.

``source /opt/ros/jazzy/setup.bash`` puts launch_testing and launch_testing_ros on PYTHONPATH, and
with them two pytest plugins (entry points ``pytest11``) that pytest 9 refuses at start-up:
``launch_testing``'s ``pytest_pycollect_makemodule(path, parent)`` names the removed ``path``
argument, and ``launch_ros``'s ``pytest_launch_collect_makemodule`` is a hook only the first one
declares. pytest.ini blocks both (``-p no:...``). Here fake distributions of the same shape, on
PYTHONPATH, show that a run with the project's configuration passes and one without it fails.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYTEST_INI = ROOT / 'pytest.ini'
RUN_TIMEOUT = 120
FAKE_PLUGINS = {
    # entry point name: (distribution, module, hook implementation)
    'launch_testing': (
        'fake_launch_testing',
        'fake_launch_testing_hooks',
        'def pytest_pycollect_makemodule(path, parent):\n    return None\n',
    ),
    'launch_ros': (
        'fake_launch_testing_ros',
        'fake_launch_testing_ros_entrypoint',
        'def pytest_launch_collect_makemodule(path, parent, entrypoint):\n    return None\n',
    ),
}


def write_distribution(site: Path, entry_point: str) -> None:
    """An installed distribution in ``site`` whose ``pytest11`` entry point is ``entry_point``."""
    distribution, module, source = FAKE_PLUGINS[entry_point]
    info = site / f'{distribution}-0.0.0.dist-info'
    info.mkdir(parents=True)
    (info / 'METADATA').write_text(
        f'Metadata-Version: 2.1\nName: {distribution}\nVersion: 0.0.0\n'
    )
    (info / 'entry_points.txt').write_text(f'[pytest11]\n{entry_point} = {module}\n')
    (site / f'{module}.py').write_text(source)


@pytest.fixture
def ros_sourced(tmp_path):
    """Run pytest on a one-test file with both fake ROS plugins on PYTHONPATH."""
    site = tmp_path / 'site-packages'
    for entry_point in FAKE_PLUGINS:
        write_distribution(site, entry_point)
    probe = tmp_path / 'probe'
    probe.mkdir()
    (probe / 'test_probe.py').write_text('def test_probe():\n    assert True\n')
    env = {k: v for k, v in os.environ.items() if not k.startswith('PYTEST_')}
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(site), env.get('PYTHONPATH')]))

    def run(config: Path) -> subprocess.CompletedProcess:
        command = [sys.executable, '-m', 'pytest', '-c', str(config), '--rootdir', str(probe)]
        command += ['-p', 'no:cacheprovider', '-q', str(probe / 'test_probe.py')]
        return subprocess.run(
            command, cwd=probe, env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT
        )

    return run


def test_the_suite_passes_with_the_ros_plugins_on_the_path(ros_sourced):
    result = ros_sourced(PYTEST_INI)
    assert result.returncode == 0, result.stdout + result.stderr
    assert '1 passed' in result.stdout


@pytest.mark.parametrize(
    ('addopts', 'complaint'),
    [
        ('', "Plugin 'launch_testing' for hook 'pytest_pycollect_makemodule'"),
        ('-p no:launch_testing', "unknown hook 'pytest_launch_collect_makemodule'"),
    ],
    ids=['no-configuration', 'launch_testing-blocked-only'],
)
def test_the_fake_plugins_break_a_run_without_the_projects_configuration(
    ros_sourced, tmp_path, addopts, complaint
):
    config = tmp_path / 'other.ini'
    config.write_text(f'[pytest]\naddopts = {addopts}\n')
    result = ros_sourced(config)
    assert result.returncode != 0
    assert complaint in result.stdout + result.stderr


def test_this_session_blocks_the_ros_plugins(pytestconfig):
    for name in FAKE_PLUGINS:
        assert pytestconfig.pluginmanager.is_blocked(name), name
