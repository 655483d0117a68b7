"""The ``@kernel`` decorator: numba compiles the model's kernels, else they run as plain Python.

Switch
------
:data:`JIT` is true when numba imports and the environment variable ``EXODIGIT_JIT`` is not
``'0'``. Only ``'0'`` switches the compiler off; any other value (unset, ``'1'``, but also
``'no'`` or ``'false'``) leaves it on. Off, :func:`kernel` returns the function itself: the same
source runs as plain Python, the slow reference path the tests compare the compiled one against.

Error model
-----------
Kernels compile with ``error_model='numpy'``: a float division by zero gives ±inf or nan, as in
numpy, where numba's default (``'python'``) checks every division and raises
ZeroDivisionError, which costs a branch per division and blocks vectorisation. Plain Python
raises on ``1.0 / 0.0`` (numpy float64 scalars give inf with a RuntimeWarning), so the two paths
would differ there: kernels never divide by zero (they guard the divisor), and neither path
relies on what a division by zero gives. No ``fastmath``: compiled results round as the plain
ones do.

Cache
-----
Compiled kernels are cached on disk (numba's ``cache=True``) so that a process loads them
instead of compiling them again. Where, and why:

a. numba keys a cached function on its own source file only: when a kernel it compiled into
   another (a callee from another module) changes, the caller's cache still loads, with the old
   callee inside. So the cache directory is named after a digest of every ``*.py`` file of this
   package, ``<base>/exodigit-<digest>`` (:func:`source_digest`, computed once per process): an
   edit anywhere in the kernels starts a fresh cache.
b. ``<base>`` is the user's ``NUMBA_CACHE_DIR`` (numba's own setting, honoured) when set; else
   the first writable of this package's ``__pycache__/numba`` (a venv or editable install) and
   the user's cache directory, ``$XDG_CACHE_HOME/exodigit`` or ``~/.cache/exodigit`` (a
   read-only install, e.g. a system or ROS one). A ``NUMBA_CACHE_DIR`` that cannot be written
   is not replaced by another place: whoever set it chose where caches may go.
c. numba picks a function's cache locator when it is decorated, from the global
   ``numba.config.CACHE_DIR``. :func:`kernel` sets it to our directory only while it decorates
   and restores it afterwards, so the user's own numba functions cache where they would have.
d. With no writable directory, or when numba cannot cache a kernel anyway (``cannot cache
   function ...: no locator available``, or it would use a locator of its own, outside our
   directory), the kernels compile in memory (``cache=False``) and one RuntimeWarning per
   process says so and how to fix it; never an import error (unless warnings are made errors,
   as the test suite does for this package's RuntimeWarnings).
e. ``python -m exodigit_model.tools.warm`` compiles every kernel into the cache and removes the
   ``exodigit-<digest>`` directories of other digests beside it (:func:`prune`), so that edits do
   not pile up caches; nothing else is ever deleted. Bases that two versions share (a
   ``NUMBA_CACHE_DIR`` used by two checkouts) lose the other version's cache at each warm.

Loading needs a writable directory too (numba checks it before it reads), so a cache made by
another user is only used when this user may write there.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

try:
    import numba
except ImportError:  # the same sources run as plain Python
    numba = None

JIT: bool = numba is not None and os.environ.get('EXODIGIT_JIT', '1') != '0'
"""Whether :func:`kernel` compiles (numba imports and ``EXODIGIT_JIT`` is not ``'0'``)."""

KERNELS_DIR = Path(__file__).resolve().parent
"""This package's directory: its ``*.py`` files make the digest of :func:`source_digest`."""

_PREFIX = 'exodigit-'
_DIGEST_DIGITS = 16
_CACHE_NAME = re.compile(rf'{_PREFIX}[0-9a-f]{{{_DIGEST_DIGITS}}}')
_OPTIONS = {'error_model': 'numpy'}
_warned = False

Function = TypeVar('Function', bound=Callable)


