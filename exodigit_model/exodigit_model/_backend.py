"""Two arithmetic backends so that one implementation serves one state or many.

The kinematics, coupling and Newton code is written once over per-joint values that are either
Python floats (one state: pure-Python arithmetic is several times faster than numpy for 3x3
problems) or 1-D numpy arrays (a batch of N states, vectorised). The few operations whose
spelling differs between the two live here.
"""

from __future__ import annotations

import math

import numpy as np

MAX_EXPONENT = 700.0
"""Largest exponent passed to exp (e^700 ≈ 1e304: finite, so a wild trial state stays finite)."""


class ScalarOps:
    """Operations on Python floats (and complex numbers)."""

    single_state = True
    """One state: whole objects (an evaluation) can follow the iteration."""

    sin = staticmethod(math.sin)
    cos = staticmethod(math.cos)

    @staticmethod
    def exp(x: float) -> float:
        """eˣ, with the exponent capped at ``MAX_EXPONENT`` (finite for any trial state)."""
        return math.exp(min(x, MAX_EXPONENT))

    @staticmethod
    def softplus_and_sigmoid(x: float) -> tuple[float, float]:
        """ln(1 + eˣ) and its slope 1/(1 + e⁻ˣ), from one exponential, without overflow."""
        z = math.exp(-abs(x))
        return max(x, 0.0) + math.log1p(z), (1.0 if x >= 0.0 else z) / (1.0 + z)

    @staticmethod
    def where(condition, if_true, if_false):
        """``if_true`` where ``condition`` holds, else ``if_false``."""
        return if_true if condition else if_false

    @staticmethod
    def select(condition, if_true, if_false):
        """``if_true`` (a value or a nested list) where ``condition`` holds, else ``if_false``."""
        return if_true if condition else if_false

    @staticmethod
    def piecewise(condition, if_true, if_false, x):
        """``if_true(x)`` where ``condition`` holds, else ``if_false(x)`` (tuples of results)."""
        return if_true(x) if condition else if_false(x)

    @staticmethod
    def any(condition) -> bool:
        """Whether ``condition`` holds anywhere."""
        return bool(condition)

    @staticmethod
    def logical_not(condition) -> bool:
        """Negation of ``condition``."""
        return not condition

    @staticmethod
    def isfinite(value) -> bool:
        """Whether ``value`` is a finite number."""
        return math.isfinite(value)


class ArrayOps:
    """Operations on 1-D numpy arrays, element by element."""

    single_state = False

    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    where = staticmethod(np.where)

    @staticmethod
    def exp(x):
        """eˣ element-wise, exponent capped at ``MAX_EXPONENT``."""
        return np.exp(np.minimum(x, MAX_EXPONENT))

    @staticmethod
    def softplus_and_sigmoid(x):
        """ln(1 + eˣ) and its slope 1/(1 + e⁻ˣ) element-wise, without overflow."""
        z = np.exp(-np.abs(x))
        return np.maximum(x, 0.0) + np.log1p(z), np.where(x >= 0.0, 1.0, z) / (1.0 + z)

    isfinite = staticmethod(np.isfinite)
    logical_not = staticmethod(np.logical_not)

    @staticmethod
    def any(condition) -> bool:
        """Whether ``condition`` holds anywhere."""
        return bool(np.any(condition))

    @classmethod
    def select(cls, condition, if_true, if_false):
        """``if_true`` where ``condition`` holds, else ``if_false``, through nested lists."""
        if isinstance(if_true, list):
            return [cls.select(condition, a, b) for a, b in zip(if_true, if_false, strict=True)]
        return np.where(condition, if_true, if_false)

    @staticmethod
    def piecewise(condition, if_true, if_false, x):
        """``if_true(x)`` where ``condition`` holds, else ``if_false(x)``, element by element.

        ``if_false`` sees 1.0 where ``condition`` holds, so that it never divides by zero there.
        """
        true_values = if_true(x)
        false_values = if_false(np.where(condition, 1.0, x))
        return tuple(
            np.where(condition, a, b) for a, b in zip(true_values, false_values, strict=True)
        )
