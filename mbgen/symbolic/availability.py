"""Which outputs a set of equations can give, and why not when they cannot.

An output applies to :class:`~mbgen.symbolic.equations.Equations` when the
equations carry what it reads: the energy needs ``kinetic_energy``, the points'
positions need points, the parameter Jacobian needs a parameter that the motion
uses, and so on.  :data:`REQUIREMENTS` holds, per output, the conditions in the
order they are checked, each with the message of the
:class:`~mbgen.errors.ModelError` raised when it fails; an output without a row
always applies.  The code generator (:mod:`mbgen.codegen.outputs`) raises that
error and the reference (:mod:`mbgen.runtime.lambdified`) offers only
:func:`applicable` outputs: both read this one table.

The motion is ``M``, ``F``, ``G``, the recursion's accelerations and the
constraints' velocity and acceleration terms (:func:`motion_exprs`); the symbols
it uses (through the program) decide :func:`dynamic_parameters` (the columns of
the parameter Jacobian) and :func:`time_symbols` (whether ``df/dt`` is needed).
:data:`SENSITIVITIES` says what each sensitivity output ``df/dv`` differentiates by.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..abi import EXPRESSION_OUTPUTS, Output
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
    return out


def time_symbols(eq: Equations) -> set:
    """Layout symbols the motion uses (``layout.time`` among them: a time-dependent model)."""
    return eq.uses(motion_exprs(eq))


def dynamic_parameters(eq: Equations) -> tuple:
    """Parameters that ``M``, ``F``, ``G`` (or the recursion) use: the others have zero sensitivity."""
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


ENERGY = Requirement(
    lambda eq: eq.kinetic_energy is not None,
    lambda eq, o: f"the equations of {eq.name!r} carry no energy expressions; " + _advice(
        eq, o, "derive with energy=True or leave Output.ENERGY out"))
DYNAMIC_PARAMETERS = Requirement(
    lambda eq: bool(dynamic_parameters(eq)),
    lambda eq, o: f"the equations of motion of {eq.name!r} have no parameters, so no "
                  f"parameter Jacobian")
POINTS = Requirement(
    lambda eq: bool(eq.points),
    lambda eq, o: f"the equations of {eq.name!r} carry no points; " + _advice(
        eq, o, "list the points to report in the scene (Scene.points) or derive with "
               "points=..."))
REACTIONS = Requirement(
    lambda eq: eq.reactions is not None and bool(eq.reactions.names),
    lambda eq, o: f"the equations of {eq.name!r} carry no joint reactions; " + _advice(
        eq, o, "derive with reactions=True (Output.REACTIONS asks for it) from an "
               "mbgen.Model with at least one body"))
INPUTS = Requirement(
    lambda eq: bool(eq.layout.inputs),
    lambda eq, o: f"the model {eq.name!r} has no inputs, so no input Jacobian")
CONSTRAINED = Requirement(
    lambda eq: eq.constraints is not None,
    lambda eq, o: f"the model {eq.name!r} has no constraints, so no {o.value}")
CONFIGURATION = Requirement(
    lambda eq: eq.constraints.m_h > 0,
    lambda eq, o: f"the model {eq.name!r} has no configuration (holonomic) constraints")

#: What each output needs of the equations, checked in order (absent: always applies).
REQUIREMENTS: dict[Output, tuple[Requirement, ...]] = {
    Output.ENERGY: (ENERGY,),
    Output.PARAMETER_JACOBIAN: (DYNAMIC_PARAMETERS,),
    Output.POSITIONS: (POINTS,),
    Output.VELOCITIES: (POINTS,),
    Output.REACTIONS: (REACTIONS,),
    Output.INPUT_JACOBIAN: (INPUTS,),
    Output.CONSTRAINT_FORCES: (CONSTRAINED,),
    Output.HOLONOMIC: (CONSTRAINED, CONFIGURATION),
    Output.HOLONOMIC_JACOBIAN: (CONSTRAINED, CONFIGURATION),
}


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


#: The sensitivity outputs: what each differentiates by.
SENSITIVITIES: dict[Output, Sensitivity] = {
    Output.JACOBIAN: Sensitivity(lambda eq, L: L.states),
    Output.PARAMETER_JACOBIAN: Sensitivity(_dynamic_in),
    Output.TIME_DERIVATIVE: Sensitivity(lambda eq, L: (L.time,), vector=True),
    Output.INPUT_JACOBIAN: Sensitivity(lambda eq, L: L.inputs),
}
