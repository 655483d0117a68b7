"""Parameter loading and validation (docs/spec/model.md §10, issue 2 "Parameters")."""

import copy
import math
import re
from pathlib import Path

import pytest
from model_reference import SEGMENT_LENGTH_KEYS, SPEC_DEFAULTS

from exodigit_model import ParameterError, dump_params, load_params, params_from_dict


def _with(path, value):
    """The defaults (docs/spec/model.md §10) with the entry at ``path`` set to ``value``."""
    data = copy.deepcopy(SPEC_DEFAULTS)
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return data


def _message(data):
    with pytest.raises(ParameterError) as caught:
        params_from_dict(data)
    return str(caught.value)


def test_defaults_equal_the_specification_section_10():
    assert load_params().to_dict() == SPEC_DEFAULTS


def test_the_full_specification_dict_builds_the_defaults():
    assert params_from_dict(SPEC_DEFAULTS) == load_params()


def test_the_specifications_parameter_file_is_the_defaults(tmp_path):
    # docs/spec/model.md §10 prints the default file; read as a user's file, it is what it says.
    spec = (Path(__file__).resolve().parents[1] / 'docs' / 'spec' / 'model.md').read_text()
    section = spec[spec.index('## 10.') : spec.index('# Part II')]
    printed = tmp_path / 'printed.yaml'
    printed.write_text(re.search(r'```yaml\n(.*?)```', section, re.S).group(1))
    assert params_from_dict(SPEC_DEFAULTS) == load_params(printed)


def test_parameter_error_is_a_value_error():
    assert issubclass(ParameterError, ValueError)


def test_unknown_top_level_key_is_named():
    data = copy.deepcopy(SPEC_DEFAULTS)
    data['glove'] = {}
    message = _message(data)
    assert 'glove' in message and 'unknown' in message


def test_unknown_nested_key_is_named():
    message = _message({'material': {'c4': 1.0}})
    assert 'c4' in message and 'unknown' in message


def test_unknown_key_inside_a_segment_is_named():
    segments = [{}, {'radius': 0.01}, {}]
    message = _message({'exo_digit': {'segments': segments}})
    assert 'radius' in message and 'unknown' in message


@pytest.mark.parametrize('count', [2, 4])
@pytest.mark.parametrize('where', [('exo_digit', 'segments'), ('finger', 'joints')])
def test_wrong_counts_are_rejected(where, count):
    entries = copy.deepcopy(SPEC_DEFAULTS[where[0]][where[1]])
    entries = (entries * 2)[:count]
    message = _message(_with(where, entries))
    assert where[1] in message and str(count) in message and '3' in message


@pytest.mark.parametrize('value', [0.0, -0.001])
@pytest.mark.parametrize('key', SEGMENT_LENGTH_KEYS)
def test_non_positive_segment_lengths_are_rejected(key, value):
    message = _message(_with(('exo_digit', 'segments', 1), {'name': 'pip', key: value}))
    assert f'segments[1].{key}' in message
    assert repr(value) in message and '> 0' in message


@pytest.mark.parametrize('value', [0.0, -0.02])
def test_non_positive_finger_link_is_rejected(value):
    message = _message(_with(('finger', 'joints', 2), {'link_half_length': value}))
    assert 'joints[2].link_half_length' in message and repr(value) in message
    assert '> 0' in message


def test_non_positive_base_block_is_rejected():
    message = _message({'exo_digit': {'base_block_half_length': -0.01}})
    assert 'base_block_half_length' in message and '-0.01' in message and '> 0' in message


@pytest.mark.parametrize('value', [0.0, -1.0e5])
def test_c1_must_be_positive(value):
    message = _message({'material': {'c1': value}})
    assert 'c1' in message and repr(value) in message and '> 0' in message


def test_negative_c2_and_c3_are_allowed():
    params = params_from_dict({'material': {'c2': -1.0e3, 'c3': -10.0}})
    assert (params.material.c2, params.material.c3) == (-1.0e3, -10.0)


