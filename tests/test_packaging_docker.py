"""Static checks of docker/ (no Docker engine on these machines: the image is not built here)."""

import re
import subprocess
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCKER = ROOT / 'docker'


def instructions() -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) pairs of the Dockerfile, continuation lines joined."""
    text = re.sub(r'\\\n', ' ', (DOCKER / 'Dockerfile').read_text())
    pairs = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith('#'):
            keyword, _, rest = line.partition(' ')
            pairs.append((keyword.upper(), rest.strip()))
    return pairs


def steps_of(keyword: str) -> list[tuple[str, str]]:
    return [step for step in instructions() if step[0] == keyword]


def test_dockerfile_builds_the_workspace_on_the_ros_base_image():
    steps = instructions()
    keywords = [k for k, _ in steps]
    assert steps[0] == ('ARG', 'ROS_DISTRO=jazzy')
    assert ('FROM', 'ros:${ROS_DISTRO}-ros-base') in steps
    run = ' '.join(args for k, args in steps if k == 'RUN')
    assert 'rosdep install --from-paths src --ignore-src -y' in run
    assert 'colcon build' in run
    assert run.index('rosdep install') < run.index('colcon build')
    assert keywords.index('ENTRYPOINT') > keywords.index('RUN')
    assert ('CMD', '["ros2", "launch", "exodigit_nodes", "glove.launch.py"]') in steps


def test_dockerfile_copies_both_packages_and_the_entrypoint_from_existing_paths():
    copies = [args.split() for k, args in steps_of('COPY')]
    sources = {c[0] for c in copies}
    assert {'exodigit_model', 'exodigit_nodes', 'docker/entrypoint.sh'} <= sources
    for source in sources:
        assert (ROOT / source).exists(), source
    for package in ('exodigit_model', 'exodigit_nodes'):
        assert [package, f'src/{package}'] in copies


def test_entrypoint_sources_both_setups_then_execs_the_command():
    script = DOCKER / 'entrypoint.sh'
    assert script.stat().st_mode & 0o111, 'entrypoint.sh is not executable'
    subprocess.run(['bash', '-n', str(script)], check=True)
    lines = [line.strip() for line in script.read_text().splitlines()]
    ros = lines.index('source "/opt/ros/${ROS_DISTRO}/setup.bash"')
    overlay = lines.index('source "${WORKSPACE}/install/setup.bash"')
    assert ros < overlay < lines.index('exec "$@"')


def test_docker_stop_sends_sigint_so_the_nodes_stop_cleanly():
    # On SIGTERM (docker stop's default) ros2 launch exits and leaves its nodes to be killed with
    # the container; on SIGINT it stops them, and pressure_command sends zero pressure.
    steps = instructions()
    keywords = [k for k, _ in steps]
    assert [args for k, args in steps if k == 'STOPSIGNAL'] == ['SIGINT']
    last_from = len(keywords) - 1 - keywords[::-1].index('FROM')
    assert keywords.index('STOPSIGNAL') > last_from, 'STOPSIGNAL is not in the final stage'
    compose = yaml.safe_load((DOCKER / 'compose.yaml').read_text())
    for name, service in compose['services'].items():
        assert service.get('stop_signal', 'SIGINT') == 'SIGINT', name


def test_compose_keeps_the_container_off_the_host_network():
    compose = yaml.safe_load((DOCKER / 'compose.yaml').read_text())
    for name, service in compose['services'].items():
        assert service.get('network_mode') != 'host', name
        assert 'ROS_DOMAIN_ID' in service['environment'], name
        assert service['build']['dockerfile'] == 'docker/Dockerfile'
        assert (DOCKER / service['build']['context'] / service['build']['dockerfile']).is_file()
