"""The layers of exodigit_nodes import one way: logic <- nodes <- runner <- testing.

``logic`` (ROS-free rules: inputs, watchdog, estimation window, pacing, parameter tables) imports
no other layer; ``nodes`` (the rclpy nodes, their tables, QoS and DDS profile) only ``logic``;
``runner`` (the glove and hand runners' sessions) ``logic`` and ``nodes``; ``testing`` (the kit)
those three (it holds a plant as the runners do). Read from the sources (no import), so a cycle
cannot hide behind import order.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / 'exodigit_nodes' / 'exodigit_nodes'
#: Which other layers each layer may import.
ALLOWED = {
    'logic': set(),
    'nodes': {'logic'},
    'runner': {'logic', 'nodes'},
    'testing': {'logic', 'nodes', 'runner'},
}


def layers_imported(source: str, layer: str) -> set[str]:
    """The other layers of exodigit_nodes that a module of ``layer`` with ``source`` imports."""
    package = ['exodigit_nodes', layer]
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level:
            # "from ..nodes.qos import A" in exodigit_nodes/runner/x.py: exodigit_nodes.nodes.qos
            full = package[: len(package) - node.level + 1] + (node.module or '').split('.')
            full = [part for part in full if part]
            found.update(full[1:2] if len(full) > 1 else (a.name for a in node.names))
        elif isinstance(node, ast.ImportFrom) and (node.module or '').startswith(
            'exodigit_nodes.'
        ):
            found.add(node.module.split('.')[1])
        elif isinstance(node, ast.Import):
            names = (a.name for a in node.names if a.name.startswith('exodigit_nodes.'))
            found.update(name.split('.')[1] for name in names)
    return (found & set(ALLOWED)) - {layer}


@pytest.mark.parametrize('layer', sorted(ALLOWED))
def test_each_layer_imports_only_the_layers_below_it(layer):
    modules = sorted((PACKAGE / layer).glob('*.py'))
    assert modules, f'no modules in {layer}'
    wrong = {
        path.name: sorted(layers_imported(path.read_text(), layer) - ALLOWED[layer])
        for path in modules
    }
    assert {name: layers for name, layers in wrong.items() if layers} == {}


@pytest.mark.parametrize(
    ('source', 'layers'),
    [
        ('from ..nodes.qos import A', {'nodes'}),
        ('from .summary import B', set()),
        ('from .. import logic', {'logic'}),
        ('from exodigit_nodes.testing import GloveSim', {'testing'}),
        ('import exodigit_nodes.nodes.plant', {'nodes'}),
        ('from exodigit_model import GloveModel', set()),
    ],
)
def test_imports_are_read_as_python_resolves_them(source, layers):
    # the rule above is only as good as its reading of relative and absolute imports
    assert layers_imported(source, 'runner') == layers
