"""The one Jinja environment over ``templates/`` and its escaping filters.

Templates are shipped in the wheel as ``mbgen._templates`` (``templates/`` at the
repository's top level in a source checkout), grouped by target in subfolders.
Every renderer (the model, its targets, the FMU, the example, the benchmarks)
loads them from here, so undefined names fail (``StrictUndefined``) and text a
user controls is escaped by the filter of where it lands (:mod:`mbgen.codegen.escape`).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

import jinja2

from .escape import FILTERS


@lru_cache(maxsize=1)
def environment() -> jinja2.Environment:
    """The Jinja environment over the templates (shipped in the wheel as ``mbgen._templates``)."""
    try:
        root = resources.files("mbgen._templates")
    except ModuleNotFoundError:  # a source checkout used without installing
        root = Path(__file__).resolve().parents[2] / "templates"
    loader = jinja2.FunctionLoader(lambda name: (root / name).read_text(encoding="utf-8"))
    env = jinja2.Environment(loader=loader, undefined=jinja2.StrictUndefined,
                             keep_trailing_newline=True, trim_blocks=True,
                             lstrip_blocks=True, autoescape=False)
    env.filters.update(FILTERS)  # one escaping function per context, see mbgen.codegen.escape
    return env


__all__ = ["environment"]
