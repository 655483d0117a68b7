"""Every declared parameter of every glove node, tried at runtime with values it must refuse.

Each node class is built in this process with its defaults, in the probe's context (no second
DDS participant), and asked what its ListParameters, DescribeParameters, GetParameters and
SetParameters services would ask it: ``list_parameters``, ``describe_parameters``,
``get_parameters`` and, per parameter, ``set_parameters_atomically`` of
``Parameter.from_parameter_msg`` (rclpy's services do exactly that, and nothing more, for each
request). The services themselves answer over DDS from node processes in
tests/test_nodes_glove.py, test_nodes_command.py and test_reliability_faults.py.

Parameters are found by listing them, so a new parameter is covered as soon as it is declared.
For each one, `reliability_params.bad_values` derives from its descriptor alone: out-of-range
numbers, NaN and ±Inf, wrong types, unknown choices, joint vectors of the wrong length. Each must
be refused with a reason naming the parameter, and the node must keep the old value and raise
nothing. Read-only parameters refuse any change. A valid change of every writable parameter is
accepted (so a node that refuses everything fails), and the old value is put back.
"""

import math

import pytest
from exodigit_nodes.nodes.catalog import NODES as ENTRIES
from rcl_interfaces.msg import ParameterType, SetParametersResult
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter
from reliability_params import bad_values, other_valid_value, parameter, python_value, value

NAMESPACE = '/params'
NODES = ('plant', 'pressure_command', 'estimator')
#: Parameters rclpy itself declares. rclpy refuses a wrong type for them before any node callback
#: runs, with its own reason ("Wrong parameter type, expected 'Type.BOOL' got 'Type.STRING'"),
#: which does not name the parameter: that much is not the glove's to change.
RCLPY_PARAMETERS = ('use_sim_time',)


@pytest.fixture(scope='module')
def nodes(probe):
    """Each glove node, built with its defaults in the probe's context; nothing spins them."""
    classes = {entry.executable: entry.node_class() for entry in ENTRIES}
    built = {}
    try:
        for name in NODES:
            built[name] = classes[name](context=probe.context, namespace=NAMESPACE)
        yield built
    finally:
        for node in built.values():
            node.destroy_node()


def described(node) -> dict:
    names = node.list_parameters([], 0).names
    return dict(zip(names, node.describe_parameters(names), strict=True))


def current(node, names: list[str]) -> dict:
    return {p.name: p.get_parameter_value() for p in node.get_parameters(names)}


def set_each(node, parameters: list) -> list:
    """What SetParameters answers: each parameter message set on its own."""
    results = []
    for message in parameters:
        try:
            result = node.set_parameters_atomically([Parameter.from_parameter_msg(message)])
        except ParameterNotDeclaredException as error:
            result = SetParametersResult(successful=False, reason=str(error))
        results.append(result)
    return results


def same(a, b) -> bool:
    a, b = python_value(a), python_value(b)
    if isinstance(a, float) and math.isnan(a):
        return isinstance(b, float) and math.isnan(b)
    return a == b


@pytest.mark.parametrize('node', NODES)
def test_every_bad_value_of_every_parameter_is_refused_naming_it(nodes, node):
    descriptors = described(nodes[node])
    ours = sorted(set(descriptors) - set(RCLPY_PARAMETERS))
    assert ours, f'{node} declares no parameters'
    before = current(nodes[node], sorted(descriptors))
    tries = []
    for name, descriptor in sorted(descriptors.items()):
        assert descriptor.description or name in RCLPY_PARAMETERS, f'{node}.{name}: no description'
        cases = bad_values(descriptor)
        if descriptor.read_only:
            changed = other_valid_value(descriptor, before[name])
            cases.append(('a change of a read-only parameter', changed or before[name]))
        tries += [(name, what, parameter(name, bad)) for what, bad in cases]
    results = set_each(nodes[node], [p for _, _, p in tries])
    outcomes = list(zip(tries, results, strict=True))
    accepted = [f'{name} = {what}' for (name, what, _), r in outcomes if r.successful]
    assert accepted == [], f'{node} accepted: {accepted}'
    unnamed = [
        f'{name} = {what}: {r.reason!r}'
        for (name, what, _), r in outcomes
        if name not in r.reason and name not in RCLPY_PARAMETERS
    ]
    assert unnamed == [], f'{node} refused without naming the parameter: {unnamed}'
    after = current(nodes[node], sorted(descriptors))
    changed = [name for name in descriptors if not same(before[name], after[name])]
    assert changed == [], f'{node} changed {changed} although every set was refused'


@pytest.mark.parametrize('node', NODES)
def test_a_valid_change_of_every_writable_parameter_is_accepted(nodes, node):
    descriptors = described(nodes[node])
    names = sorted(set(descriptors) - set(RCLPY_PARAMETERS))
    before = current(nodes[node], names)
    changes = {}
    for name in names:
        descriptor = descriptors[name]
        valid = other_valid_value(descriptor, before[name])
        if not descriptor.read_only and valid is not None:
            changes[name] = valid
    assert changes, f'{node}: no writable parameter with a known valid value'
    try:
        for name, new in changes.items():
            result = set_each(nodes[node], [parameter(name, new)])[0]
            assert result.successful, f'{node}.{name} = {python_value(new)}: {result.reason}'
            assert same(current(nodes[node], [name])[name], new)
    finally:
        set_each(nodes[node], [parameter(name, before[name]) for name in changes])
    after = current(nodes[node], names)
    assert all(same(before[n], after[n]) for n in changes), 'old values not restored'


@pytest.mark.parametrize('node', NODES)
def test_use_sim_time_can_be_switched_at_runtime(nodes, node):
    def sim_time(on: bool) -> list:
        return [parameter('use_sim_time', value(ParameterType.PARAMETER_BOOL, on))]

    results = set_each(nodes[node], sim_time(True))
    set_each(nodes[node], sim_time(False))
    assert results[0].successful, f'{node}: use_sim_time := true refused: {results[0].reason}'
