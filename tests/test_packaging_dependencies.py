"""exodigit_nodes declares every third-party module it imports, for pip and for rosdep.

Read from the sources, not from what this venv happens to have installed: every ``import`` in the
package's modules and launch files (also those inside functions, like the recorder's rosbags).
A ROS package is declared in package.xml by its own name; a Python library by its rosdep key
(``python3-<name>``, or ``python3-<name>-pip`` for a pip-only one) and in setup.py's
``install_requires``, which is what ``pip install ./exodigit_nodes`` reads.
"""

import ast
import functools
import re
import sys
import xml.etree.ElementTree as ElementTree
from importlib.metadata import packages_distributions
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[1] / 'exodigit_nodes'
SOURCES = sorted(
    [*(PACKAGE_DIR / 'exodigit_nodes').rglob('*.py'), *PACKAGE_DIR.glob('launch/*.py')]
)
PYTEST_PLUGIN = PACKAGE_DIR / 'exodigit_nodes' / 'testing' / 'plugin.py'
"""The testing kit's pytest11 entry point: pytest loads it, so it may rely on test_depends."""


def imported_modules(path: Path) -> set[str]:
    """Top-level names of the absolute imports in one source file."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name.partition('.')[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module.partition('.')[0])
    return names


def third_party(path: Path) -> set[str]:
    return imported_modules(path) - set(sys.stdlib_module_names) - {'exodigit_nodes'}


def package_xml(*tags: str) -> set[str]:
    root = ElementTree.parse(PACKAGE_DIR / 'package.xml').getroot()
    return {element.text.strip() for tag in tags for element in root.iter(tag)}


def normalized(name: str) -> str:
    """A distribution name as pip compares them (PEP 503)."""
    return re.sub(r'[-_.]+', '-', name).lower()


@functools.cache
def installed() -> dict[str, list[str]]:
    """Top-level module -> distributions installed here (reads every one: once a session)."""
    return packages_distributions()


def distributions(module: str) -> list[str]:
    """Names of the distributions that install ``module`` here (its own name if none does)."""
    return [normalized(name) for name in installed().get(module, [module])]


def install_requires() -> set[str]:
    """Normalized distribution names of setup.py's install_requires (versions dropped)."""
    tree = ast.parse((PACKAGE_DIR / 'setup.py').read_text())
    call = next(
        node
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and getattr(node.func, 'id', '') == 'setup'
    )
    requirements = next(k.value for k in call.keywords if k.arg == 'install_requires')
    return {
        normalized(re.split(r'[\s<>=!~;\[]', r, maxsplit=1)[0])
        for r in ast.literal_eval(requirements)
    }


def undeclared_by(rosdep_keys: set[str], pip_names: set[str]):
    """A function: what is missing to declare a module (a message), or None when nothing is."""

    def missing(module: str) -> str | None:
        if module in rosdep_keys:
            return None  # a ROS package (or a sibling package of the workspace), by its name
        needs = []
        if not {f'python3-{module}', f'python3-{module}-pip'} & rosdep_keys:
            needs.append(f'a rosdep key python3-{module}[-pip] in package.xml')
        if not set(distributions(module)) & pip_names:
            needs.append('install_requires in setup.py')
        return ' and '.join(needs) or None

    return missing


def test_the_sources_are_found_and_import_the_libraries_this_test_is_about():
    modules = set().union(*map(third_party, SOURCES))
    assert PYTEST_PLUGIN in SOURCES
    assert {'rclpy', 'numpy', 'matplotlib', 'rosbags', 'launch_ros'} <= modules


def test_every_third_party_module_the_package_imports_is_declared():
    run_keys = package_xml('exec_depend', 'depend')
    test_keys = package_xml('test_depend')
    pip_names = install_requires()
    # the test runner brings its own: pytest is installed by whoever runs the plugin
    runner = {key.removeprefix('python3-') for key in test_keys}
    problems = []
    for path in SOURCES:
        if path == PYTEST_PLUGIN:
            declared = undeclared_by(run_keys | test_keys, pip_names | runner)
        else:
            declared = undeclared_by(run_keys, pip_names)
        for module in sorted(third_party(path)):
            if missing := declared(module):
                problems.append(
                    f'{path.relative_to(PACKAGE_DIR)} imports {module}: needs {missing}'
                )
    assert not problems, '\n'.join(problems)


def test_the_check_names_what_a_module_lacks():
    assert undeclared_by({'rclpy'}, set())('rclpy') is None
    assert undeclared_by({'python3-rosbags-pip'}, {'rosbags'})('rosbags') is None
    assert undeclared_by(set(), {'matplotlib'})('matplotlib') == (
        'a rosdep key python3-matplotlib[-pip] in package.xml'
    )
    assert undeclared_by({'python3-matplotlib'}, set())('matplotlib') == (
        'install_requires in setup.py'
    )
    assert undeclared_by({'python3-yaml'}, {'pyyaml'})('yaml') is None  # PyYAML installs yaml
    assert undeclared_by(set(), set())('yaml') == (
        'a rosdep key python3-yaml[-pip] in package.xml and install_requires in setup.py'
    )
