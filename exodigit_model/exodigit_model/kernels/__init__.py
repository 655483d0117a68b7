"""The model's compiled kernels: flat functions of floats and small arrays, one source.

Every hot path of the model (the coupled and extensible solves, their inverse and estimator,
the chambers and the simulation step, one glove or a batch) is written once here, as plain
functions that numba compiles (:mod:`.jit`). With numba missing or ``EXODIGIT_JIT=0`` the same
functions run as plain Python: the reference path the suite checks the compiled one against.
"""
