"""Bad values for a declared ROS parameter, derived from its ParameterDescriptor alone.

The parameter tests list a running node's parameters over its ListParameters and
DescribeParameters services and try each value `bad_values` gives: out of the declared range,
of a wrong type, non-finite, a string outside the declared choices, a joint vector of the wrong
length. New parameters are covered as soon as they are declared. `other_valid_value` gives a
value the node must accept (so the test can tell "refuses everything" from "validates").
"""

from __future__ import annotations

import math

from rcl_interfaces.msg import Parameter, ParameterDescriptor, ParameterType, ParameterValue

#: Fraction of a parameter's range by which `other_valid_value` moves it.
NUDGE = 0.01

_FIELDS = {
    ParameterType.PARAMETER_BOOL: 'bool_value',
    ParameterType.PARAMETER_INTEGER: 'integer_value',
    ParameterType.PARAMETER_DOUBLE: 'double_value',
    ParameterType.PARAMETER_STRING: 'string_value',
    ParameterType.PARAMETER_DOUBLE_ARRAY: 'double_array_value',
}


def value(kind: int, python_value) -> ParameterValue:
    """A ParameterValue of type ``kind`` holding ``python_value``."""
    result = ParameterValue(type=kind)
    setattr(result, _FIELDS[kind], python_value)
    return result


def python_value(parameter_value: ParameterValue):
    """The Python value held by a ParameterValue (lists for arrays)."""
    held = getattr(parameter_value, _FIELDS[parameter_value.type])
    return list(held) if parameter_value.type == ParameterType.PARAMETER_DOUBLE_ARRAY else held


def choices(descriptor: ParameterDescriptor) -> list[str]:
    """Allowed strings named in ``additional_constraints`` ('one of: a, b'), else []."""
    text = descriptor.additional_constraints
    if not text.startswith('one of:'):
        return []
    return [item.strip() for item in text[len('one of:') :].split(',')]


def _numbers(descriptor: ParameterDescriptor) -> list[float]:
    out = [math.nan, math.inf, -math.inf]
    for rule in list(descriptor.floating_point_range) + list(descriptor.integer_range):
        step = max(1.0, abs(rule.to_value) * 0.5, abs(rule.from_value) * 0.5)
        out += [rule.from_value - step, rule.to_value + step]
    return out


def bad_values(descriptor: ParameterDescriptor) -> list[tuple[str, ParameterValue]]:
    """(what, value) pairs the node must refuse for this parameter."""
    kind = descriptor.type
    cases: list[tuple[str, ParameterValue]] = []
    if kind != ParameterType.PARAMETER_STRING:
        cases.append(('a string', value(ParameterType.PARAMETER_STRING, 'not-a-value')))
    if kind == ParameterType.PARAMETER_BOOL:
        cases.append(('a number', value(ParameterType.PARAMETER_DOUBLE, 1.0)))
    if kind == ParameterType.PARAMETER_STRING:
        cases.append(('a number', value(ParameterType.PARAMETER_DOUBLE, 1.0)))
        if choices(descriptor):
            cases.append(('an unknown choice', value(kind, 'no-such-choice')))
    if kind == ParameterType.PARAMETER_INTEGER:
        cases.append(('a fraction', value(ParameterType.PARAMETER_DOUBLE, 0.5)))
        for number in _numbers(descriptor)[3:]:
            cases.append((f'{number:g}', value(kind, int(number))))
    if kind == ParameterType.PARAMETER_DOUBLE:
        for number in _numbers(descriptor):
            cases.append((f'{number:g}', value(kind, number)))
    if kind == ParameterType.PARAMETER_DOUBLE_ARRAY:
        cases.append(('two values', value(kind, [0.0, 0.0])))
        cases.append(('four values', value(kind, [0.0] * 4)))
        for number in _numbers(descriptor):
            cases.append((f'[{number:g}, ...]', value(kind, [number, 0.0, 0.0])))
    return cases


def other_valid_value(descriptor: ParameterDescriptor, current: ParameterValue):
    """A value different from ``current`` that the descriptor allows, or None if none is known."""
    kind = descriptor.type
    held = python_value(current)
    if kind == ParameterType.PARAMETER_BOOL:
        return value(kind, not held)
    if kind == ParameterType.PARAMETER_STRING:
        others = [c for c in choices(descriptor) if c != held]
        return value(kind, others[0]) if others else None
    ranges = list(descriptor.floating_point_range) + list(descriptor.integer_range)
    if not ranges:
        return None
    low, high = ranges[0].from_value, ranges[0].to_value
    # A small move keeps rules between parameters (e.g. sine_low <= sine_high) satisfied.
    if kind == ParameterType.PARAMETER_INTEGER:
        return value(kind, int(held + 1 if held + 1 <= high else held - 1))
    step = NUDGE * (high - low)
    if kind == ParameterType.PARAMETER_DOUBLE:
        return value(kind, held + step if held + step <= high else held - step)
    if kind == ParameterType.PARAMETER_DOUBLE_ARRAY:
        return value(kind, [x + step if x + step <= high else x - step for x in held])
    return None


def parameter(name: str, parameter_value: ParameterValue) -> Parameter:
    """A Parameter message."""
    return Parameter(name=name, value=parameter_value)
