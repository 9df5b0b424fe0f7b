"""What generated code promises its callers: the outputs, the status codes, the rendered bundle.

This is the contract between the stage that writes code (:mod:`mbgen.codegen`)
and the stages that build and run it (:mod:`mbgen.build.extension`, :mod:`mbgen.runtime`):
both read it, neither imports the other.

:class:`Output`
    The functions a generated model may hold (``<prefix>_<output>``) and the
    integrators that may be rendered with them.
Status codes
    What every generated C function returns (``<PREFIX>_<CODE>`` in the
    header): :data:`STATUS_CODES` always, :data:`INTEGRATOR_STATUS_CODES` with an
    integrator or the step API, :data:`CONSTRAINT_STATUS_CODES` for a
    constrained model.  The generated Python raises the matching exception.
:class:`Rendered`, :class:`FunctionInfo`
    The file texts, the cffi declarations and how to call each function.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from enum import Enum
from typing import Iterable

from .errors import ModelError

class Output(str, Enum):
    """What a generated model computes."""

    RHS = "rhs"
    MASS_MATRIX = "mass_matrix"
    FORCING = "forcing"
    ENERGY = "energy"
    JACOBIAN = "jacobian"
    PARAMETER_JACOBIAN = "parameter_jacobian"
    TIME_DERIVATIVE = "time_derivative"
    POSITIONS = "positions"
    VELOCITIES = "velocities"
    REACTIONS = "reactions"
    INPUT_JACOBIAN = "input_jacobian"
    CONSTRAINT_FORCES = "constraint_forces"
    HOLONOMIC = "holonomic"
    HOLONOMIC_JACOBIAN = "holonomic_jacobian"
    DOPRI5 = "dopri5"
    RK4 = "rk4"
    ROSENBROCK = "rosenbrock"

    @property
    def is_integrator(self) -> bool:
        return self in INTEGRATORS

    @classmethod
    def parse(cls, values: Iterable) -> tuple["Output", ...]:
        """Outputs from enum members or their names, in canonical (declaration) order."""
        if isinstance(values, (str, Output)):
            values = (values,)
        wanted = set()
        for v in values:
            try:
                wanted.add(v if isinstance(v, cls) else cls(str(v).lower()))
            except ValueError:
                raise ModelError(f"unknown output {v!r}; choose from "
                                 f"{', '.join(o.value for o in cls)}") from None
        return tuple(o for o in cls if o in wanted)


INTEGRATORS = (Output.DOPRI5, Output.RK4, Output.ROSENBROCK)
#: Outputs that are expressions of the equations (everything but the integrators).
EXPRESSION_OUTPUTS = tuple(o for o in Output if o not in INTEGRATORS)


STATUS_CODES = (("OK", 0, "success"),
                ("NOT_POSITIVE_DEFINITE", 1, "the mass matrix is not positive definite"),
                ("NONFINITE", 2, "an output is NaN or infinite"))
CONSTRAINT_STATUS_CODES = (
    ("CONSTRAINT_SINGULAR", 7, "the constraint Jacobian A_r of the dependent speeds is singular "
                               "(a locked or singular configuration)"),
    ("PROJECTION_FAILED", 8, "the dependent coordinates could not be projected back onto the "
                             "configuration constraints (Newton did not converge)"))
INTEGRATOR_STATUS_CODES = (
    ("STEP_TOO_SMALL", 3, "the step size fell below the resolution of t"),
    ("MAX_STEPS", 4, "the step limit was reached before the last output time"),
    ("SINGULAR_ITERATION_MATRIX", 5, "the implicit method's matrix I - h*gamma*J is singular"),
    ("BAD_ARGUMENT", 6, "invalid argument (output times not increasing, bad tolerances, ...)"))


@dataclass(frozen=True)
class Rendered:
    """Generated file texts of one model.

    Attributes
    ----------
    prefix : str
        C prefix and file stem (``<prefix>.h``, ``<prefix>.c``, ``<prefix>.py``).
    files : dict
        ``{file name: text}``.
    cdef : str
        Declarations for ``cffi.FFI.cdef`` (same prototypes as the header).
    functions : tuple of FunctionInfo
        How to call each generated function.
    layout : Layout
        The ABI: order of states, parameters and inputs of the generated code.
    defaults : dict
        Default values of the ABI's parameters (by name) where known.
    outputs : tuple of Output
        Every output generated, integrators included.
    extension, extension_cdef : str
        C source (and its declarations) compiled into the Python extension
        only: the batch loops of :mod:`mbgen.codegen.targets.batch`.
    content_hash : str
        ``<PREFIX>_CONTENT_HASH`` of the header (:mod:`mbgen.codegen.header`).
    stack_bounds : tuple of (str, int)
        Stack bound in bytes of every public C function, as stated in the header.
    step_methods : tuple of str
        The step API's methods (empty without the step target).
    joints : tuple of (str, str)
        Name and reaction frame of every joint, in the rows of the ``reactions`` output.
    constraints : tuple of str, and dependent : tuple of str
        Names of the constraints (rows of ``constraint_forces``) and the dependent
        coordinates of the configuration constraints (empty without constraints).
    """

    prefix: str
    files: dict
    cdef: str
    functions: tuple
    layout: Layout
    defaults: dict
    outputs: tuple
    extension: str = ""
    extension_cdef: str = ""
    content_hash: str = ""
    stack_bounds: tuple = ()
    step_methods: tuple = ()
    joints: tuple = ()
    constraints: tuple = ()
    dependent: tuple = ()

    @property
    def header(self) -> str:
        return self.files[f"{self.prefix}.h"]

    @property
    def source(self) -> str:
        return self.files[f"{self.prefix}.c"]

    @property
    def python(self) -> str:
        return self.files[f"{self.prefix}.py"]

    def digest(self) -> str:
        """Content hash of every file and the cdef (names the compiled module)."""
        h = hashlib.sha256()
        for name in sorted(self.files):
            h.update(name.encode() + b"\0" + self.files[name].encode() + b"\0")
        h.update(self.cdef.encode())
        h.update(b"\0" + self.extension.encode() + b"\0" + self.extension_cdef.encode())
        return h.hexdigest()

    def sources(self) -> dict:
        """Plain strings a process needs to build this model (no sympy, no compiled objects)."""
        return dict(prefix=self.prefix, files=dict(self.files), cdef=self.cdef,
                    extension=self.extension, extension_cdef=self.extension_cdef,
                    digest=self.digest())


@dataclass(frozen=True)
class FunctionInfo:
    """What a runtime needs to call one generated function."""

    output: str          # Output value, e.g. "rhs"
    c_name: str          # e.g. "pendulum_rhs"
    args: tuple          # subset of ("t", "x", "p", "r") in call order
    out_size: int
    out_shape: tuple
    out_labels: tuple


#: Every status code, by value: ``{value: (name, meaning)}``.
ALL_STATUS_CODES = {value: (name, text) for name, value, text in
                    STATUS_CODES + INTEGRATOR_STATUS_CODES + CONSTRAINT_STATUS_CODES}


def status_name(status: int) -> str:
    """The code's name without prefix (``"MAX_STEPS"``), ``"UNKNOWN"`` for no code."""
    return ALL_STATUS_CODES.get(status, ("UNKNOWN", ""))[0]


def status_message(prefix: str, status: int) -> str:
    """``"<PREFIX>_CODE: meaning"`` of a C status code (``""`` for OK)."""
    if status == 0:
        return ""
    code, text = ALL_STATUS_CODES.get(status, ("UNKNOWN", "unknown error"))
    return f"{prefix.upper()}_{code}: {text}"


__all__ = ["Output", "INTEGRATORS", "EXPRESSION_OUTPUTS", "STATUS_CODES",
           "INTEGRATOR_STATUS_CODES", "CONSTRAINT_STATUS_CODES", "ALL_STATUS_CODES",
           "status_name", "status_message", "Rendered", "FunctionInfo"]
