"""Optional dependencies of the tools, imported only when a subcommand needs them.

The model core needs numpy, scipy and PyYAML only; the tools also use matplotlib (figures),
tqdm (progress bars) and rosbags (MCAP bags), installed by the package's ``tools`` extra.
"""

from __future__ import annotations

import importlib
from types import ModuleType

INSTALL_HINT = 'pip install "./exodigit_model[tools]"'
"""What a user runs to get the optional dependencies."""


class ToolError(Exception):
    """A problem with the user's input or environment, reported as one line without a traceback."""


def require(module: str) -> ModuleType:
    """Import ``module`` or raise :class:`ToolError` saying how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        top = module.split('.')[0]
        message = f'{top} is not installed; install the tools with: {INSTALL_HINT}'
        raise ToolError(message) from None


def pyplot() -> ModuleType:
    """matplotlib.pyplot on the headless Agg backend."""
    matplotlib = require('matplotlib')
    matplotlib.use('Agg')
    return require('matplotlib.pyplot')


def progress(iterable=None, **kwargs):
    """A tqdm progress bar on stderr (``iterable`` or ``total`` as for tqdm).

    Shown on a terminal only (``disable=None``), so logs and CI output stay clean.
    """
    tqdm = require('tqdm')
    kwargs.setdefault('disable', None)
    kwargs.setdefault('leave', False)
    kwargs.setdefault('dynamic_ncols', True)
    return tqdm.tqdm(iterable, **kwargs)
