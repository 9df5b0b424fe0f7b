r"""The constraints of a sympy ``KanesMethod`` or ``LagrangesMethod`` in mbgen's form.

:func:`mbgen.from_sympy` converts functions of time to plain symbols first; this
module then builds :class:`~mbgen.symbolic.equations.Constraints` from what the sympy
method states, in plain symbols, with ``u = [u_s; u_r]`` (independent, then
dependent speeds):

* configuration: ``f_h(q, t) = 0`` (``m_h`` rows) with one dependent
  coordinate each, and ``df_h/dq``;
* velocity: ``A u + b = 0`` (``m`` rows, ``A = d rows/du``, ``b = rows(u = 0)``),
  the rows of the configuration constraints first;
* acceleration: ``A u' + beta = 0`` with
  :math:`\beta = \sum_j \partial(Au+b)/\partial q_j\,G_j + \partial(Au+b)/\partial t`
  (``q' = G``, ``u`` held fixed), derived here from the velocity rows, never
  taken from the sympy method.

``M`` and ``F`` stay those of the unconstrained system over every speed; the
generated code reduces them (``M u' = F + A^T lambda``).

KanesMethod
    Velocity rows: its ``velocity_constraints`` as given (``k_nh u + f_nh``, the
    kinematic equations substituted by sympy), so the multiplier of a row is the
    generalized force conjugate to that row: for rows stating that a body's
    contact point has zero velocity, the contact force (what sympy's auxiliary
    equations give).  Each configuration constraint must have its time
    derivative among the velocity constraints, up to a factor (as
    ``System.form_eoms`` writes them); that row moves to the front and is named
    ``configuration_<i>``, the others ``velocity_<k>`` (``i``, ``k``: positions
    in the lists given to sympy).  Dependent coordinates and speeds are the
    method's own.
LagrangesMethod
    Velocity rows: ``coneqs`` (the time derivatives of ``hol_coneqs``, then
    ``nonhol_coneqs``), so ``A = -lam_coeffs``, and the multipliers are sympy's
    ``lam1, lam2, ...`` with the values of its ``solve_multipliers()`` and
    ``rhs()`` (``mass_matrix_full`` reads ``M q'' + lam_coeffs^T lam = forcing``;
    the sign of the ``eom`` expression's ``lam`` terms is the opposite).  The
    speeds are ``q'``; the dependent ones are named (``dependent=``) or chosen
    here from the constraint Jacobian (see :func:`choose_dependent`).

Numerical rank tests evaluate the matrices at seeded random states (states in
``[-1.3, 1.3]``, every other symbol in ``[0.3, 1.7]``) by a DAG substitution:
generic rank is what decides, and a singular configuration met at run time is
the C status ``CONSTRAINT_SINGULAR``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import sympy as sm

from ..errors import ModelError
from ..symbolic.equations import Constraints
from ..symbolic.graph import differentiate, free_symbols, xreplace_dag

_TRIES = 3  # random states per rank test


class Stated(NamedTuple):
    """Constraints as the sympy method states them (functions of time, or plain symbols).

    ``velocity`` rows are linear in the speeds.  ``kind`` is ``"kane"`` (the last
    ``n_dependent`` speeds are dependent, ``dependent_coordinates`` given) or
    ``"lagrange"`` (``names`` given, dependents named in ``requested`` or
    chosen).
    """

    kind: str
    holonomic: list
    velocity: list
    names: list
    dependent_coordinates: list
    n_dependent: int = 0
    requested: list | None = None

    def expressions(self) -> list:
        return list(self.holonomic) + list(self.velocity)


class Reduced(NamedTuple):
    """What the constrained importer returns: the speed order and the constraints."""

    order: list            # positions of the speeds, independent then dependent
    n_dependent: int
    constraints: Constraints


# --------------------------------------------------------------------------- numbers
class _Sampler:
    """Seeded random values for every symbol of some expressions, one state at a time."""

    def __init__(self, states: Sequence[sm.Symbol]):
        self.states = set(states)
        self.rng = np.random.default_rng(20240610)

    def state(self, symbols) -> dict:
        return {s: sm.Float(self.rng.uniform(-1.3, 1.3) if s in self.states
                            else self.rng.uniform(0.3, 1.7)) for s in sorted(symbols, key=str)}


def _numeric(rows: list[list], values: dict) -> np.ndarray | None:
    """``rows`` (a list of lists of expressions) at ``values``; None where not finite and real."""
    flat = [e for r in rows for e in r]
    if not flat:
        return np.zeros((len(rows), 0))
    out = []
    for e in xreplace_dag(flat, values):
        try:
            z = complex(e)
        except TypeError:
            return None
        if not np.isfinite(z) or abs(z.imag) > 1e-12 * max(1.0, abs(z.real)):
            return None
        out.append(z.real)
    return np.array(out).reshape(len(rows), -1)


def _samples(rows: list[list], sampler: _Sampler):
    """``rows`` evaluated at up to ``_TRIES`` random states (those where they are finite)."""
    symbols = free_symbols([e for r in rows for e in r])
    for _ in range(_TRIES):
        value = _numeric(rows, sampler.state(symbols))
        if value is not None:
            yield value


def _rank(a: np.ndarray) -> int:
    return int(np.linalg.matrix_rank(a)) if a.size else 0


# --------------------------------------------------------------------------- forms
def _jacobian(exprs: list, variables: Sequence[sm.Symbol]) -> list[list]:
    """``[[d e/d v for v in variables] for e in exprs]`` (symengine, one memo: linear in the
    graph)."""
    return differentiate(list(exprs), list(variables)) if exprs else []


def _affine(rows: list, speeds: Sequence[sm.Symbol], what: list[str]) -> tuple[list, list]:
    """``(A, b)`` with ``rows = A u + b``; refuses rows that are not linear in ``speeds``."""
    A = _jacobian(rows, speeds)
    moving = set(speeds)
    bad = [w for w, a in zip(what, A) if free_symbols(a) & moving]
    if bad:
        raise ModelError(f"the constraint(s) {bad} are not linear in the speeds; velocity "
                         f"constraints must read A(q, t) u + b(q, t) = 0")
    b = xreplace_dag(rows, {u: sm.S.Zero for u in speeds})
    return A, b


def _time_derivative(exprs: list, coordinates, kinematics, time) -> list:
    """``sum_j d e/dq_j G_j + d e/dt`` for each expression (``q' = G``, speeds held fixed)."""
    J = _jacobian(exprs, [*coordinates, time])
    return [sm.Add(*(d * g for d, g in zip(row, kinematics) if d != 0), row[-1]) for row in J]


def _build(names, holonomic, dependent_coordinates, A, b, speeds, coordinates, kinematics,
           time) -> Constraints:
    """``Constraints`` from velocity rows ``A u + b`` over ``speeds`` (already in final order)."""
    m, mh = len(A), len(holonomic)
    velocity = [sm.Add(*(a * u for a, u in zip(row, speeds))) + bi for row, bi in zip(A, b)]
    beta = _time_derivative(velocity, coordinates, kinematics, time)
    return Constraints(
        names=tuple(names),
        holonomic=sm.ImmutableMatrix(mh, 1, list(holonomic)),
        dependent_coordinates=tuple(dependent_coordinates),
        holonomic_jacobian=sm.ImmutableMatrix(mh, len(coordinates),
                                              [e for r in _jacobian(holonomic, coordinates)
                                               for e in r]),
        velocity_matrix=sm.ImmutableMatrix(m, len(speeds), [e for r in A for e in r]),
        velocity_bias=sm.ImmutableMatrix(m, 1, b),
        acceleration_bias=sm.ImmutableMatrix(m, 1, beta))


def _check_counts(m: int, mh: int, n_speeds: int, n_coordinates: int, where: str) -> None:
    if m >= n_speeds:
        raise ModelError(f"{m} velocity constraints for {n_speeds} speeds in {where}: at least "
                         f"one speed must stay independent; drop redundant constraints")
    if mh >= n_coordinates:
        raise ModelError(f"{mh} configuration constraints for {n_coordinates} coordinates in "
                         f"{where}: at least one coordinate must stay independent")


def _nonsingular(block: list[list], sampler: _Sampler) -> bool:
    """Whether the square ``block`` has full rank at one of the random states."""
    return any(_rank(v) == len(block) for v in _samples(block, sampler))


# --------------------------------------------------------------------------- KanesMethod
def kane(stated: Stated, coordinates, speeds, kinematics, time) -> Reduced:
    """Constraints of a KanesMethod whose last ``stated.n_dependent`` speeds are dependent.

    The velocity rows keep sympy's form; the row that is the time derivative of
    configuration constraint ``i`` (up to a factor) comes first, in the order of
    the configuration constraints.
    """
    m, mh, n = len(stated.velocity), len(stated.holonomic), len(speeds)
    _check_counts(m, mh, n, len(coordinates), "the KanesMethod")
    if m != stated.n_dependent:
        raise ModelError(f"{m} velocity constraints for {stated.n_dependent} dependent speeds")
    sampler = _Sampler([*coordinates, *speeds])
    where = [f"velocity_constraints[{k}]" for k in range(m)]
    A, b = _affine(list(stated.velocity), speeds, where)
    for q in stated.dependent_coordinates:
        if q not in free_symbols(stated.holonomic):
            raise ModelError(f"the dependent coordinate {q} appears in no configuration "
                             f"constraint of the KanesMethod; make q_dependent coordinates that "
                             f"the configuration_constraints determine")

    # pair each configuration constraint with the velocity row that is its time derivative
    hdot = _time_derivative(list(stated.holonomic), coordinates, kinematics, time)
    Ah, bh = _affine(hdot, speeds, [f"d/dt configuration_constraints[{i}]" for i in range(mh)])
    rows = [ra + [rb] for ra, rb in zip(A + Ah, b + bh)]
    values = list(_samples(rows, sampler))
    if not values:
        raise ModelError("the velocity constraints of the KanesMethod are not finite at any "
                         "random state tried; check them for divisions by zero")
    paired: list[int] = []
    for i in range(mh):
        match = [k for k in range(m) if k not in paired and all(
            np.linalg.norm(v[m + i]) > 0 and _rank(v[[m + i, k]]) == 1 for v in values)]
        if not match:
            raise ModelError(f"no velocity constraint of the KanesMethod is the time derivative "
                             f"of configuration_constraints[{i}] (up to a factor); include "
                             f"d/dt of every configuration constraint in velocity_constraints "
                             f"(System.form_eoms does so)")
        paired.append(match[0])
    order = paired + [k for k in range(m) if k not in paired]
    names = [f"configuration_{i}" for i in range(mh)] + [f"velocity_{k}" for k in order[mh:]]
    A, b = [A[k] for k in order], [b[k] for k in order]

    dependent_block = [row[n - m:] for row in A]
    if not _nonsingular(dependent_block, sampler):
        raise ModelError(f"the velocity constraints of the KanesMethod are redundant or do not "
                         f"determine its dependent speeds {list(speeds[n - m:])} (their "
                         f"coefficient block is singular at random states); drop a redundant "
                         f"constraint or choose other u_dependent")
    if mh:
        if not _nonsingular(_jacobian(stated.holonomic, stated.dependent_coordinates), sampler):
            raise ModelError(f"the configuration constraints of the KanesMethod are redundant "
                             f"or do not determine q_dependent "
                             f"{list(stated.dependent_coordinates)}; choose other dependent "
                             f"coordinates")
    cons = _build(names, stated.holonomic, stated.dependent_coordinates, A, b, speeds,
                  coordinates, kinematics, time)
    return Reduced(list(range(n)), m, cons)


# --------------------------------------------------------------------------- LagrangesMethod
def lagrange(stated: Stated, coordinates, speeds, kinematics, time) -> Reduced:
    """Constraints of a LagrangesMethod (speeds ``q'``, one per coordinate, in its order).

    Dependent speeds are those of ``stated.requested`` (coordinates) or chosen by
    :func:`choose_dependent`; the configuration constraints' dependent
    coordinates are chosen among them.
    """
    m, mh, n = len(stated.velocity), len(stated.holonomic), len(speeds)
    _check_counts(m, mh, n, len(coordinates), "the LagrangesMethod")
    A, b = _affine(list(stated.velocity), speeds, list(stated.names))
    sampler = _Sampler([*coordinates, *speeds])
    H = _jacobian(stated.holonomic, coordinates)
    dep_q, dep_u = choose_dependent(A, H, coordinates, stated.requested, sampler)
    independent = [j for j in range(n) if j not in dep_u]
    order = independent + dep_u
    A = [[row[j] for j in order] for row in A]
    cons = _build(stated.names, stated.holonomic, [coordinates[j] for j in dep_q], A, b,
                  [speeds[j] for j in order], coordinates, kinematics, time)
    return Reduced(order, m, cons)


def choose_dependent(A: list[list], H: list[list], coordinates, requested, sampler: _Sampler
                     ) -> tuple[list[int], list[int]]:
    """Dependent coordinates (``m_h``) and speeds (``m``) of a LagrangesMethod, as positions.

    ``A`` (``m x n``): the velocity rows' coefficients of ``q'``; ``H``
    (``m_h x n``): ``df_h/dq``.  With ``requested`` (coordinate positions, ``m``
    of them) the dependent speeds are theirs, and the dependent coordinates the
    first of them, in the order given, that keep ``H``'s columns independent.
    Without, both are chosen greedily from the last coordinate to the first:
    coordinates that raise the rank of ``H``'s columns, then further speeds that
    raise the rank of ``A``'s.  Either way the blocks must be nonsingular at
    random states, else a :class:`ModelError` names the choice that works.
    """
    m, mh, n = len(A), len(H), len(coordinates)
    values = next(iter(_samples(A + H, sampler)), None)
    if values is None:
        raise ModelError("the constraints of the LagrangesMethod are not finite at any random "
                         "state tried; check them for divisions by zero")
    An, Hn = values[:m], values[m:]

    def greedy(matrix, chosen, candidates, target):
        chosen = list(chosen)
        for j in candidates:
            if len(chosen) == target:
                break
            if j not in chosen and _rank(matrix[:, chosen + [j]]) > _rank(matrix[:, chosen]):
                chosen.append(j)
        return chosen if len(chosen) == target else None

    backwards = list(range(n - 1, -1, -1))
    automatic_q = greedy(Hn, [], backwards, mh)
    automatic = None if automatic_q is None else greedy(An, automatic_q, backwards, m)
    suggestion = ("" if automatic is None else
                  f"; dependent={[str(coordinates[j]) for j in sorted(automatic)]} would")
    if requested is None:
        if automatic is None:
            raise ModelError("the constraints of the LagrangesMethod are redundant (their "
                             "Jacobian has lower rank than their number at random states); "
                             "drop the redundant ones")
        dep_q, dep_u = sorted(automatic_q), sorted(automatic)
    else:
        if len(requested) != m:
            raise ModelError(f"dependent= names {len(requested)} coordinates, but the "
                             f"LagrangesMethod has {m} constraints: name one coordinate per "
                             f"constraint{suggestion}")
        dep_q = greedy(Hn, [], requested, mh)
        if dep_q is None:
            raise ModelError(f"the configuration constraints do not determine any {mh} of "
                             f"dependent={[str(coordinates[j]) for j in requested]} (singular "
                             f"Jacobian){suggestion}")
        dep_q, dep_u = sorted(dep_q), sorted(requested)
    if not _nonsingular([[row[j] for j in dep_u] for row in A], sampler) or (
            mh and not _nonsingular([[row[j] for j in dep_q] for row in H], sampler)):
        raise ModelError(f"the constraints of the LagrangesMethod do not determine the speeds "
                         f"of {[str(coordinates[j]) for j in dep_u]} (singular at random "
                         f"states){suggestion}")
    return dep_q, dep_u
