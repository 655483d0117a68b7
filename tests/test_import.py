"""What importing the packages pulls in: never ROS into the model, numba only where it steps."""

import subprocess
import sys

import pytest

import exodigit_model


def modules_after(statement: str, roots: set[str]) -> list[str]:
    """The modules of the packages ``roots`` loaded by a fresh interpreter after ``statement``."""
    code = (
        f'import sys; {statement}; '
        f'print(sorted(m for m in sys.modules if m.split(".")[0] in {sorted(roots)!r}))'
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return eval(result.stdout)  # a printed list of module names


def test_importing_the_model_and_every_public_name_imports_no_ros():
    statement = 'import exodigit_model as m; [getattr(m, name) for name in m.__all__]'
    loaded = modules_after(statement, {'rclpy', 'rosidl_runtime_py', 'std_msgs', 'sensor_msgs'})
    assert loaded == []


@pytest.mark.parametrize(
    'module',
    [
        'exodigit_nodes.nodes.recorder',
        'exodigit_nodes.runner.monitor',
        'exodigit_nodes.glove',
        'exodigit_nodes.hand',
        'exodigit_nodes.nodes.pressure_command',
    ],
)
def test_a_process_that_steps_no_glove_imports_no_numba(module):
    # numba costs a process about 0.45 s of CPU and 100 MB (docs/compiled.md): the
    # recorder and the runners load none of the model's kernels, so they must not import it.
    assert modules_after(f'import {module}', {'numba', 'llvmlite'}) == []


def test_the_stepping_modules_do_import_numba():
    # The check above can fail: importing the stepper does load numba.
    assert 'numba' in modules_after('import exodigit_model.stepping.simulation', {'numba'})


def test_every_public_name_resolves_and_is_listed():
    # Each name is imported from the module its table row names: a wrong row raises here.
    for name in exodigit_model.__all__:
        assert getattr(exodigit_model, name) is not None
        assert name in dir(exodigit_model)


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="has no attribute 'GloveModle'"):
        exodigit_model.GloveModle  # noqa: B018


@pytest.mark.parametrize(('mode', 'imports'), [('sine', False), ('position', True)])
def test_pressure_command_loads_the_model_only_for_a_controller_that_needs_it(
    mode, imports, ros_domain
):
    # The feed-forward of position and force mode needs the model's kernels; the other modes
    # start without numba (about half a node's start-up CPU). The node joins the session's
    # domain (ros_domain exports it), on loopback only (conftest).
    statement = (
        'import rclpy; from exodigit_nodes.nodes.pressure_command import PressureCommand; '
        'rclpy.init(); '
        f"PressureCommand(parameter_overrides=[rclpy.parameter.Parameter('mode', value={mode!r})])"
    )
    assert bool(modules_after(statement, {'numba'})) is imports
