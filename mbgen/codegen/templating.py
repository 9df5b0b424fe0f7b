"""The one Jinja environment over ``templates/`` and its escaping filters.

Templates are shipped in the wheel as ``mbgen._templates`` (``templates/`` at the
repository's top level in a source checkout), grouped by target in subfolders.
Every renderer (the model, its targets, the FMU, the example, the benchmarks)
loads them from here, so undefined names fail (``StrictUndefined``) and text a
user controls is escaped by the filter of where it lands (:mod:`mbgen.codegen.escape`).

Jinja compiles a template to Python the first time a process loads it: that was 0.22 s of
the 0.26 s a small model's render took in a new process (cProfile, the 2-link arm).  The
compiled templates are kept in the cache (``<cache>/templates-<jinja version>``, a private
folder; :class:`_TemplateCache`), checked against the template's text by Jinja, so a new
process loads them instead.  Without a usable cache, templates are compiled as before.
"""

from __future__ import annotations

import os
import stat
from functools import lru_cache
from importlib import resources
from pathlib import Path

import jinja2
from jinja2.bccache import Bucket

from .escape import FILTERS


class _TemplateCache(jinja2.FileSystemBytecodeCache):
    """Jinja's compiled templates in a private folder of the cache; a file that cannot be
    read or written is compiled again, never an error (the cache is an optimisation)."""

    def load_bytecode(self, bucket: Bucket) -> None:
        try:
            super().load_bytecode(bucket)
        except (OSError, EOFError, ValueError, TypeError, AttributeError, ImportError):
            bucket.reset()

    def dump_bytecode(self, bucket: Bucket) -> None:
        try:
            super().dump_bytecode(bucket)
        except OSError:
            pass


def _template_cache() -> _TemplateCache | None:
    """The compiled templates' folder in :func:`mbgen.build.cache.cache_dir`, made private
    (0700, the user's own, not a link), or None where there is none to be had."""
    from ..build.cache import cache_dir
    from ..errors import CacheError

    try:
        folder = cache_dir() / f"templates-{jinja2.__version__}"
        folder.mkdir(mode=0o700, exist_ok=True)
        info = os.lstat(folder)
    except (CacheError, OSError):
        return None
    mine = not hasattr(os, "getuid") or info.st_uid == os.getuid()
    if not stat.S_ISDIR(info.st_mode) or not mine or info.st_mode & 0o022:
        return None
    return _TemplateCache(str(folder))


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
                             lstrip_blocks=True, autoescape=False,
                             bytecode_cache=_template_cache())
    env.filters.update(FILTERS)  # one escaping function per context, see mbgen.codegen.escape
    return env


__all__ = ["environment"]
