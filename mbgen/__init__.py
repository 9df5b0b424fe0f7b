"""mbgen: multibody models to fast, verified C and Python.

Pipeline (each arrow is one function returning a frozen value)::

    Model --derive--> Equations --bake/optimize--> Kernel --render--> Rendered
          --build--> CompiledModel --verify--> Report

The folders are the stages, and imports run downward only (the import-linter
contract in ``pyproject.toml``, run by ``tests/test_layout.py``)::

    cli                      one module per subcommand
    bench                    benchmarks (nothing below imports them)
    studies                  work-precision, ensembles
    verify | viz | export    check, golden, audit, stress | pictures | FMU
    pipeline                 derive -> bake -> optimize -> render -> build
    derivation | codegen     Model -> Equations | Equations -> Rendered
    model | runtime          what the user states | the three back ends
    symbolic | build | integrators
    abi | names | fileio | summary
    errors

This module is the public face: the names a user imports from ``mbgen``.

How to add a public name
------------------------
1. Define it in the stage that owns it (never here), public in its module.
2. Import it below and list it in ``__all__``.
3. Say it in README.md (its examples run in ``tests/test_readme_blocks.py``);
   ``tests/test_packaging.py`` imports the installed package.
A new stage is a folder placed in the ``layers`` of ``pyproject.toml``'s
import-linter contract; ``tests/test_layout.py`` fails until it is, and until
its ``__init__`` says how to add one more of what it holds.
"""

from importlib import import_module as _import_module

from . import _moved
from ._version import __version__
from .abi import Output
from .codegen.optimize import CseBackend
from .codegen.targets import Targets
from .derivation import Method, derive
from .derivation.from_sympy import from_sympy
from .errors import (
    BuildError,
    CheckFailed,
    ConstraintError,
    IntegrationError,
    MbgenError,
    ModelError,
    NonFiniteResultError,
    SceneError,
    SingularConstraintError,
    SingularMassMatrixError,
    UnknownNameError,
    UsageError,
)
from .export import export_fmu, generate
from .model.builder import Model, t
from .model.mjcf import from_mjcf, from_mujoco
from .model.scene import Scene, load_scene
from .model.urdf import from_urdf
from .pipeline import compile, equations_of, run
from .runtime.compiled import CompiledModel
from .runtime.integration import Trajectory
from .runtime.lambdified import LambdifiedModel
from .runtime.linearize import Linearization, linearize, tangent_jacobian
from .runtime.named import InputTable
from .runtime.python import PythonModel, python_model
from .runtime.stepper import Stepper
from .studies.ensemble import ensemble
from .symbolic.equations import Equations
from .symbolic.layout import Layout

#: Public names imported on first use: ``simulate`` pulls in scipy.integrate (about 0.3 s)
#: and the pictures need the ``plot`` extra, so ``import mbgen`` does not pay for them.
_LAZY = {"simulate": "mbgen.runtime.simulate", "plot_simulation": "mbgen.viz.plots",
         "animate_scene": "mbgen.viz.animate"}


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(_import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mbgen' has no attribute {name!r}")


def __dir__():
    return sorted(set(__all__) | {n for n in globals() if n.startswith("__")})


__all__ = ["__version__", "linearize", "tangent_jacobian", "Linearization", "Model", "t",
           "derive", "from_sympy", "from_urdf", "from_mjcf", "from_mujoco", "Output",
           "CseBackend", "compile", "equations_of", "run", "python_model", "LambdifiedModel",
           "CompiledModel", "PythonModel", "Scene",
           "load_scene", "Method", "Equations", "Layout", "MbgenError", "ModelError",
           "SceneError", "ConstraintError", "BuildError", "SingularMassMatrixError",
           "SingularConstraintError", "NonFiniteResultError",
           "CheckFailed", "IntegrationError", "Targets", "export_fmu", "generate", "ensemble",
           "UnknownNameError", "UsageError", "InputTable", "simulate", "Trajectory", "Stepper",
           "plot_simulation", "animate_scene"]

_moved.install()
