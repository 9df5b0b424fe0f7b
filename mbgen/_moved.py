"""Module paths that moved, kept importable for one minor version (0.2) with a warning.

The documented paths of earlier releases (``mbgen.plots.plot_simulation`` before the stage
packages; ``mbgen.run.named.read_input_csv`` before the stage packages became nouns) still
import, as the module that now holds them -- the same module object, so a class imported
the old way *is* the class imported the new way -- with a :class:`DeprecationWarning`
that names the new path.  ``CHANGELOG.md`` lists the moves.

``mbgen.run`` and ``mbgen.derive`` are public *functions* (the pipeline's first and last
verbs); the packages that held the stages under those names are now ``mbgen.runtime`` and
``mbgen.derivation``.  A finder that answered ``import mbgen.run.named`` by importing a
module ``mbgen.run`` would let the import system rebind ``mbgen.run`` to that module, so
the two old package names are registered in ``sys.modules`` under the new packages
(:func:`install`), and only their submodules go through the finder.  ``import mbgen.run.x
as y`` cannot work while ``mbgen.run`` is a function (Python binds ``y`` by attributes);
``from mbgen.run.x import name`` does.

How to add a moved path
-----------------------
Add a row to :data:`MOVED` (old prefix -> new prefix); ``tests/test_layout.py`` imports
every row's old path and checks the warning and the identity.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: Old module path (or package prefix) -> where it lives now.
MOVED = {
    "mbgen.run": "mbgen.runtime",
    "mbgen.derive": "mbgen.derivation",
    "mbgen.plots": "mbgen.viz.plots",
    "mbgen.animate": "mbgen.viz.animate",
    "mbgen.stepper": "mbgen.runtime.stepper",
    "mbgen.kinematics": "mbgen.model.kinematics",
    "mbgen.expressions": "mbgen.model.expressions",
    "mbgen.escape": "mbgen.codegen.escape",
}

#: Old names of packages that are also public functions of ``mbgen`` (see the docstring).
PACKAGES_UNDER_FUNCTIONS = ("mbgen.run", "mbgen.derive")

REMOVED_IN = "0.2"


def new_name(old: str) -> str | None:
    """Where the module ``old`` lives now, or None if it did not move."""
    for prefix, now in MOVED.items():
        if old == prefix or old.startswith(prefix + "."):
            return now + old[len(prefix):]
    return None


class _Existing(importlib.abc.Loader):
    """Hands the import system a module that is already imported, under its old name."""

    def __init__(self, module):
        self.module, self.spec = module, module.__spec__

    def create_module(self, spec):
        return self.module

    def exec_module(self, module):
        module.__spec__ = self.spec        # the import system set the old name's spec


class MovedFinder(importlib.abc.MetaPathFinder):
    """A ``sys.meta_path`` finder for the rows of :data:`MOVED`."""

    def find_spec(self, fullname, path=None, target=None):
        now = new_name(fullname)
        if now is None or fullname in PACKAGES_UNDER_FUNCTIONS:
            return None
        warnings.warn(f"{fullname} moved to {now}; the old path goes in mbgen {REMOVED_IN} "
                      f"(CHANGELOG.md)", DeprecationWarning, stacklevel=2)
        module = importlib.import_module(now)
        return importlib.util.spec_from_loader(fullname, _Existing(module),
                                               is_package=hasattr(module, "__path__"))


def install() -> None:
    """Put :class:`MovedFinder` first on ``sys.meta_path`` (once) and the old package
    names of :data:`PACKAGES_UNDER_FUNCTIONS` in ``sys.modules``."""
    if not any(isinstance(f, MovedFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, MovedFinder())
    for old in PACKAGES_UNDER_FUNCTIONS:
        sys.modules.setdefault(old, importlib.import_module(MOVED[old]))
