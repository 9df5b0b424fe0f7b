"""Which outputs a set of equations can give, and why not when they cannot.

An output applies to :class:`~mbgen.symbolic.equations.Equations` when the
equations carry what it reads: the energy needs ``kinetic_energy``, the points'
positions need points, the parameter Jacobian needs a parameter that the motion
uses, and so on.  What each output needs is its row's ``needs``
(:data:`mbgen.abi.OUTPUT_INFO`, checked in order); :data:`CONDITIONS` holds, per
:class:`~mbgen.abi.Need`, the test and the message of the
:class:`~mbgen.errors.ModelError` raised when it fails.  The code generator
(:mod:`mbgen.codegen.outputs`) raises that error and the reference
(:mod:`mbgen.runtime.lambdified`) offers only :func:`applicable` outputs: both read
:data:`REQUIREMENTS`, the rows' needs as conditions.

The motion is ``M``, ``F``, ``G``, the recursion's accelerations and the
constraints' velocity and acceleration terms (:func:`motion_exprs`); the symbols
it uses (through the program) decide :func:`dynamic_parameters` (the columns of
the parameter Jacobian) and :func:`time_symbols` (whether ``df/dt`` is needed).
:data:`SENSITIVITIES` says what each sensitivity output ``df/dv`` differentiates by
(from its row's ``wrt``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..abi import EXPRESSION_OUTPUTS, OUTPUT_INFO, Need, Output
from ..errors import ModelError
from .equations import Equations
from .layout import Layout


def motion_exprs(eq: Equations) -> list:
    """Every expression the right-hand side may use (either form, constraints included)."""
    out = list(eq.mass_matrix) + list(eq.forcing) + list(eq.kinematics)
    if eq.accelerations is not None:
        out += list(eq.accelerations)
    if eq.constraints is not None:
        c = eq.constraints
        out += list(c.velocity_matrix) + list(c.velocity_bias) + list(c.acceleration_bias)
    if eq.contacts is not None:
        out += eq.contacts.expressions()
    return out


def time_symbols(eq: Equations) -> set:
    """Layout symbols the motion uses (``layout.time`` among them: a time-dependent model)."""
    return eq.uses(motion_exprs(eq))


def dynamic_parameters(eq: Equations) -> tuple:
    """Parameters that ``M``, ``F``, ``G`` (or the recursion) use: the others have zero
    sensitivity."""
    used = eq.uses(motion_exprs(eq))
    return tuple(p for p in eq.layout.parameters if p in used)


_IMPORTED = ("they come from from_sympy(), which converts the equations of motion only "
             "(from_sympy(obj, name=, parameters=, dependent=) takes no option for more): leave "
             "{what} out, or build the model with mbgen.Model to get it")


def imported(eq: Equations) -> bool:
    """Equations converted by :func:`mbgen.from_sympy` (their ``method`` is ``sympy.*``)."""
    return str(eq.method).startswith("sympy.")


def imported_hint(what: str) -> str:
    """What to do when imported equations lack what ``what`` (an option's name) needs."""
    return _IMPORTED.format(what=what)


def _advice(eq: Equations, output: Output, otherwise: str) -> str:
    return imported_hint(f"Output.{output.name}") if imported(eq) else otherwise


@dataclass(frozen=True)
class Requirement:
    """A condition on the equations, and the error message when it fails."""

    holds: Callable[[Equations], bool]
    message: Callable[[Equations, Output], str]


#: The test of every need, and the message when it fails.
CONDITIONS: dict[Need, Requirement] = {
    Need.ENERGY: Requirement(
        lambda eq: eq.kinetic_energy is not None,
        lambda eq, o: f"the equations of {eq.name!r} carry no energy expressions; " + _advice(
            eq, o, "derive with energy=True or leave Output.ENERGY out")),
    Need.DYNAMIC_PARAMETERS: Requirement(
        lambda eq: bool(dynamic_parameters(eq)),
        lambda eq, o: f"the equations of motion of {eq.name!r} have no parameters, so no "
                      f"parameter Jacobian"),
    Need.POINTS: Requirement(
        lambda eq: bool(eq.points),
        lambda eq, o: f"the equations of {eq.name!r} carry no points; " + _advice(
            eq, o, "list the points to report in the scene (Scene.points) or derive with "
                   "points=...")),
    Need.REACTIONS: Requirement(
        lambda eq: eq.reactions is not None and bool(eq.reactions.names),
        lambda eq, o: f"the equations of {eq.name!r} carry no joint reactions; " + _advice(
            eq, o, "derive with reactions=True (Output.REACTIONS asks for it) from an "
                   "mbgen.Model with at least one body")),
    Need.INPUTS: Requirement(
        lambda eq: bool(eq.layout.inputs),
        lambda eq, o: f"the model {eq.name!r} has no inputs, so no input Jacobian"),
    Need.CONSTRAINTS: Requirement(
        lambda eq: eq.constraints is not None,
        lambda eq, o: f"the model {eq.name!r} has no constraints, so no {o.value}"),
    Need.CONFIGURATION: Requirement(
        lambda eq: eq.constraints.m_h > 0,
        lambda eq, o: f"the model {eq.name!r} has no configuration (holonomic) constraints"),
    Need.MULTIPLIERS: Requirement(
        lambda eq: eq.constraints is not None or eq.contacts is not None,
        lambda eq, o: f"the model {eq.name!r} has no constraints or contacts, so no "
                      f"{o.value}"),
    Need.UNCONSTRAINED: Requirement(
        lambda eq: eq.constraints is None and eq.contacts is None,
        lambda eq, o: f"the model {eq.name!r} has constraints or contacts; {o.value} is for "
                      f"models without (use the jacobian or contact_jacobian output)"),
    Need.CONTACTS: Requirement(
        lambda eq: eq.contacts is not None,
        lambda eq, o: f"the model {eq.name!r} has no contacts, so no {o.value} (state them "
                      f"with model.contact(point) or contacts=... of from_urdf/from_mjcf)"),
}

#: What each output needs of the equations, checked in order (absent: always applies):
#: its row's ``needs`` as conditions.
REQUIREMENTS: dict[Output, tuple[Requirement, ...]] = {
    o: tuple(CONDITIONS[n] for n in row.needs) for o, row in OUTPUT_INFO.items() if row.needs}


def require(eq: Equations, output: Output) -> None:
    """Raise the :class:`~mbgen.errors.ModelError` of the first requirement that fails."""
    for r in REQUIREMENTS.get(output, ()):
        if not r.holds(eq):
            raise ModelError(r.message(eq, output))


def applies(eq: Equations, output: Output) -> bool:
    """Whether the equations can give ``output`` (an expression output)."""
    return all(r.holds(eq) for r in REQUIREMENTS.get(output, ()))


def applicable(eq: Equations) -> tuple[Output, ...]:
    """Every expression output the equations can give (energy, parameters, points permitting)."""
    return tuple(o for o in EXPRESSION_OUTPUTS if applies(eq, o))


@dataclass(frozen=True)
class Sensitivity:
    """``df/dv`` of the first-order right-hand side ``f``: the variables ``v`` of the equations
    in the order of a layout; ``vector``: ``v`` is time alone, so ``df/dt`` has shape ``(n_x,)``
    rather than ``(n_x, n_v)``."""

    variables: Callable[[Equations, Layout], tuple]
    vector: bool = False


def _dynamic_in(eq: Equations, layout: Layout) -> tuple:
    used = set(dynamic_parameters(eq))
    return tuple(p for p in layout.parameters if p in used)


#: What ``df/dv`` differentiates by, per argument ``v`` (a row's ``wrt``).
BY_ARGUMENT: dict[str, Sensitivity] = {
    "x": Sensitivity(lambda eq, L: L.states),
    "p": Sensitivity(_dynamic_in),
    "t": Sensitivity(lambda eq, L: (L.time,), vector=True),
    "r": Sensitivity(lambda eq, L: L.inputs),
}

#: The sensitivity outputs: what each differentiates by (the rows with a ``wrt``).
SENSITIVITIES: dict[Output, Sensitivity] = {
    o: BY_ARGUMENT[row.wrt] for o, row in OUTPUT_INFO.items() if row.wrt}
