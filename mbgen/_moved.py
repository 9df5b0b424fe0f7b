"""Module paths that moved, kept importable for one minor version (0.2) with a warning.

The documented paths of earlier releases (``mbgen.plots.plot_simulation`` before the stage
packages; ``mbgen.run.named.read_input_csv`` before the stage packages became nouns) still
import, as the module that now holds them -- the same module object, so a class imported
the old way *is* the class imported the new way -- with a :class:`DeprecationWarning`
that names the new path.  ``CHANGELOG.md`` lists the moves.

``mbgen.run`` and ``mbgen.derive`` are public *functions* (the pipeline's first and last
verbs); the packages that held the stages under those names are now ``mbgen.runtime`` and
``mbgen.derivation``.  A finder that answers ``import mbgen.run.named`` imports the package
``mbgen.run`` first (the new package, under its old name), after which the import system
binds ``mbgen.run`` to that module; :class:`FunctionsStay`, the class of the ``mbgen``
module (:func:`install`), refuses that one binding, so ``mbgen.run`` stays the function, and
nothing is imported before an old path is asked for (``import mbgen`` imports no stage).
``import mbgen.run.x as y`` cannot work while ``mbgen.run`` is a function (Python binds
``y`` by attributes); ``from mbgen.run.x import name`` does.

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
import types
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
        if now is None:
            return None
        if fullname in PACKAGES_UNDER_FUNCTIONS:     # the parent of an old path: no warning
            module = importlib.import_module(now)
            return importlib.util.spec_from_loader(fullname, _Existing(module), is_package=True)
        warnings.warn(f"{fullname} moved to {now}; the old path goes in mbgen {REMOVED_IN} "
                      f"(CHANGELOG.md)", DeprecationWarning, stacklevel=2)
        module = importlib.import_module(now)
        return importlib.util.spec_from_loader(fullname, _Existing(module),
                                               is_package=hasattr(module, "__path__"))


class FunctionsStay(types.ModuleType):
    """The class of the ``mbgen`` module: the import system's binding of an old package of
    :data:`PACKAGES_UNDER_FUNCTIONS` to its name (``mbgen.run = <module mbgen.runtime>``,
    once a submodule of it was imported) is refused, so the name stays the function."""

    def __setattr__(self, name, value):
        if f"{self.__name__}.{name}" in PACKAGES_UNDER_FUNCTIONS and \
                isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


def install() -> None:
    """Put :class:`MovedFinder` first on ``sys.meta_path`` (once) and make
    :class:`FunctionsStay` the class of the ``mbgen`` module."""
    if not any(isinstance(f, MovedFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, MovedFinder())
    package = sys.modules[__name__.rpartition(".")[0]]
    if not isinstance(package, FunctionsStay):
        package.__class__ = FunctionsStay
