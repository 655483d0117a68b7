"""ros_ws/ is a colcon workspace reaching both packages; colcon builds it into a ROS install space.

The build runs when colcon is installed in the same environment as rclpy (requirements/dev.txt
installs colcon-common-extensions in the venv); it is skipped, with the reason, otherwise.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ('exodigit_model', 'exodigit_nodes')
NODE_EXECUTABLES = ('plant', 'pressure_command', 'estimator')
COLCON = shutil.which('colcon', path=str(Path(sys.executable).parent))
BUILD_TIMEOUT = 600


def test_workspace_sources_are_relative_links_to_the_packages():
    for package in PACKAGES:
        link = ROOT / 'ros_ws' / 'src' / package
        assert link.is_symlink(), f'{link} is not a symlink'
        target = os.readlink(link)
        assert not os.path.isabs(target), f'{link} -> {target} is absolute'
        assert link.resolve() == (ROOT / package).resolve()
        assert (link / 'package.xml').is_file()


@pytest.fixture(scope='module')
def built_workspace(tmp_path_factory):
    """A copy of the workspace (and the packages it links to) after ``colcon build``."""
    if COLCON is None:
        pytest.skip(f'colcon is not installed next to {sys.executable} (colcon-common-extensions)')
    root = tmp_path_factory.mktemp('colcon')
    ignore = shutil.ignore_patterns('*.egg-info', '__pycache__', 'build', 'install', 'log')
    for package in PACKAGES:
        shutil.copytree(ROOT / package, root / package, ignore=ignore)
    shutil.copytree(ROOT / 'ros_ws', root / 'ros_ws', symlinks=True, ignore=ignore)
    workspace = root / 'ros_ws'
    result = subprocess.run(
        [COLCON, 'build'], cwd=workspace, capture_output=True, text=True, timeout=BUILD_TIMEOUT
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return workspace


def test_colcon_installs_the_node_executables_where_ros2_run_finds_them(built_workspace):
    lib = built_workspace / 'install' / 'exodigit_nodes' / 'lib' / 'exodigit_nodes'
    for executable in (*NODE_EXECUTABLES, 'glove'):
        path = lib / executable
        assert path.is_file() and os.access(path, os.X_OK), path
        assert 'python' in path.read_text().splitlines()[0]


def test_colcon_installs_launch_config_and_index_files(built_workspace):
    install = built_workspace / 'install'
    share = install / 'exodigit_nodes' / 'share' / 'exodigit_nodes'
    assert (share / 'launch' / 'glove.launch.py').is_file()
    assert (share / 'package.xml').is_file()
    sources = sorted(p.name for p in (ROOT / 'exodigit_nodes' / 'config').glob('*.yaml'))
    assert sources and sorted(p.name for p in (share / 'config').glob('*.yaml')) == sources
    for package in PACKAGES:
        index = install / package / 'share' / 'ament_index' / 'resource_index' / 'packages'
        assert (index / package).is_file()


def test_sourced_install_space_resolves_the_package_share_and_runs_the_glove(built_workspace):
    install = built_workspace / 'install'
    script = (
        f'source {install}/setup.bash && '
        f'{sys.executable} -c "'
        'from ament_index_python.packages import get_package_share_directory as share; '
        'import exodigit_nodes; '
        "print(share('exodigit_nodes')); print(exodigit_nodes.__file__)\" && "
        f'{install}/exodigit_nodes/lib/exodigit_nodes/glove --help'
    )
    result = subprocess.run(['bash', '-c', script], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    share, module, *help_text = result.stdout.splitlines()
    assert Path(share) == install / 'exodigit_nodes' / 'share' / 'exodigit_nodes'
    assert Path(module).is_relative_to(install)
    assert any('--duration' in line for line in help_text)
