"""The regions of the valve flow function ψ of ISO 6358-3 (docs/spec/model.md (14.3)).

A module of plain constants, without numba: the parameter checks of :mod:`..pneumatics` read
them, and the kernels compile them in; here, among the kernels' sources, an edit of them starts
a fresh kernel cache (:func:`.jit.source_digest`).
"""

LAMINAR_RATIO = 0.999
"""Pressure ratio above which the flow of (14.3) is laminar (linear in the pressure drop)."""
