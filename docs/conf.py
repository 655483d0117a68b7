"""Sphinx configuration of the exodigit documentation site (``make docs``; docs/development.md).

Sphinx reads the Markdown pages with myst-parser and builds the API reference with sphinx-autoapi,
which reads the packages' source without importing it (no rclpy, no numba at build time); the
numpy docstrings are turned into fields by napoleon. Warnings are errors (``make docs`` passes
``-W``), so a page, a link or a docstring that Sphinx cannot read fails the build.
"""

import re
from pathlib import Path

from docutils import nodes
from sphinx import addnodes
from sphinx.transforms.post_transforms import SphinxPostTransform

ROOT = Path(__file__).resolve().parents[1]

project = 'exodigit'
author = 'the exodigit developers'
copyright = '2026, the exodigit developers'

extensions = [
    'myst_parser',
    'sphinx.ext.napoleon',
    'autoapi.extension',
]

root_doc = 'index'
source_suffix = {'.md': 'markdown', '.rst': 'restructuredtext'}
exclude_patterns = ['_build']

# Markdown: headings get anchors as on GitHub (``[...](#virtual-patient-trials)``), links to
# other pages and files are written as on GitHub (relative paths), so one text reads in both.
myst_heading_anchors = 3
myst_enable_extensions = ['colon_fence']

# API reference: every module of both packages, from the source alone.
autoapi_type = 'python'
autoapi_dirs = [
    str(ROOT / 'exodigit_model' / 'exodigit_model'),
    str(ROOT / 'exodigit_nodes' / 'exodigit_nodes'),
]
autoapi_root = 'api'
autoapi_options = ['members', 'show-inheritance', 'show-module-summary']
autoapi_member_order = 'bysource'
autoapi_keep_files = False
autoapi_add_toctree_entry = True
autoapi_ignore = [
    # For the lead: its docstrings write ":class:`PatientJob`s", which reStructuredText cannot
    # read (a role must end before a letter); take this out once they are fixed or the module
    # is gone (issue 34 replaces the worker pool).
    '*/testing/trial_worker.py',
]

# exodigit_model's __init__ exports its names lazily (PEP 562 ``__getattr__``, so that a process
# that steps no glove never imports numba): the modules' ``from exodigit_model import GloveModel``
# are right, but static analysis cannot follow them, and autoapi would warn at each.
suppress_warnings = ['autoapi.python_import_resolution']
# The docstrings name modules and classes relatively (:mod:`.valves`, :class:`.Hold`) and give
# shapes in numpy's words (``ndarray, shape (steps, 3)``); where a name has several targets
# (kernels.valves and tools.valves, control's Hold and inverse's Hold), Sphinx links the first
# and would warn. A name with no target is not warned about either (the build is not nitpicky).
suppress_warnings += ['ref.python']

napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False

LITERAL = re.compile(r'(``.*?``)')


def absolute_value_bars(app, what, name, obj, options, lines):
    """Let the docstrings' notation for an absolute value, |x|, read as text.

    reStructuredText takes ``|x|`` for a substitution, which no docstring here means; the bars
    are escaped outside inline literals (a literal shows its text as written).
    """
    for index, line in enumerate(lines):
        if '|' in line and not line.lstrip().startswith(('>>>', '...')):
            parts = LITERAL.split(line)
            parts[::2] = [re.sub(r'(?<!\\)\|', r'\\|', part) for part in parts[::2]]
            lines[index] = ''.join(parts)


class RepositoryLinks(SphinxPostTransform):
    """Show a link to a file or folder of the repository outside docs/ as its text.

    The pages are written to be read on GitHub too, where ``[the example](../examples/...)``
    opens the folder; the site has no page for it, and myst-parser would warn. A link whose
    target is in neither (a typo) is left to myst-parser, which warns. The README, included by
    index.md, links from the repository's root.
    """

    default_priority = 8  # before myst-parser resolves its references (9)

    def run(self, **kwargs):
        for node in list(self.document.findall(addnodes.pending_xref)):
            if node.get('reftype') != 'myst':
                continue
            target = node['reftarget'].split('#')[0]
            if node.get('refdomain') == 'doc':
                if target in self.env.found_docs:
                    continue
                candidates = [Path(target + '.md')]
            else:
                here = Path(self.env.doc2path(self.env.docname)).parent
                candidates = [here / target, ROOT / target]
            for candidate in candidates:
                path = candidate.resolve()
                docs = Path(self.env.srcdir).resolve()
                if path.exists() and path.is_relative_to(ROOT) and not path.is_relative_to(docs):
                    node.replace_self(nodes.literal(node.astext(), node.astext()))
                    break


def setup(app):
    app.connect('autodoc-process-docstring', absolute_value_bars, priority=600)
    app.add_post_transform(RepositoryLinks)


# Sphinx's own theme: furo's navigation tree cost 9 s more of CPU a build (44 s against 35 s,
# most of the rest is autoapi reading the source), for a hundred API pages.
html_theme = 'alabaster'
html_title = 'exodigit'
html_theme_options = {'fixed_sidebar': True, 'page_width': '1100px', 'sidebar_width': '260px'}
