"""The example user package (examples/my_glove_controller) as its user runs it.

Its tests run from a copy outside this repository (so its own pytest.ini is the configuration
and the ``glove_sim`` fixture comes from the installed ``exodigit_nodes`` plugin, not from our
conftest). Its launch_testing example needs ``launch_testing`` (a ROS 2 install): here it is only
compiled, and it runs only where ``launch_testing`` and colcon are importable (skipped, with the
reason, otherwise).
"""

import importlib.util
import os
import py_compile
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / 'examples' / 'my_glove_controller'
LAUNCH_TEST = EXAMPLE / 'test' / 'glove_sim_launch.test.py'
RUN_TIMEOUT = 600
COLCON = shutil.which('colcon', path=str(Path(sys.executable).parent))


def user_environment(package: Path | None = None) -> dict[str, str]:
    """Our environment (our domain, loopback discovery), with ``package`` importable."""
    env = dict(os.environ)
    if package is not None:
        env['PYTHONPATH'] = str(package)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('PYTEST_ADDOPTS', None)
    return env


def test_the_example_packages_own_tests_pass_with_the_installed_fixture(tmp_path):
    package = tmp_path / 'my_glove_controller'
    shutil.copytree(EXAMPLE, package, ignore=shutil.ignore_patterns('__pycache__'))
    result = subprocess.run(
        [sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider', '-p', 'no:randomly'],
        cwd=package,
        env=user_environment(package),
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT,
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-4000:]
    summary = output.strip().splitlines()[-1]
    assert '2 passed' in summary and 'skipped' not in summary, summary


def test_the_launch_testing_example_compiles(tmp_path):
    py_compile.compile(str(LAUNCH_TEST), cfile=str(tmp_path / 'launch.pyc'), doraise=True)


def test_the_launch_testing_example_passes_on_a_ros_install(tmp_path):
    missing = [
        name
        for name, found in (
            ('launch_testing', importlib.util.find_spec('launch_testing')),
            ('colcon', COLCON),
        )
        if found is None
    ]
    if missing:
        pytest.skip(f'{" and ".join(missing)} not installed here (a ROS 2 install has them)')
    workspace = tmp_path / 'ws'
    ignore = shutil.ignore_patterns('*.egg-info', '__pycache__', 'build', 'install', 'log')
    for package in (ROOT / 'exodigit_model', ROOT / 'exodigit_nodes', EXAMPLE):
        shutil.copytree(package, workspace / 'src' / package.name, ignore=ignore)
    build = subprocess.run(
        [COLCON, 'build'], cwd=workspace, capture_output=True, text=True, timeout=RUN_TIMEOUT
    )
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    test = f'src/my_glove_controller/test/{LAUNCH_TEST.name}'
    script = f'source install/setup.bash && launch_test {test}'
    result = subprocess.run(
        ['bash', '-c', script],
        cwd=workspace,
        env=user_environment(),
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT,
    )
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-4000:]
