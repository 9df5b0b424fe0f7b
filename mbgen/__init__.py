"""mbgen: multibody models to fast, verified C and Python.

Pipeline (each arrow is one function returning a frozen value)::

    Model --derive--> Equations --bake/optimize--> Kernel --render--> Rendered
          --build--> CompiledModel --verify--> Report

The folders are the stages, and imports run downward only (the import-linter
contract in ``pyproject.toml``, run by ``tests/test_layout.py``)::

    cli                      one module per subcommand
    bench                    benchmarks (nothing below imports them)
    studies                  work-precision, ensembles
    verify | viz | export | interop   check, golden, audit, stress | pictures | FMU |
                             CasADi and JAX functions
    pipeline                 derive -> bake -> optimize -> render -> build
    derivation | codegen     Model -> Equations | Equations -> Rendered
    model | runtime          what the user states | the three back ends
    symbolic | build | integrators
    abi | names | fileio | summary
    errors

This module is the public face: the names a user imports from ``mbgen``.  Each is
imported on first use (PEP 562 ``__getattr__`` over :data:`_PUBLIC`), so ``import mbgen``
and ``mbgen --version`` load no stage, and no sympy, NumPy, SciPy or Jinja, until a name
is used; ``from mbgen import X``, ``dir(mbgen)`` and ``__all__`` are as if every name
were imported here.

How to add a public name
------------------------
1. Define it in the stage that owns it (never here), public in its module.
2. Add it to its module's row of :data:`_PUBLIC` (a new row for a new module); ``__all__``
   is made from the table.
3. Give it an entry on a page of ``docs/api/`` (``tests/test_docs.py`` fails until it
   has one) and show it in use on a page of ``docs/`` (its examples run in
   ``tests/test_readme_blocks.py``); ``tests/test_packaging.py`` imports the installed
   package.
A new stage is a folder placed in the ``layers`` of ``pyproject.toml``'s
import-linter contract; ``tests/test_layout.py`` fails until it is, and until
its ``__init__`` says how to add one more of what it holds.
"""

from importlib import import_module as _import_module

from ._moved import install as _install_moved
from ._version import __version__

#: Where each public name lives: module -> names, imported on first use.
_PUBLIC = {
    "mbgen.abi": ("Output",),
    "mbgen.codegen.optimize": ("CseBackend",),
    "mbgen.codegen.targets": ("Targets",),
    "mbgen.derivation": ("Method", "derive"),
    "mbgen.derivation.from_sympy": ("from_sympy",),
    "mbgen.errors": ("BuildError", "CheckFailed", "ConstraintError", "IntegrationError",
                     "MbgenError", "ModelError", "NonFiniteResultError", "SceneError",
                     "SingularConstraintError", "SingularMassMatrixError", "UnknownNameError",
                     "UsageError"),
    "mbgen.export": ("export_fmu", "generate"),
    "mbgen.interop": ("casadi_function", "jax_function"),
    "mbgen.model.builder": ("Model", "t"),
    "mbgen.model.mjcf": ("from_mjcf", "from_mujoco"),
    "mbgen.model.scene": ("Scene", "load_scene"),
    "mbgen.model.urdf": ("from_urdf",),
    "mbgen.pipeline": ("compile", "equations_of", "run"),
    "mbgen.runtime.compiled": ("CompiledModel",),
    "mbgen.runtime.integration": ("Trajectory",),
    "mbgen.runtime.lambdified": ("LambdifiedModel",),
    "mbgen.runtime.linearize": ("Linearization", "linearize", "tangent_jacobian"),
    "mbgen.runtime.named": ("InputTable",),
    "mbgen.runtime.python": ("PythonModel", "python_model"),
    "mbgen.runtime.simulate": ("simulate",),
    "mbgen.runtime.stepper": ("Stepper",),
    "mbgen.studies.ensemble": ("ensemble",),
    "mbgen.symbolic.equations": ("Equations",),
    "mbgen.symbolic.layout": ("Layout",),
    "mbgen.viz.plots": ("plot_simulation",),
    "mbgen.viz.animate": ("animate_scene",),
}

#: Public name -> its module (:data:`_PUBLIC` turned round).
_HOME = {name: module for module, names in _PUBLIC.items() for name in names}


def __getattr__(name: str):
    """A public name, imported from its module on first use and kept here."""
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'mbgen' has no attribute {name!r}")
    value = getattr(_import_module(home), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(__all__) | {n for n in globals() if n.startswith("__")})


__all__ = ["__version__", *_HOME]

_install_moved()