def test_negative_stiffness_is_rejected_and_zero_allowed():
    message = _message(_with(('finger', 'joints', 0), {'stiffness': -0.01}))
    assert 'joints[0].stiffness' in message and '-0.01' in message and '>= 0' in message
    free = params_from_dict(_with(('finger', 'joints', 0), {'stiffness': 0.0}))
    assert free.finger.joints[0].stiffness == 0.0


@pytest.mark.parametrize('value', [True, False, '1.1e5', 'soft', [1.0], {'a': 1}])
def test_non_numbers_are_rejected(value):
    message = _message({'material': {'c1': value}})
    assert 'c1' in message and repr(value) in message and 'number' in message


def test_an_empty_value_takes_the_default():
    # YAML "c1:" with no value loads as None: the key is missing, so the default holds
    # (docs/spec/model.md §10).
    assert params_from_dict({'material': {'c1': None}}).material.c1 == 1.1e5


@pytest.mark.parametrize('value', [math.inf, -math.inf, math.nan])
def test_non_finite_values_are_rejected(value):
    message = _message({'material': {'c2': value}})
    assert 'c2' in message and 'finite' in message


def test_segment_name_must_be_a_string():
    message = _message(_with(('exo_digit', 'segments', 0), {'name': 3}))
    assert 'name' in message and '3' in message


def test_yaml_file_is_merged_over_the_defaults(tmp_path):
    path = tmp_path / 'partial.yaml'
    path.write_text(
        'material:\n  c1: 2.5e5\nfinger:\n  joints:\n    - {}\n    - {stiffness: 0.1}\n    - {}\n'
    )
    expected = copy.deepcopy(SPEC_DEFAULTS)
    expected['material']['c1'] = 2.5e5
    expected['finger']['joints'][1]['stiffness'] = 0.1
    assert load_params(path).to_dict() == expected


def test_exponent_floats_in_yaml_are_numbers(tmp_path):
    # YAML 1.1 (plain PyYAML) reads 1.1e5 and 2e4 as strings; docs/spec/model.md §10 writes them
    # as floats.
    path = tmp_path / 'exponents.yaml'
    path.write_text('material: {c1: 1.1e5, c2: 2e4, c3: -3E+2}\n')
    material = load_params(path).material
    assert (material.c1, material.c2, material.c3) == (1.1e5, 2.0e4, -300.0)


def test_dump_then_load_round_trips(tmp_path):
    data = copy.deepcopy(SPEC_DEFAULTS)
    data['material'] = {'c1': 123456.789, 'c2': -1.5e3, 'c3': 7.25}
    data['exo_digit']['segments'][2]['arc_length'] = 0.0171234567891
    data['finger']['joints'][1]['stiffness'] = 0.0
    params = params_from_dict(data)
    path = tmp_path / 'dumped.yaml'
    dump_params(params, path)
    assert load_params(path) == params
    assert load_params(path).to_dict() == data


def test_missing_file_names_the_file(tmp_path):
    path = tmp_path / 'nowhere.yaml'
    with pytest.raises(ParameterError, match=re.escape(str(path))):
        load_params(path)


def test_invalid_yaml_names_the_file(tmp_path):
    path = tmp_path / 'broken.yaml'
    path.write_text('material: {c1: [1, 2\n')
    with pytest.raises(ParameterError, match=re.escape(str(path))):
        load_params(path)


def test_rule_broken_in_a_file_names_file_key_and_value(tmp_path):
    path = tmp_path / 'bad_stiffness.yaml'
    path.write_text('finger:\n  joints: [{}, {}, {stiffness: -2.0}]\n')
    with pytest.raises(ParameterError) as caught:
        load_params(path)
    message = str(caught.value)
    assert 'bad_stiffness.yaml' in message and 'stiffness' in message and '-2.0' in message


def test_top_level_that_is_not_a_mapping_is_rejected(tmp_path):
    path = tmp_path / 'list.yaml'
    path.write_text('- 1\n- 2\n')
    with pytest.raises(ParameterError, match=re.escape(str(path))):
        load_params(path)


def test_parameters_are_frozen():
    params = load_params()
    with pytest.raises(AttributeError):
        params.material.c1 = 1.0