def kernel(function: Function | None = None, *, counted: bool = True, forceinline: bool = False):
    """Compile ``function`` with numba, cached (module docstring); return it as is without JIT.

    ``@kernel``, ``@kernel(counted=False)`` or ``@kernel(counted=False, forceinline=True)``.

    numba compiles a kernel once per argument types, into a library of its own, and links that
    library into every kernel that calls it, where LLVM optimises it again with the caller. So
    the cost of compiling grows with every kernel a callee is linked into and every distinct
    argument type it is called with, never with numba-level copies of its body (numba's
    ``inline='always'``, which types and lowers a callee again at every call site, is not
    used). Callers therefore pass one layout per argument: C-contiguous, writable float64
    arrays, and flags as ``np.bool_(...)`` (a literal ``True`` or ``False`` is a type of its
    own to numba: one more compile of the callee and of everything it calls).

    Parameters
    ----------
    function : callable
        A kernel of this package: a flat function of floats and small numpy arrays.
    counted : bool
        Whether numba counts references to the arrays the kernel handles (its runtime, NRT).
        ``counted=False`` for every kernel that allocates nothing (the leaves and the loops of
        the hot path): every view it takes of a workspace array would cost an atomic increment
        and decrement of one shared count otherwise (measured with perf: ~100 pairs per
        evaluation of the statics). Such a kernel may not allocate arrays, and may not return
        an array to a kernel that counts (that kernel would release a reference it was never
        given).
    forceinline : bool
        Have LLVM inline the kernel at every call site (numba's ``forceinline``: the LLVM
        attribute ``alwaysinline``; numba compiles the kernel itself once). For the kernels of
        the hot path that take ``glove`` and ``work``: numba passes every array of those named
        tuples as separate numbers, several hundred per call, and such a call costs about
        0.3 µs (measured: the batch step of 1,000 gloves 0.82 M glove-steps/s with
        :func:`.newton.newton` and :func:`.stepping.step_into` called, 1.5 M inlined). Keep the
        call sites few (:func:`.newton.newton` has one of each evaluation): each is a copy for
        LLVM to optimise.

    Returns
    -------
    callable
        numba's dispatcher, or ``function`` itself when :data:`JIT` is false.
    """
    if function is None:
        return lambda decorated: kernel(decorated, counted=counted, forceinline=forceinline)
    if not JIT:
        return function
    from ..compiling import announce_compiles  # here: it imports numba, which JIT has

    directory = cache_directory()
    announce_compiles(directory)  # one log line when the kernels compile (docs/compiled.md)
    options = dict(_OPTIONS)
    if not counted:
        options['_nrt'] = False
    options['forceinline'] = forceinline
    if directory is not None:
        compiled = _cached(function, directory, options)
        if compiled is not None:
            return compiled
    return numba.njit(cache=False, **options)(function)


def _cached(function: Callable, directory: Path, options: dict) -> Callable | None:
    """The cached dispatcher numba makes of ``function`` in ``directory``, or None."""
    previous = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(directory)
    try:
        compiled = numba.njit(cache=True, **options)(function)
    except RuntimeError as error:
        if 'cannot cache' not in str(error):
            raise
        _warn_in_memory(str(error))
        return None
    finally:
        numba.config.CACHE_DIR = previous
    # numba falls back to a locator of its own (the source's __pycache__, its user directory)
    # when ours fails, where rule a's digest would not protect the kernel.
    if not Path(compiled.stats.cache_path).is_relative_to(directory):
        _warn_in_memory(f'numba chose {compiled.stats.cache_path} instead of {directory}')
        return None
    return compiled


@functools.cache
def cache_directory() -> Path | None:
    """The process's cache directory, ``<base>/exodigit-<digest>``; None: compile in memory.

    Chosen (and created) once per process, warning once when no base is writable.
    """
    name = f'{_PREFIX}{source_digest()}'
    bases = cache_bases()
    for base in bases:
        if _writable(base / name):
            return base / name
    _warn_in_memory('cannot write to ' + ' nor '.join(str(base / name) for base in bases))
    return None


def cache_bases() -> list[Path]:
    """The candidate ``<base>`` directories, in order of preference (module docstring, b)."""
    if numba is not None and numba.config.CACHE_DIR:
        return [Path(numba.config.CACHE_DIR).absolute()]
    bases = [KERNELS_DIR / '__pycache__' / 'numba']
    xdg = os.environ.get('XDG_CACHE_HOME', '')
    if os.path.isabs(xdg):  # the XDG specification ignores a relative path
        bases.append(Path(xdg) / 'exodigit')
    else:
        with contextlib.suppress(RuntimeError):  # no home directory to be found
            bases.append(Path.home() / '.cache' / 'exodigit')
    return bases


def source_digest(directory: Path = KERNELS_DIR) -> str:
    """The first 16 hex digits of the sha256 of the ``*.py`` files in ``directory``, by name."""
    digest = hashlib.sha256()
    for path in sorted(directory.glob('*.py')):
        source = path.read_bytes()
        digest.update(f'{path.name}\0{len(source)}\0'.encode())
        digest.update(source)
    return digest.hexdigest()[:_DIGEST_DIGITS]


def prune(current: Path | None = None) -> list[Path]:
    """Remove the ``exodigit-<digest>`` directories beside ``current`` but itself.

    Parameters
    ----------
    current : Path, optional
        The cache directory to keep; :func:`cache_directory` when omitted.

    Returns
    -------
    list of Path
        The directories removed (none when nothing is cached on disk).
    """
    current = cache_directory() if current is None else current
    if current is None:
        return []
    stale = [
        path
        for path in sorted(current.parent.iterdir())
        if path.name != current.name
        and _CACHE_NAME.fullmatch(path.name)
        and path.is_dir()
        and not path.is_symlink()
    ]
    for path in stale:
        shutil.rmtree(path, ignore_errors=True)
    return stale


def _writable(directory: Path) -> bool:
    """Whether ``directory`` exists or can be made, and takes a file (numba's own test)."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=directory).close()
    except OSError:
        return False
    return True


def _warn_in_memory(reason: str) -> None:
    """Warn, once per process, that the kernels are compiled in memory at every start."""
    global _warned
    if _warned:
        return
    _warned = True
    warnings.warn(
        f'exodigit_model kernels cannot be cached ({reason}): numba compiles them in memory in '
        'every process, which costs as long as a cold `python -m exodigit_model.tools.warm` '
        '(docs/compiled.md). Set NUMBA_CACHE_DIR to a writable directory to compile '
        'them once.',
        RuntimeWarning,
        stacklevel=4,  # the kernel's module: _warn_in_memory < cache_directory/_cached < kernel
    )
