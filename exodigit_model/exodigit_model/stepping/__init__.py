"""A glove in time: settings, the chambers' lag, the stepper and the joiner of its streams.

:mod:`.settings` (rate, lag, supply, sensor noise, seed; the step times t_k), :mod:`.chambers`
(the regulators' first-order lag, discretised exactly), :mod:`.simulation` (one glove or a
batch stepped behind regulators or valves, docs/spec/model.md §13-14) and :mod:`.joining`
(pairing the samples of a glove's streams by time). Built on :mod:`exodigit_model.physics`.
"""
