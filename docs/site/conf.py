"""Sphinx configuration of lagrangian's documentation site.

Build (warnings are errors), from the repository root, after ``pip install . sphinx``:

    sphinx-build -W -b html docs/site target/site
"""

import lagrangian

project = "lagrangian"
author = "the lagrangian authors"
release = version = lagrangian.__version__

extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon"]
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False}
# The package's docstrings name NumPy and matplotlib types that are not documented here.
nitpicky = False

html_theme = "alabaster"
html_static_path = ["_static"]
html_theme_options = {"description": "Equations of motion from energies", "page_width": "1100px"}
exclude_patterns = ["_build"]


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write absolute values and norms as |x|, which reStructuredText would take
    for substitutions: escape every bar (no docstring has a table)."""
    for i, line in enumerate(lines):
        lines[i] = line.replace("|", "\\|")


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars)
