"""The layers of exodigit_model import one way, and no module imports itself back.

From the bottom: ``base`` (the checks, the optional extras, the compiled kernels), ``physics``
(the paper's model and its extensions: parameters, material, solve, inverse, air, patients and
their populations), ``stepping`` (a glove in time: settings, chambers, the stepper, the joiner),
``control`` (controllers, the safety limiter, the valve loop, target cycles), then the
applications, each of which may use those before it: ``gym`` (Gymnasium environments),
``trials`` (virtual-patient trials, whose policies run in a Gymnasium environment) and
``tools`` (the ``exodigit`` command, figures, reports, calibration). A module imports from its
own layer and those below, never the package's root (which re-exports the public names), and
the modules import one another without a circle. Read from the sources (no import), counting
imports inside functions (they run too) but not those only for type checkers.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / 'exodigit_model' / 'exodigit_model'
ROOT = 'exodigit_model'
LAYERS = ('base', 'physics', 'stepping', 'control', 'gym', 'trials', 'tools')
"""Bottom first: a module may import from its own layer and those before it."""
BASE = ('checks', 'compiling', 'extras', 'kernels')
"""The top-level modules and packages of the bottom layer."""


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix('').parts)
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def layer_of(module: str) -> str | None:
    """The layer of a module of the package (None for the root package itself)."""
    parts = module.split('.')
    if len(parts) == 1:
        return None
    return 'base' if parts[1] in BASE else parts[1]


def type_checking_only(tree: ast.Module) -> set[ast.AST]:
    """The nodes inside ``if TYPE_CHECKING:`` blocks."""
    hidden = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, 'id', None) == 'TYPE_CHECKING':
            for child in node.body:
                hidden.update(ast.walk(child))
    return hidden


def imports(source: str, module: str, *, package: bool = False) -> set[str]:
    """The modules of exodigit_model that ``module`` imports (``package``: it is an __init__)."""
    here = module.split('.') if package else module.split('.')[:-1]
    tree = ast.parse(source)
    hidden = type_checking_only(tree)
    found = set()
    for node in ast.walk(tree):
        if node in hidden:
            continue
        if isinstance(node, ast.ImportFrom):
            base = here[: len(here) - node.level + 1] if node.level else []
            target = '.'.join([*base, *filter(None, (node.module or '').split('.'))])
            submodules = [f'{target}.{alias.name}' for alias in node.names]
            known = [name for name in submodules if resolves(name)]
            found.update(known or [target])
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return {name for name in found if name == ROOT or name.startswith(ROOT + '.')} - {module}


def resolves(module: str) -> bool:
    """Whether ``module`` is a module or package of exodigit_model."""
    path = PACKAGE.parent / module.replace('.', '/')
    return path.with_suffix('.py').exists() or (path / '__init__.py').exists()


def graph() -> dict[str, set[str]]:
    """Every module of the package and the package modules it imports."""
    found = {}
    for path in sorted(PACKAGE.rglob('*.py')):
        name = module_name(path)
        found[name] = imports(path.read_text(), name, package=path.name == '__init__.py')
    return found


def test_each_module_imports_only_its_layer_and_those_below():
    wrong = {}
    for module, imported in graph().items():
        layer = layer_of(module)
        if layer is None:
            continue
        above = [
            name
            for name in imported
            if layer_of(name) is None or LAYERS.index(layer_of(name)) > LAYERS.index(layer)
        ]
        if above:
            wrong[module] = sorted(above)
    assert wrong == {}


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in edges.get(node, ()):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                other = stack.pop()
                on_stack.discard(other)
                component.append(other)
                if other == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(edges):
        if node not in index:
            visit(node)
    return found


def test_no_module_imports_itself_back_through_others():
    assert cycles(graph()) == []


@pytest.mark.parametrize(
    ('source', 'module', 'expected'),
    [
        ('from ..physics.model import GloveModel', 'exodigit_model.gym.env', 'physics.model'),
        ('from .model import GloveModel', 'exodigit_model.physics.params', 'physics.model'),
        ('from .. import compiling', 'exodigit_model.tools.warm', 'compiling'),
        ('from . import valves', 'exodigit_model.tools.cli', 'tools.valves'),
        ('from exodigit_model import GloveModel', 'exodigit_model.tools.cli', ''),
        ('import exodigit_model.gym.env', 'exodigit_model.tools.cli', 'gym.env'),
        ('if TYPE_CHECKING:\n    from .model import X', 'exodigit_model.physics.params', None),
        ('def f():\n    from ..trials import spec', 'exodigit_model.gym.env', 'trials.spec'),
    ],
)
def test_imports_are_read_as_python_resolves_them(source, module, expected):
    # the rules above are only as good as this reading of relative and absolute imports
    found = imports(source, module)
    assert found == (set() if expected is None else {f'{ROOT}.{expected}'.rstrip('.')})


def test_cycles_are_found_in_a_small_graph():
    edges = {'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}
    assert cycles(edges) == [['a', 'b', 'c']]
