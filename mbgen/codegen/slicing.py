"""Slicing: bake fixed parameters and absent inputs into the equations.

``bake(equations, fixed, inputs)`` is a pure stage between derivation and
optimisation.  Intermediate quantities of a recursive derivation (the
equations' program) that become numbers are folded into what uses them.  Fixed
parameters become numbers (integral values stay exact, so
``2*g`` with ``g = 10`` folds to ``20``; a zero offset removes every term it
multiplies), inputs that a scene leaves out become zero, and both leave the
layout, so they vanish from the arithmetic and from the generated ABI.
Parameters that no emitted expression uses are removed later, in
:func:`mbgen.codegen.optimize.optimize`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import sympy as sm

from ..errors import ModelError
from ..symbolic.build import interned
from ..symbolic.equations import Equations, PointKinematics
from ..symbolic.graph import xreplace_dag
from ..symbolic.layout import Layout
from ..symbolic.program import Program


def number(value: float) -> sm.Expr:
    """A sympy number for ``value``: exact when integral, else a double-precision Float."""
    value = float(value)
    if value.is_integer() and abs(value) < 2**53:
        return sm.Integer(int(value))
    return sm.Float(value, 17)


def bake(equations: Equations, fixed: Mapping[str, float] | None = None,
         inputs: Sequence[str] | None = None) -> Equations:
    """Substitute ``fixed`` parameter values and zero for inputs not in ``inputs``.

    Parameters
    ----------
    equations : Equations
    fixed : mapping name -> value
        Parameters to bake in as constants.
    inputs : sequence of str or None
        Inputs the scene provides at run time; ``None`` keeps every input.

    Returns
    -------
    Equations
        With a layout that no longer lists the baked parameters and absent inputs.
    """
    with interned():    # changed sums and products built directly (mbgen.symbolic.build)
        return _bake(equations, fixed, inputs)


def _bake(equations: Equations, fixed: Mapping[str, float] | None = None,
          inputs: Sequence[str] | None = None) -> Equations:
    """:func:`bake`'s work, inside its interning of new nodes."""
    fixed = dict(fixed or {})
    L = equations.layout
    by_name = {str(s): s for s in L.parameters}
    unknown = set(fixed) - set(by_name)
    if unknown:
        raise ModelError(f"fixed parameter(s) {sorted(unknown)} are not parameters of "
                         f"{equations.name!r}; parameters: {list(L.parameter_names)}")
    keep_inputs = L.input_names if inputs is None else tuple(inputs)
    unknown = set(keep_inputs) - set(L.input_names)
    if unknown:
        raise ModelError(f"input(s) {sorted(unknown)} are not inputs of {equations.name!r}; "
                         f"inputs: {list(L.input_names)}")
    sub = {by_name[k]: number(v) for k, v in fixed.items()}
    sub.update({s: sm.S.Zero for s in L.inputs if str(s) not in keep_inputs})
    program = equations.program
    if not sub and not program:
        return equations

    memo: dict = {}   # one memo for every field: shared subexpressions are replaced once
    mapping = dict(sub)
    kept = []
    for sym, e in program.assignments:   # fold: assignments that became numbers or symbols go
        value = xreplace_dag([e], mapping, memo, keep_sums=True)[0]
        if sym not in program.checks and (value.is_Number or value.is_Symbol):
            mapping[sym] = value
        else:
            kept.append((sym, value))
    if not sub and len(kept) == len(program.assignments):
        return equations

    def bake_all(exprs):
        return xreplace_dag(exprs, mapping, memo, keep_sums=True)

    def bake_matrix(m):
        return sm.ImmutableMatrix(m.rows, m.cols, bake_all(list(m)))

    def bake_expr(e):
        return None if e is None else bake_all([e])[0]

    reactions = equations.reactions
    if reactions is not None:
        reactions = replace(reactions, matrix=bake_matrix(reactions.matrix))
    layout = Layout(L.coordinates, L.speeds,
                    tuple(s for s in L.parameters if s not in sub),
                    tuple(s for s in L.inputs if s not in sub), L.time, L.dependent_speeds)
    constraints = equations.constraints
    if constraints is not None:
        constraints = replace(constraints, **{
            f: bake_matrix(getattr(constraints, f))
            for f in ("holonomic", "holonomic_jacobian", "velocity_matrix", "velocity_bias",
                      "acceleration_bias")})
    return replace(
        equations,
        layout=layout,
        mass_matrix=bake_matrix(equations.mass_matrix),
        forcing=bake_matrix(equations.forcing),
        kinematics=bake_matrix(equations.kinematics),
        kinetic_energy=bake_expr(equations.kinetic_energy),
        potential_energy=bake_expr(equations.potential_energy),
        points=tuple(PointKinematics(pk.name, bake_matrix(pk.position), bake_matrix(pk.velocity))
                     for pk in equations.points),
        defaults={k: v for k, v in equations.defaults.items() if k not in fixed},
        program=Program(tuple(kept), program.checks),
        accelerations=(None if equations.accelerations is None
                       else bake_matrix(equations.accelerations)),
        reactions=reactions,
        constraints=constraints,
        residual=None if equations.residual is None else bake_matrix(equations.residual),
        residual_jacobian=(None if equations.residual_jacobian is None
                           else bake_matrix(equations.residual_jacobian)),
        residual_tangent=(None if equations.residual_tangent is None
                          else bake_matrix(equations.residual_tangent)),
        partials_solve=(None if equations.partials_solve is None
                        else tuple(map(bake_matrix, equations.partials_solve))),
        pairs=(None if equations.pairs is None else replace(
            equations.pairs, ancestor=bake_matrix(equations.pairs.ancestor),
            descendant=bake_matrix(equations.pairs.descendant))),
        contacts=(None if equations.contacts is None else replace(
            equations.contacts, jacobian=bake_matrix(equations.contacts.jacobian),
            drift=bake_matrix(equations.contacts.drift))),
    )
