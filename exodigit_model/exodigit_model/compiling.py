"""Say so when numba compiles the model's kernels, instead of a silent minute.

A process whose cache (docs/compiled.md; :mod:`.kernels.jit`) lacks a kernel compiles it
at the kernel's first call: a fresh ``pip install``, a node started after ``colcon build``, the
first ``check_env(GloveEnv())``. Compiling everything takes about a minute of CPU; numba says
nothing meanwhile. :func:`announce_compiles` registers a listener for numba's compile events
(``numba.core.event``, kind ``'numba:compile'``), which numba emits only when it compiles, never
when it loads a kernel from the cache or calls a compiled one: a warm process pays nothing.

What the logger ``exodigit_model.compiling`` says:

- WARNING, once per process, at the first compile of a kernel of this package: that the kernels
  are compiling, where their cache is and how long all of them take. A warning, as libraries that
  compile on first use give it, so that it shows without any logging configuration (Python's
  last-resort handler writes it to stderr; a node's stderr is in its launch log).
- INFO, at the end of each outermost compile (a kernel with the callees it compiled): its name,
  its time and the compile time of the process so far.
"""

from __future__ import annotations

import functools
import logging
import time
from pathlib import Path

from numba.core import event  # imported only where kernels compile (kernels.jit with numba on)

logger = logging.getLogger(__name__)

KERNELS_PACKAGE = f'{__name__.rpartition(".")[0]}.kernels'
"""The package whose kernels are announced: ``exodigit_model.kernels``."""
COLD_COMPILE = 'about a minute of CPU'
"""How long compiling every kernel takes (docs/compiled.md: 59 s CPU, idle 2-core VM)."""


class CompileNotice(event.Listener):
    """A listener of numba's compile events that logs the compiles of ``package``'s kernels.

    numba compiles a kernel's callees inside the kernel's own compile (nested events, one
    thread at a time under numba's compiler lock): the outermost one is timed.

    Parameters
    ----------
    package : str
        Kernels whose module is this one or inside it are announced; others are ignored.
    cache : Path, optional
        Where the compiled kernels are cached (None: in memory), for the warning.
    """

    def __init__(self, package: str = KERNELS_PACKAGE, cache: Path | None = None) -> None:
        self.package = package
        self.cache = cache
        self.announced = False
        self.depth = 0
        self.started = 0.0
        self.total = 0.0

    def ours(self, compiled: event.Event) -> bool:
        """Whether the event is a compile of a kernel of :attr:`package`.

        A function made by ``exec`` has no module (None): never ours.
        """
        module = compiled.data['dispatcher'].py_func.__module__ or ''
        return module == self.package or module.startswith(self.package + '.')

    def on_start(self, compiled: event.Event) -> None:
        """Announce the first compile; time the outermost one."""
        if not self.ours(compiled):
            return
        if not self.announced:
            self.announced = True
            where = f'into {self.cache}' if self.cache else 'in memory (nothing is cached)'
            logger.warning(
                'exodigit_model: numba is compiling the model kernels %s, once: '
                '%s for all of them (docs/compiled.md; '
                '`python -m exodigit_model.tools.warm` compiles them ahead)',
                where,
                COLD_COMPILE,
            )
        if self.depth == 0:
            self.started = time.perf_counter()
        self.depth += 1

    def on_end(self, compiled: event.Event) -> None:
        """Log the time of an outermost compile when it ends."""
        if not self.ours(compiled):
            return
        self.depth -= 1
        if self.depth == 0:
            took = time.perf_counter() - self.started
            self.total += took
            function = compiled.data['dispatcher'].py_func
            logger.info(
                'exodigit_model: compiled %s.%s in %.1f s (%.1f s of compiling so far)',
                function.__module__,
                function.__qualname__,
                took,
                self.total,
            )


@functools.cache
def announce_compiles(cache: Path | None) -> None:
    """Register the process's one :class:`CompileNotice` (kernels cached in ``cache``)."""
    event.register('numba:compile', CompileNotice(cache=cache))
