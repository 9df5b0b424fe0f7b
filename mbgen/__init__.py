"""mbgen: multibody models to fast, verified C and Python.

Pipeline (each arrow is one function returning a frozen value)::

    Model --derive--> Equations --optimize--> Kernel --render--> Rendered
          --build--> CompiledModel --verify--> Report
"""

from ._version import __version__
from .derive import Method, derive
from .symbolic.equations import Equations
from .errors import (BuildError, CheckFailed, ConstraintError, IntegrationError, MbgenError,
                     ModelError, NonFiniteResultError, SceneError, SingularConstraintError,
                     SingularMassMatrixError, UnknownNameError, UsageError)
from .derive.from_sympy import from_sympy
from .symbolic.layout import Layout
from .run.linearize import Linearization, linearize
from .run.named import InputTable
from .model.builder import Model, t
from .codegen.optimize import CseBackend
from .abi import Output
from .pipeline import compile, equations_of, run
from .run.lambdified import LambdifiedModel
from .run.compiled import CompiledModel
from .run.python import PythonModel, python_model
from .model.scene import Scene, load_scene
from .codegen.targets import Targets
from .export import export_fmu
from .studies.ensemble import ensemble
from .run.integration import Trajectory
from .run.simulate import simulate
from .run.stepper import Stepper
from .viz.plots import plot_simulation
from .viz.animate import animate_scene


__all__ = ["__version__", "linearize", "Linearization", "Model", "t", "derive", "from_sympy", "Output", "CseBackend", "compile", "equations_of", "run",
           "python_model", "LambdifiedModel", "CompiledModel", "PythonModel", "Scene",
           "load_scene", "Method", "Equations", "Layout", "MbgenError", "ModelError",
           "SceneError", "ConstraintError", "BuildError", "SingularMassMatrixError", "SingularConstraintError", "NonFiniteResultError",
           "CheckFailed", "IntegrationError", "Targets", "export_fmu", "ensemble",
           "UnknownNameError", "UsageError", "InputTable", "simulate", "Trajectory", "Stepper",
           "plot_simulation", "animate_scene"]
