r"""The reference: a ``sympy.lambdify`` of the *unoptimised* equations.

No optimising CSE, no printer of ours: expressions go straight from the
derivation into NumPy code through sympy's own printer, and ``M u' = F`` is
solved with :func:`numpy.linalg.cholesky` and :func:`numpy.linalg.solve`, each
speed first measured in its own mass's units (a diagonal scaling, so a mass of
1e-20 loses no digits; :attr:`LambdifiedModel.resolution` says how many digits the
last evaluation's solves can vouch for).
Singular is singular here as in the generated code (:mod:`mbgen.codegen.solver`):
the mass matrix (of a constrained model: ``Z^T M Z`` on the null space ``Z`` of the
constraints) is singular when a squared Cholesky pivot ``d_j`` is not above
``PIVOT_ULPS n eps`` times the magnitude of the summands of its diagonal entry
(``M_jj``; ``(|Z|^T |M| |Z|)_jj``), and the constraint block ``A_r`` when a pivot of its
LU with partial pivoting is not above ``CONSTRAINT_PIVOT max|A_r|``.  This
is what the compiled C and the generated Python are checked against.  Nodes the
derived graph shares are named once (:func:`mbgen.symbolic.graph.split_shared`), so
the printed code is as large as the graph, not as its expanded tree.

Jacobians are derivatives of ``G`` and of ``R = F - M a`` (the accelerations
``a`` held fixed), lambdified, with
:math:`\partial u'/\partial v = M^{-1} \partial R/\partial v` solved numerically.
Every expression is lambdified on first use.

Each output is one row of :data:`REFERENCES`: the method that computes it,
with or without constraints (what the output is, its shape and what it needs: its
row of :data:`mbgen.abi.OUTPUT_INFO`).  Only the outputs the equations can give are
offered (:func:`mbgen.symbolic.availability.applicable`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import sympy as sm

from ..abi import Output
from ..errors import ModelError
from ..symbolic.availability import SENSITIVITIES, applicable
from ..symbolic.equations import Equations, acceleration_symbols, lambda_symbols
from ..symbolic.graph import differentiate, free_symbols, split_shared
from ..symbolic.layout import Layout
from ..symbolic.program import Program
from .base import ModelBase


class _At(NamedTuple):
    """The arguments of one evaluation, checked: ``(t, x, p, r)``."""

    t: float
    x: np.ndarray
    p: np.ndarray
    r: np.ndarray


class _Solved(NamedTuple):
    """A constrained model solved at one state: ``A`` of ``A u + b = 0``, the dependent
    speeds ``ur``, the mass matrix ``M`` (every speed), ``G``, the accelerations ``acc``
    (every speed) and the multipliers ``lam``."""

    A: np.ndarray
    ur: np.ndarray
    M: np.ndarray
    G: np.ndarray
    acc: np.ndarray
    lam: np.ndarray


class LambdifiedModel(ModelBase):
    """``Equations`` evaluated through ``sympy.lambdify`` (NumPy backend).

    Parameters
    ----------
    equations : Equations
    outputs : iterable of Output
        Outputs to offer (those the equations cannot give are dropped).
    layout : Layout, optional
        Argument order (default: the equations' layout).  Pass a generated
        model's ABI layout to call both with the same arrays.
    """

    backend = "lambdify"

    def __init__(self, equations: Equations, outputs=tuple(Output), layout: Layout | None = None):
        L = layout or equations.layout
        offered = set(applicable(equations))
        outputs = tuple(o for o in Output.parse(outputs) if o in offered)
        super().__init__(equations.name, L, equations.defaults, outputs)
        self.equations = _inlined(equations)
        if equations.constraints is not None:
            self.constraint_names = equations.constraints.names
            self.dependent_coordinates = tuple(
                map(str, equations.constraints.dependent_coordinates))
        if equations.reactions is not None:
            self.reaction_names = equations.reactions.names
            self.reaction_frames = equations.reactions.frames
        self._n_u = L.n_u
        self._args = (L.time, list(L.states), list(L.parameters), list(L.inputs))
        if equations.constraints is not None:
            self._args += (list(equations.layout.dependent_speeds),)
        self._known = L.symbols()
        self._cache: dict = {}
        self._solved: list[np.ndarray] = []   # the matrices the last evaluation solved

    def _lambdify(self, key, make_expr, extra_args=()):
        hit = self._cache.get(key)
        if hit is None:
            expr = make_expr()
            symbols = free_symbols(list(sm.Matrix(expr)))
            unknown = symbols - self._known - set(sm.flatten(extra_args))
            if unknown:
                raise ModelError(f"{self.name}: {key} needs {sorted(map(str, unknown))}, "
                                 f"which the layout does not provide")
            # Split before lambdify sees the expression: it walks its argument as a tree.
            reps, reduced = split_shared(sm.ImmutableMatrix(expr))
            hit = sm.lambdify(self._args + tuple(extra_args), reduced, modules="numpy",
                              cse=lambda e: (reps, e))
            self._cache[key] = hit
        return hit

    def _value(self, at: _At, key, make_expr, ur=None, extra_args=(), extra=()) -> np.ndarray:
        """``make_expr()`` at ``at`` (lambdified on first use under ``key``); ``extra`` are the
        values of the symbols ``extra_args``.  A constrained model's expressions also take
        the dependent speeds ``ur`` (zero where not given)."""
        f = self._lambdify(key, make_expr, extra_args)
        c = self.equations.constraints
        if c is not None:
            at = at + (np.zeros(c.m) if ur is None else ur,)
        return np.array(f(*at, *extra), dtype=float)

    def _evaluate(self, output, t, x, p, r):
        self._require(output)
        at = _At(self._t(t), self._x(x), self._p(p), self._r(r))
        self._solved = []
        out = REFERENCES[output](self, output, at)
        if not np.all(np.isfinite(out)):
            self._fail(2, output.value, at.t, at.x)
        return out

    @property
    def resolution(self) -> float:
        """The relative error the last evaluation may carry from its linear solves: ``n kappa u``
        for the worst of them (``kappa`` its 2-norm condition number, ``n`` its size, ``u``
        the unit roundoff; the bound of a backward-stable dense solve, Higham's
        ``gamma_n kappa``), 0.0 when it solved nothing.  Computed when asked, so a caller
        that never asks pays nothing; :func:`mbgen.verify.check.compare` asks only where a
        sample disagrees."""
        return max((len(K) * float(np.linalg.cond(K)) * np.finfo(float).eps
                    for K in self._solved), default=0.0)

    @property
    def condition(self) -> float:
        """The largest 2-norm condition number of the last evaluation's linear solves (0.0 when
        it solved nothing)."""
        return max((float(np.linalg.cond(K)) for K in self._solved), default=0.0)

    def _solve(self, K, b) -> np.ndarray:
        """``K^-1 b`` (numpy's LU), ``K`` kept for :attr:`resolution`."""
        self._solved.append(K)
        return np.linalg.solve(K, b)

    def _solve_mass(self, M, F) -> np.ndarray:
        """``M^-1 F`` solved as ``(D M D) y = D F``, ``a = D y`` with ``D = diag(M)^-1/2``
        (:func:`_mass_scaling`): each speed in its own mass's units, so the solve does not
        depend on them."""
        d = _mass_scaling(M)
        wide = (slice(None),) + (None,) * (np.ndim(F) - 1)
        return d[wide] * self._solve(d[:, None] * M * d, d[wide] * F)

    def _solve_saddle(self, M, A, f, g):
        """``(a, lambda)`` of ``M a - A^T lambda = f``, ``A a = g``, nondimensionalised by
        :func:`_saddle_scaling`; ``f`` ``(n,)`` or ``(n, k)``, ``g`` ``(m,)`` or ``(m, k)``."""
        d, e = _saddle_scaling(M, A)
        As = e[:, None] * A * d
        K = np.block([[d[:, None] * M * d, -As.T], [As, np.zeros((len(e), len(e)))]])
        wide = (slice(None),) + (None,) * (np.ndim(f) - 1)
        y = self._solve(K, np.concatenate([d[wide] * f, e[wide] * g]))
        return d[wide] * y[:len(d)], e[wide] * y[len(d):]

    # ------------------------------------------------------------ shared steps
    def _mf(self, output, at: _At):
        """``M`` and ``F`` of an unconstrained model (SingularMassMatrixError for a singular
        ``M``)."""
        eq, n = self.equations, self._n_u
        M = self._value(at, "M", lambda: eq.mass_matrix).reshape(n, n)
        F = self._value(at, "F", lambda: eq.forcing)
        if not _positive_definite(M, np.abs(M)):
            self._fail(1, output.value, at.t, at.x)
        return M, F.reshape(-1)

    def _dependent_speeds(self, output, at: _At):
        """``A`` and ``u_r`` from ``A_r u_r = -(A_s u_s + b)`` (None, None without constraints)."""
        eq, L = self.equations, self.layout
        c = eq.constraints
        if c is None:
            return None, None
        A = self._value(at, "CA", lambda: c.velocity_matrix).reshape(c.m, L.n_u + L.n_d)
        b = self._value(at, "CB", lambda: c.velocity_bias).reshape(-1)
        Ar, As = A[:, L.n_u:], A[:, :L.n_u]
        if not _smallest_lu_pivot(Ar) > CONSTRAINT_PIVOT * np.max(np.abs(Ar)):
            self._fail(7, output.value, at.t, at.x)
        return A, self._solve(Ar, -(As @ at.x[L.n_q:] + b))

    def _solve_constrained(self, output, at: _At) -> _Solved:
        """Accelerations and multipliers from the whole saddle-point system
        ``[M -A^T; A 0] [a; lambda] = [F; -beta]`` with numpy's dense solve, nondimensionalised
        first (:func:`_saddle_scaling`; the generated code reduces the system instead)."""
        eq, L = self.equations, self.layout
        c = eq.constraints
        n = L.n_u + L.n_d
        A, ur = self._dependent_speeds(output, at)
        M = self._value(at, "M", lambda: eq.mass_matrix).reshape(n, n)
        F = self._value(at, "F", lambda: eq.forcing, ur).reshape(-1)
        beta = self._value(at, "beta", lambda: c.acceleration_bias, ur).reshape(-1)
        G = self._value(at, "G", lambda: eq.kinematics, ur).reshape(-1)
        d, e = _saddle_scaling(M, A)   # nondimensionalised: Z^T M Z loses no digits to units
        Ms, Z = d[:, None] * M * d, _null_space(e[:, None] * A * d)
        if not _positive_definite(Z.T @ Ms @ Z, np.abs(Z).T @ np.abs(Ms) @ np.abs(Z)):
            self._fail(1, output.value, at.t, at.x)
        acc, lam = self._solve_saddle(M, A, F, -beta)
        return _Solved(A, ur, M, G, acc, lam)

    def _solve_contacts(self, output, at: _At):
        """``(M, J, acc, lam)`` of a model with contacts: the saddle-point system
        ``[M -J^T; J 0] [a; lambda] = [F; -c]`` by numpy's dense solve, nondimensionalised
        (:meth:`_solve_saddle`), after the generated code's two checks: ``M`` positive
        definite, and the Delassus matrix ``J M^-1 J^T`` (status 9) by its rule."""
        eq, n = self.equations, self._n_u
        k = eq.contacts
        M, F = self._mf(output, at)
        J = self._value(at, "CJ", lambda: k.jacobian).reshape(k.m, n)
        c = self._value(at, "CB", lambda: k.drift).reshape(-1)
        G = J @ self._solve_mass(M, J.T)
        if not _delassus_regular(G, n):
            self._fail(9, output.value, at.t, at.x)
        acc, lam = self._solve_saddle(M, J, F, -c)
        return M, J, acc, lam

    def _contact_sensitivity(self, output, at: _At, variables, forces: bool = False):
        """``df/dv`` (``forces``: and ``dlambda/dv`` below it) of a model with contacts: implicit
        differentiation, with numpy, of ``R = F - M a + J^T lambda`` and ``C = J a + c``."""
        eq, L = self.equations, self.layout
        k = eq.contacts
        n, m, nq, nv = L.n_u, k.m, L.n_q, len(variables)
        M, J, acc, lam = self._solve_contacts(output, at)
        accs, lams = list(sm.symbols(f"ra0:{n}")), list(sm.symbols(f"rl0:{m}"))
        R = (sm.Matrix(eq.forcing) - sm.Matrix(eq.mass_matrix) * sm.Matrix(accs)
             + sm.Matrix(k.jacobian).T * sm.Matrix(lams))
        C = sm.Matrix(k.jacobian) * sm.Matrix(accs) + sm.Matrix(k.drift)
        D = self._value(at, ("contact", output), lambda: sm.Matrix(differentiate(
            list(eq.kinematics) + list(R) + list(C), list(variables))), None, (accs, lams),
                        (acc, lam)).reshape(-1, nv)
        dG, dR, dC = D[:nq], D[nq:nq + n], D[nq + n:]
        da, dl = self._solve_saddle(M, J, dR, -dC)
        return np.vstack([dG, da] + ([dl] if forces else []))

    # ------------------------------------------------------------ the outputs
    def _rhs(self, output, at: _At):
        if self.equations.contacts is not None:
            G = self._value(at, "G", lambda: self.equations.kinematics).reshape(-1)
            return np.concatenate([G, self._solve_contacts(output, at)[2]])
        if self.equations.constraints is not None:
            s = self._solve_constrained(output, at)
            return np.concatenate([s.G, s.acc[:self.layout.n_u]])
        M, F = self._mf(output, at)
        G = self._value(at, "G", lambda: self.equations.kinematics).reshape(-1)
        return np.concatenate([G, self._solve_mass(M, F)])

    def _mass_matrix(self, output, at: _At):
        n = self.layout.n_u + self.layout.n_d
        return self._value(at, "M", lambda: self.equations.mass_matrix).reshape(n, n)

    def _forcing(self, output, at: _At):
        _, ur = self._dependent_speeds(output, at)
        return self._value(at, "F", lambda: self.equations.forcing, ur).reshape(-1)

    def _energy(self, output, at: _At):
        eq = self.equations
        _, ur = self._dependent_speeds(output, at)
        pot = eq.potential_energy if eq.potential_energy is not None else sm.S.Zero
        return self._value(at, "E", lambda: sm.Matrix([eq.kinetic_energy, pot]), ur).reshape(-1)

    def _positions(self, output, at: _At):
        points = self.equations.points
        return self._value(at, "positions", lambda: sm.Matrix.hstack(
            *(pk.position for pk in points)).T).reshape(len(points), 3)

    def _velocities(self, output, at: _At):
        points = self.equations.points
        _, ur = self._dependent_speeds(output, at)
        return self._value(at, "velocities", lambda: sm.Matrix.hstack(
            *(pk.velocity for pk in points)).T, ur).reshape(len(points), 3)

    def _reactions(self, output, at: _At):
        eq = self.equations
        if eq.contacts is not None:
            raise ModelError(f"{self.name}: the reference adds no contact forces to the joint "
                             f"reactions (nor does the generated code); leave Output.REACTIONS "
                             f"out")
        if eq.constraints is not None:
            s = self._solve_constrained(output, at)
            symbols = (list(acceleration_symbols(len(s.acc))), list(lambda_symbols(len(s.lam))))
            return self._value(at, "reactions", lambda: eq.reactions.matrix, s.ur, symbols,
                               (s.acc, s.lam)).reshape(-1, 6)
        M, F = self._mf(output, at)
        acc = list(acceleration_symbols(self._n_u))
        return self._value(at, "reactions", lambda: eq.reactions.matrix, None, (acc,),
                           (self._solve_mass(M, F),)).reshape(-1, 6)

    def _constraint_forces(self, output, at: _At):
        if self.equations.contacts is not None:
            return self._solve_contacts(output, at)[3]
        return self._solve_constrained(output, at).lam

    def _contact_jacobian(self, output, at: _At):
        return self._contact_sensitivity(output, at, self.layout.states, forces=True)

    def _holonomic(self, output, at: _At):
        return self._value(at, "fh", lambda: self.equations.constraints.holonomic).reshape(-1)

    def _holonomic_jacobian(self, output, at: _At):
        c = self.equations.constraints
        return self._value(at, "dfh", lambda: c.holonomic_jacobian).reshape(c.m_h, self.layout.n_q)

    def _sensitivity(self, output, at: _At):
        """``df/dv`` for the output's variables ``v`` (as generated: for the parameter
        Jacobian, the parameters of ``M``, ``F`` and ``G``)."""
        eq, L = self.equations, self.layout
        sensitivity = SENSITIVITIES[output]
        variables = tuple(sensitivity.variables(eq, L))
        if eq.constraints is not None:
            out = self._implicit_sensitivity(output, at, variables)
        elif eq.contacts is not None:
            out = self._contact_sensitivity(output, at, variables)
        else:
            acc = list(sm.symbols(f"acc0:{L.n_u}"))
            dG = self._lambdify(("dG", output), lambda: sm.Matrix(
                differentiate(list(eq.kinematics), variables)), (acc,))
            dR = self._lambdify(("dR", output), lambda: sm.Matrix(differentiate(list(
                sm.Matrix(eq.forcing) - sm.Matrix(eq.mass_matrix) * sm.Matrix(acc)), variables)),
                                (acc,))
            M, F = self._mf(output, at)
            a = self._solve_mass(M, F)
            G_v = np.array(dG(*at, a), dtype=float).reshape(-1, len(variables))
            R_v = np.array(dR(*at, a), dtype=float).reshape(self._n_u, len(variables))
            out = np.vstack([G_v, self._solve_mass(M, R_v)])
        return out.reshape(-1) if sensitivity.vector else out

    def _tangent_jacobian(self, output, at: _At):
        """``[du'/dq G, du'/du]`` from the reference's own ``df/dx`` (``G = dq'/du``)."""
        J, nq = self._sensitivity(Output.JACOBIAN, at), self.layout.n_q
        return np.hstack([J[nq:, :nq] @ J[:nq, nq:], J[nq:, nq:]])

    def _implicit_sensitivity(self, output, at: _At, variables):
        """Sensitivities of a constrained model: implicit differentiation, with numpy, of
        ``C = A u + b``, ``E = M a - F - A^T lambda`` and ``B = A a + beta``."""
        eq, L = self.equations, self.layout
        c = eq.constraints
        n, m, ns, nq, nv = L.n_u + L.n_d, c.m, L.n_u, L.n_q, len(variables)
        s = self._solve_constrained(output, at)
        accs, lams = list(sm.symbols(f"ra0:{n}")), list(sm.symbols(f"rl0:{m}"))
        u = list(L.all_speeds)
        Ms, As_ = sm.Matrix(eq.mass_matrix), sm.Matrix(c.velocity_matrix)
        Cx = As_ * sm.Matrix(u) + sm.Matrix(c.velocity_bias)
        Ex = Ms * sm.Matrix(accs) - sm.Matrix(eq.forcing) - As_.T * sm.Matrix(lams)
        Bx = As_ * sm.Matrix(accs) + sm.Matrix(c.acceleration_bias)
        everything = list(variables) + list(L.dependent_speeds)
        D = self._value(at, ("implicit", output), lambda: sm.Matrix(differentiate(
            list(Cx) + list(eq.kinematics) + list(Ex) + list(Bx), everything)),
                        s.ur, (accs, lams), (s.acc, s.lam)).reshape(-1, nv + m)
        dC, dG, dE, dB = D[:m], D[m:m + nq], D[m + nq:m + nq + n], D[m + nq + n:]
        dur = -self._solve(s.A[:, ns:], dC[:, :nv])
        da, _ = self._solve_saddle(s.M, s.A, -(dE[:, :nv] + dE[:, nv:] @ dur),
                                   -(dB[:, :nv] + dB[:, nv:] @ dur))
        return np.vstack([dG[:, :nv] + dG[:, nv:] @ dur, da[:ns]])


#: How the reference computes every expression output: a method of :class:`LambdifiedModel`
#: ``(model, output, at) -> array`` (it branches on constraints where the two differ).
REFERENCES: dict[Output, Callable] = {
    Output.RHS: LambdifiedModel._rhs,
    Output.MASS_MATRIX: LambdifiedModel._mass_matrix,
    Output.FORCING: LambdifiedModel._forcing,
    Output.ENERGY: LambdifiedModel._energy,
    Output.JACOBIAN: LambdifiedModel._sensitivity,
    Output.PARAMETER_JACOBIAN: LambdifiedModel._sensitivity,
    Output.TIME_DERIVATIVE: LambdifiedModel._sensitivity,
    Output.POSITIONS: LambdifiedModel._positions,
    Output.VELOCITIES: LambdifiedModel._velocities,
    Output.REACTIONS: LambdifiedModel._reactions,
    Output.INPUT_JACOBIAN: LambdifiedModel._sensitivity,
    Output.CONSTRAINT_FORCES: LambdifiedModel._constraint_forces,
    Output.HOLONOMIC: LambdifiedModel._holonomic,
    Output.HOLONOMIC_JACOBIAN: LambdifiedModel._holonomic_jacobian,
    Output.CONTACT_JACOBIAN: LambdifiedModel._contact_jacobian,
    Output.TANGENT_JACOBIAN: LambdifiedModel._tangent_jacobian,
}


def _mass_scaling(M) -> np.ndarray:
    """``d = 1 / sqrt(|diag M|)``: ``D M D`` has a unit diagonal, each speed measured in its own
    mass's units (a speed without mass takes the largest mass's scale)."""
    diag = np.abs(np.diag(M))
    top = diag.max(initial=0.0)
    return 1.0 / np.sqrt(np.where(diag > 0, diag, top if top > 0 else 1.0))


def _saddle_scaling(M, A):
    """Diagonal scalings ``(d, e)`` that nondimensionalise ``[M -A^T; A 0]``.

    ``d`` is :func:`_mass_scaling`'s and ``e`` gives every row of ``A D`` a largest entry
    of 1: the scaled system ``[D M D, -(E A D)^T; E A D, 0]`` has blocks of order one
    whatever the units.  Solved unscaled, partial pivoting at ``m = 1e-20`` picked the O(1)
    constraint rows and rounded the 1e-20 mass block away (relative error 1.45 against a
    scale-invariant generated code).  The scalings change no answer (``a = D y``,
    ``lambda = E z``), so the reference stays the dense solve of the whole system.
    """
    d = _mass_scaling(M)
    rows = np.abs(A * d).max(axis=1, initial=0.0)
    return d, 1.0 / np.where(rows > 0, rows, 1.0)


#: A mass matrix's pivot ``d_j <= PIVOT_ULPS n eps M_jj`` is singular (the generated code's
#: rule: :data:`mbgen.codegen.solver.PIVOT_ULPS`).
PIVOT_ULPS = 16
#: A pivot of the LU of the constraint block ``A_r`` not above this times ``max|A_r|`` is
#: singular (``CONSTRAINT_SINGULAR``; as ``templates/model/constraints.c.j2``).
CONSTRAINT_PIVOT = 1e-13


def _null_space(A) -> np.ndarray:
    """An orthonormal basis ``Z`` of the null space of ``A`` (columns): ``Z^T M Z`` is positive
    definite when the constrained system has a well-defined motion."""
    _, sv, vt = np.linalg.svd(A)
    rank = int(np.sum(sv > 1e-12 * max(1.0, sv.max() if sv.size else 1.0)))
    return vt[rank:].T


def _positive_definite(M, magnitude) -> bool:
    """Whether the symmetric ``M`` (n x n) is positive definite beyond rounding: every squared
    Cholesky pivot ``d_j`` above ``PIVOT_ULPS n eps magnitude_jj``, the magnitude of the
    summands of ``M_jj`` (``|M|`` itself, or ``|Z|^T |M| |Z|`` for ``Z^T M Z``).  The rule
    of the generated ``L D L^T`` (:mod:`mbgen.codegen.solver`), whose pivots are these."""
    n = M.shape[0]
    try:
        pivots = np.diag(np.linalg.cholesky(M)) ** 2
    except np.linalg.LinAlgError:
        return False
    return bool(np.all(pivots > PIVOT_ULPS * n * np.finfo(float).eps * np.diag(magnitude)))


def _delassus_regular(G, n_u: int) -> bool:
    """Whether the contacts' Delassus matrix ``G`` (``m x m``) is regular by the generated
    code's rule (``templates/runtime/contact.c.j2``): every squared Cholesky pivot above
    ``PIVOT_ULPS (n_u + m) eps G_jj``."""
    m = G.shape[0]
    try:
        pivots = np.diag(np.linalg.cholesky((G + G.T) / 2)) ** 2
    except np.linalg.LinAlgError:
        return False
    return bool(np.all(pivots > PIVOT_ULPS * (n_u + m) * np.finfo(float).eps * np.diag(G)))


def _smallest_lu_pivot(A) -> float:
    """``min_k |u_kk|`` of the LU factorisation of the square ``A`` with partial pivoting."""
    U = np.array(A, dtype=float)
    smallest = np.inf
    for k in range(U.shape[0]):
        p = k + int(np.argmax(np.abs(U[k:, k])))
        U[[k, p]] = U[[p, k]]
        if not abs(U[k, k]) > 0.0:    # zero or NaN: singular
            return 0.0
        smallest = min(smallest, abs(U[k, k]))
        U[k + 1:] -= np.outer(U[k + 1:, k] / U[k, k], U[k])
    return smallest


def _inlined(eq: Equations) -> Equations:
    """``eq`` with its program's symbols replaced by their definitions (left nested, unflattened).

    The reference evaluates the unoptimised expressions themselves; a
    recursion's accelerations are not used (``u'`` always comes from solving
    ``M u' = F``), so compiled code that uses the recursion is checked against
    a different algorithm.
    """
    P = eq.program
    if not P:
        return eq
    matrices = [eq.mass_matrix, eq.forcing, eq.kinematics]
    if eq.contacts is not None:
        matrices += [eq.contacts.jacobian, eq.contacts.drift]
    matrices += [m for pk in eq.points for m in (pk.position, pk.velocity)]
    if eq.reactions is not None:
        matrices.append(eq.reactions.matrix)
    scalars = [e if e is not None else sm.S.Zero for e in (eq.kinetic_energy,
                                                           eq.potential_energy)]
    flat = P.inline([e for m in matrices for e in m] + scalars, evaluate=False)
    it = iter(flat)
    out = [sm.ImmutableMatrix(m.rows, m.cols, [next(it) for _ in range(len(m))])
           for m in matrices]
    T, V = next(it), next(it)
    M, F, G, *rest = out
    contacts = eq.contacts
    if contacts is not None:
        contacts = replace(contacts, jacobian=rest[0], drift=rest[1])
        rest = rest[2:]
    points = tuple(replace(pk, position=rest[2 * i], velocity=rest[2 * i + 1])
                   for i, pk in enumerate(eq.points))
    reactions = (replace(eq.reactions, matrix=rest[-1]) if eq.reactions is not None else None)
    return replace(eq, mass_matrix=M, forcing=F, kinematics=G,
                   kinetic_energy=None if eq.kinetic_energy is None else T,
                   potential_energy=None if eq.potential_energy is None else V,
                   points=points, program=Program(), accelerations=None, reactions=reactions,
                   residual=None, residual_jacobian=None, residual_tangent=None,
                   partials_solve=None, pairs=None, contacts=contacts)
