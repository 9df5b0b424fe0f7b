"""mbgen: multibody models to fast, verified C and Python.

Pipeline (each arrow is one function returning a frozen value)::

    Model --derive--> Equations --optimize--> Kernel --render--> Rendered
          --build--> CompiledModel --verify--> Report
"""

from ._version import __version__
from .derive import Method, derive
from .equations import Equations
from .errors import (BuildError, CheckFailed, ConstraintError, IntegrationError, MbgenError,
                     ModelError,
                     NonFiniteResultError, SceneError, SingularConstraintError,
                     SingularMassMatrixError, UnknownNameError, UsageError)
from .importers import from_sympy
from .layout import Layout
from .linearize import Linearization, linearize
from .named import InputTable
from .model import Model, t
from .optimize import CseBackend
from .abi import Output
from .pipeline import compile, equations_of, python_model, run
from .reference import LambdifiedModel
from .runtime import CompiledModel, PythonModel
from .scene import Scene, load_scene
from .targets import Targets
from .targets.fmu import export_fmu
from .ensemble import ensemble


__all__ = ["__version__", "linearize", "Linearization", "Model", "t", "derive", "from_sympy", "Output", "CseBackend", "compile", "equations_of", "run",
           "python_model", "LambdifiedModel", "CompiledModel", "PythonModel", "Scene",
           "load_scene", "Method", "Equations", "Layout", "MbgenError", "ModelError",
           "SceneError", "ConstraintError", "BuildError", "SingularMassMatrixError", "SingularConstraintError", "NonFiniteResultError",
           "CheckFailed", "IntegrationError", "Targets", "export_fmu", "ensemble",
           "UnknownNameError", "UsageError", "InputTable"]
