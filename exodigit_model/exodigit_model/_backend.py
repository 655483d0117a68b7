"""Two arithmetic backends so that one implementation serves one state or many.

The kinematics, coupling and Newton code is written once over per-joint values that are either
Python floats (one state: pure-Python arithmetic is several times faster than numpy for 3x3
problems) or 1-D numpy arrays (a batch of N states, vectorised). The few operations whose
spelling differs between the two live here.
"""

from __future__ import annotations

import math

import numpy as np


class ScalarOps:
    """Operations on Python floats (and complex numbers)."""

    sin = staticmethod(math.sin)
    cos = staticmethod(math.cos)

    @staticmethod
    def where(condition, if_true, if_false):
        """``if_true`` where ``condition`` holds, else ``if_false``."""
        return if_true if condition else if_false

    @staticmethod
    def all(condition) -> bool:
        """Whether ``condition`` holds everywhere."""
        return bool(condition)

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

    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    where = staticmethod(np.where)
    isfinite = staticmethod(np.isfinite)
    logical_not = staticmethod(np.logical_not)

    @staticmethod
    def any(condition) -> bool:
        """Whether ``condition`` holds anywhere."""
        return bool(np.any(condition))

    @staticmethod
    def all(condition) -> bool:
        """Whether ``condition`` holds everywhere."""
        return bool(np.all(condition))
