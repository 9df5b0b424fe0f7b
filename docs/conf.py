"""Sphinx configuration of mbgen's documentation site.

Build it (warnings and broken references are errors) with::

    .venv/bin/python -m sphinx -W -n --keep-going -b html docs docs/_build/html

Prose is MyST Markdown; the API reference is autodoc over the numpydoc docstrings of the
names ``mbgen`` exports (``mbgen/__init__.py``'s ``_PUBLIC`` table); ``_ext/mbgen_docs.py``
adds the gallery of built-in scenes and the "How to add" lists of the package docstrings.
No page needs the network: no intersphinx, no remote images.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import mbgen  # noqa: E402  (after the path: the extension imports mbgen too)

project = "mbgen"
author = "the mbgen authors"
copyright = "the mbgen authors"
release = version = mbgen.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "mbgen_docs",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
# examples/ holds the worked examples' Python (linked, shown with literalinclude)
exclude_patterns = ["_build", "examples", "**/.ipynb_checkpoints"]

# --- MyST: GitHub's heading anchors, so `page.md#a-heading` links work on GitHub and here
myst_heading_anchors = 4
myst_enable_extensions = ["colon_fence", "deflist"]
suppress_warnings = [
    # A block of tool output sits under an HTML comment that the block tests read
    # (`<!-- output: mbgen ... -->`): harmless raw HTML, shown by no builder but html.
    "myst.html",
]

# --- the reference: autodoc + numpydoc over the public names
autodoc_member_order = "bysource"
autodoc_typehints = "none"            # the numpydoc sections carry types and shapes
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autosummary_generate = False          # tables only: the objects are on api/*.md
numpydoc_show_class_members = False   # autodoc's :members: lists them
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# Names outside mbgen: no network, so no intersphinx; they are shown as code, not linked.
nitpick_ignore_regex = [
    ("py:.*", r"(numpy|np|sympy|sp|scipy|casadi|jax|jnp|cffi|dask|pandas|mujoco|"
              r"pinocchio|pin|matplotlib|pathlib|os|typing|collections|enum|dataclasses|"
              r"concurrent|threading|pydy|symengine|builtins)(\..*)?"),
]

# --- the theme
html_theme = "furo"
html_title = f"mbgen {release}"
html_static_path: list[str] = []
html_show_sourcelink = False
