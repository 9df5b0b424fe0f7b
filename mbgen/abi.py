"""What generated code promises its callers: the outputs, the status codes, the rendered bundle.

This is the contract between the stage that writes code (:mod:`mbgen.codegen`)
and the stages that build and run it (:mod:`mbgen.build.extension`, :mod:`mbgen.runtime`):
both read it, neither imports the other.

:class:`Output`
    The functions a generated model may hold (``<prefix>_<output>``) and the
    integrators that may be rendered with them.
:data:`OUTPUT_INFO`
    One :class:`OutputInfo` row per expression output: its C array, its shape, what
    it computes, what it needs of the equations (:class:`Need`) and what a
    sensitivity differentiates by.  The stages derive what they state about an
    output from its row; each keeps only its builder, keyed by :class:`Output`.
Status codes
    What every generated C function returns (``<PREFIX>_<CODE>`` in the
    header): :data:`STATUS_CODES` always, :data:`INTEGRATOR_STATUS_CODES` with an
    integrator or the step API, :data:`CONSTRAINT_STATUS_CODES` for a
    constrained model, :data:`CONTACT_STATUS_CODES` for one with contacts.  The
    generated Python raises the matching exception.
:class:`Rendered`, :class:`FunctionInfo`
    The file texts, the cffi declarations and how to call each function.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

from .errors import ModelError

if TYPE_CHECKING:   # an annotation only: abi sits below the symbolic stage
    from .symbolic.layout import Layout

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
    CONTACT_JACOBIAN = "contact_jacobian"
    TANGENT_JACOBIAN = "tangent_jacobian"
    DOPRI5 = "dopri5"
    RK4 = "rk4"
    ROSENBROCK = "rosenbrock"

    @property
    def is_integrator(self) -> bool:
        return self in INTEGRATORS

    @classmethod
    def parse(cls, values: Iterable) -> tuple[Output, ...]:
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


class Need(str, Enum):
    """What an output needs of the equations beyond ``M``, ``F`` and ``G``.

    :data:`mbgen.symbolic.availability.CONDITIONS` holds the test of each and the
    error message when it fails.
    """

    ENERGY = "energy"                           # kinetic (and potential) energy expressions
    DYNAMIC_PARAMETERS = "dynamic_parameters"   # a parameter that the motion uses
    POINTS = "points"                           # points to report
    REACTIONS = "reactions"                     # joint reactions (a model with a body)
    INPUTS = "inputs"                           # an input
    CONSTRAINTS = "constraints"                 # constraints of any kind
    CONFIGURATION = "configuration"             # configuration (holonomic) constraints
    MULTIPLIERS = "multipliers"                 # constraints or contacts: forces to report
    CONTACTS = "contacts"                       # rigid point contacts
    UNCONSTRAINED = "unconstrained"             # neither constraints nor contacts


@dataclass(frozen=True)
class OutputInfo:
    """One expression output: everything about it that is data.

    The stages derive from this row what they state about the output -- the
    generated C comment (:func:`mbgen.codegen.outputs.spec`), whether some equations
    can give it (:mod:`mbgen.symbolic.availability`), the accessor's docstring
    (:mod:`mbgen.runtime.base`) and the table in ``docs/modelling.md`` (checked by
    ``tests/codegen/test_outputs.py``) -- and keep only how they compute it, keyed by
    :class:`Output`.

    Attributes
    ----------
    output : Output
    array : str
        The output array of the C function ``int <prefix>_<output>(double t, const double
        *x[, const double *p][, const double *r], double *<array>)`` (``p`` and ``r`` when
        the model has parameters and inputs), and the result's name in the generated Python.
    shape : tuple of str
        The result's shape in the model's sizes: ``n_x`` states, ``n_q`` coordinates, ``n_u``
        (independent) speeds, ``n_d`` dependent speeds (0 without constraints), ``n_p``
        parameters, ``n_pd`` those of them the motion uses (``M``, ``F``, ``G``: the columns of
        ``df/dp``), ``n_r`` inputs, ``m`` constraints, ``m_h`` configuration constraints,
        ``k`` reported points, ``n_joints`` joints (``m``: three per contact of a model with
        contacts); or a sum of them (``"n_u + n_d"``), or
        a number.  The C array holds it row-major.
    doc : str
        What it computes, one sentence of plain text without the final period (no markup:
        it lands in C comments, docstrings and Markdown alike).  Where it does not depend on
        the equations it is the generated function's comment, with a 2-D array's row-major
        layout.
    needs : tuple of Need
        What it needs of the equations, checked in this order (empty: every model gives it).
    wrt : str
        For a sensitivity ``df/dv`` of the first-order right-hand side: the argument ``v``
        it differentiates by, ``"x"``, ``"p"``, ``"t"`` or ``"r"`` (empty for the others).
    note : str
        More for Python callers, as a sentence without the final period: in the accessor's
        docstring and the docs, not in C.
    """

    output: Output
    array: str
    shape: tuple[str, ...]
    doc: str
    needs: tuple[Need, ...] = ()
    wrt: str = ""
    note: str = ""

    @property
    def shape_text(self) -> str:
        """The shape as Python writes a tuple: ``"(n_x,)"``, ``"(n_x, n_p)"``."""
        return f"({self.shape[0]},)" if len(self.shape) == 1 else f"({', '.join(self.shape)})"


_POINTS = "The points reported are the scene's points, else every point but the origin"

#: Every expression output, one row each (integrators have none: they are C code that calls
#: these, :mod:`mbgen.integrators`).
OUTPUT_INFO: dict[Output, OutputInfo] = {row.output: row for row in (
    OutputInfo(Output.RHS, "dxdt", ("n_x",),
               "First-order right-hand side dxdt = [q'; u']: q' = G(q,u,t) and the accelerations "
               "u' of M u' = F"),
    OutputInfo(Output.MASS_MATRIX, "M", ("n_u + n_d", "n_u + n_d"),
               "Mass matrix M(q,t), symmetric (with constraints: of every speed, the dependent "
               "ones last, in M u' = F + A^T lambda)"),
    OutputInfo(Output.FORCING, "F", ("n_u + n_d",),
               "Forcing F(q,u,r,t) of M u' = F (with constraints: of every speed, the dependent "
               "ones last, in M u' = F + A^T lambda)"),
    OutputInfo(Output.ENERGY, "energy", ("2",),
               "Kinetic energy T and potential energy V (gravity, springs)", (Need.ENERGY,)),
    OutputInfo(Output.JACOBIAN, "J", ("n_x", "n_x"),
               "Jacobian df/dx of the first-order right-hand side", wrt="x",
               note="Pass it to solve_ivp as its jac argument"),
    OutputInfo(Output.PARAMETER_JACOBIAN, "Jp", ("n_x", "n_pd"),
               "Parameter Jacobian df/dp of the right-hand side", (Need.DYNAMIC_PARAMETERS,),
               wrt="p"),
    OutputInfo(Output.TIME_DERIVATIVE, "dfdt", ("n_x",),
               "Partial time derivative df/dt of the right-hand side", wrt="t",
               note="Zero unless the model depends on t explicitly"),
    OutputInfo(Output.POSITIONS, "positions", ("k", "3"),
               "Positions of the reported points in Newtonian components", (Need.POINTS,),
               note=_POINTS),
    OutputInfo(Output.VELOCITIES, "velocities", ("k", "3"),
               "Velocities of the reported points in Newtonian components", (Need.POINTS,),
               note=_POINTS),
    OutputInfo(Output.REACTIONS, "reactions", ("n_joints", "6"),
               "Joint reactions: for each joint, the force and the moment (about the joint "
               "point) that the parent exerts on the child, in the joint's frame: Fx, Fy, Fz, "
               "Mx, My, Mz", (Need.REACTIONS,),
               note="Rows in the order of reaction_names (from the root), each in the frame "
                    "named in reaction_frames"),
    OutputInfo(Output.INPUT_JACOBIAN, "Jr", ("n_x", "n_r"),
               "Input Jacobian df/dr of the right-hand side (B of a linearisation)",
               (Need.INPUTS,), wrt="r"),
    OutputInfo(Output.CONSTRAINT_FORCES, "lam", ("m",),
               "Constraint multipliers lambda of M u' = F + A^T lambda, one per constraint (a "
               "point constraint's: the force on the body at the point along the frame axis)",
               (Need.MULTIPLIERS,),
               note="A stated constraint's multiplier is the generalized force conjugate to it; "
                    "rows in the order of constraint_names; with contacts (m = 3 per contact), "
                    "the force the ground exerts at each contact point in Newtonian components, "
                    "contacts in the order stated"),
    OutputInfo(Output.HOLONOMIC, "fh", ("m_h",),
               "Residual f_h(q, t) of the configuration constraints (zero on the constraint "
               "manifold)", (Need.CONSTRAINTS, Need.CONFIGURATION)),
    OutputInfo(Output.HOLONOMIC_JACOBIAN, "dfh", ("m_h", "n_q"),
               "Jacobian of the configuration constraints, df_h/dq",
               (Need.CONSTRAINTS, Need.CONFIGURATION)),
    OutputInfo(Output.CONTACT_JACOBIAN, "Jc", ("n_x + m", "n_x"),
               "Jacobian d(f, lambda)/dx of the right-hand side f and the contact forces lambda "
               "together: the n_x rows of the jacobian output, then one row per contact force",
               (Need.CONTACTS,),
               note="The derivatives of the contact dynamics in one call (Pinocchio's "
                    "computeConstraintDynamicsDerivatives: du'/dq, du'/du, dlambda/dq, dlambda/du; "
                    "mbgen.tangent_jacobian maps a floating base's quaternion columns)"),
    OutputInfo(Output.TANGENT_JACOBIAN, "Jt", ("n_u", "2*n_u"),
               "Jacobian [du'/d delta, du'/du] of the accelerations in the speeds' tangent "
               "space: delta moves the configuration along the speeds, q + G(q) delta with "
               "G = dq'/du", (Need.UNCONSTRAINED,),
               note="Pinocchio's computeABADerivatives [ddq_dq, ddq_dv], a floating base's "
                    "quaternion included; where q' = u, the u' rows of the jacobian output. "
                    "For kinematics q' = G(q) u (every joint of from_urdf and from_mjcf)"),
)}


STATUS_CODES = (("OK", 0, "success"),
                ("NOT_POSITIVE_DEFINITE", 1, "the mass matrix is not positive definite"),
                ("NONFINITE", 2, "an output is NaN or infinite"))
CONSTRAINT_STATUS_CODES = (
    ("CONSTRAINT_SINGULAR", 7, "the constraint Jacobian A_r of the dependent speeds is singular "
                               "(a locked or singular configuration)"),
    ("PROJECTION_FAILED", 8, "the dependent coordinates could not be projected back onto the "
                             "configuration constraints (Newton did not converge)"))
CONTACT_STATUS_CODES = (
    ("CONTACT_SINGULAR", 9, "the contacts' Delassus matrix J M^-1 J^T is singular (two "
                            "contacts on one point, a leg stretched straight: the forces are "
                            "undetermined)"),)
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
                    STATUS_CODES + INTEGRATOR_STATUS_CODES + CONSTRAINT_STATUS_CODES
                    + CONTACT_STATUS_CODES}


def status_name(status: int) -> str:
    """The code's name without prefix (``"MAX_STEPS"``), ``"UNKNOWN"`` for no code."""
    return ALL_STATUS_CODES.get(status, ("UNKNOWN", ""))[0]


def status_message(prefix: str, status: int) -> str:
    """``"<PREFIX>_CODE: meaning"`` of a C status code (``""`` for OK)."""
    if status == 0:
        return ""
    code, text = ALL_STATUS_CODES.get(status, ("UNKNOWN", "unknown error"))
    return f"{prefix.upper()}_{code}: {text}"


__all__ = ["Output", "INTEGRATORS", "EXPRESSION_OUTPUTS", "Need", "OutputInfo", "OUTPUT_INFO",
           "STATUS_CODES", "INTEGRATOR_STATUS_CODES", "CONSTRAINT_STATUS_CODES",
           "CONTACT_STATUS_CODES",
           "ALL_STATUS_CODES", "status_name", "status_message", "Rendered", "FunctionInfo"]
