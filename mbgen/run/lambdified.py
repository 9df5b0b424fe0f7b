r"""The reference: a ``sympy.lambdify`` of the *unoptimised* equations.

No optimising CSE, no printer of ours: expressions go straight from the
derivation into NumPy code through sympy's own printer, and ``M u' = F`` is
solved with :func:`numpy.linalg.cholesky` and :func:`numpy.linalg.solve`.  This
is what the compiled C and the generated Python are checked against.  Nodes the
derived graph shares are named once (:func:`mbgen.symbolic.graph.split_shared`), so
the printed code is as large as the graph, not as its expanded tree.

Jacobians are derivatives of ``G`` and of ``R = F - M a`` (the accelerations
``a`` held fixed), lambdified, with
:math:`\partial u'/\partial v = M^{-1} \partial R/\partial v` solved numerically.
Every expression is lambdified on first use.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import sympy as sm

from ..symbolic.equations import Equations, acceleration_symbols, lambda_symbols
from ..errors import ModelError
from ..symbolic.layout import Layout
from ..abi import Output
from ..symbolic.program import Program
from ..codegen.outputs import differentiate, dynamic_parameters
from .base import ModelBase
from ..symbolic.graph import free_symbols, split_shared

_SENSITIVITY = (Output.JACOBIAN, Output.PARAMETER_JACOBIAN, Output.TIME_DERIVATIVE,
                Output.INPUT_JACOBIAN)


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
        outputs = tuple(o for o in Output.parse(outputs) if not o.is_integrator and (
            o is not Output.ENERGY or equations.kinetic_energy is not None) and (
            o is not Output.PARAMETER_JACOBIAN or L.n_p) and (
            o not in (Output.POSITIONS, Output.VELOCITIES) or equations.points) and (
            o is not Output.REACTIONS or equations.reactions is not None))
        outputs = tuple(o for o in outputs if equations.constraints is not None or o not in (
            Output.CONSTRAINT_FORCES, Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN))
        outputs = tuple(o for o in outputs if o is not Output.INPUT_JACOBIAN or L.n_r)
        super().__init__(equations.name, L, equations.defaults, outputs)
        self.equations = _inlined(equations)
        if equations.constraints is not None:
            self.constraint_names = equations.constraints.names
            self.dependent_coordinates = tuple(map(str, equations.constraints.dependent_coordinates))
        if equations.reactions is not None:
            self.reaction_names = equations.reactions.names
            self.reaction_frames = equations.reactions.frames
        self._n_u = L.n_u
        self._args = (L.time, list(L.states), list(L.parameters), list(L.inputs))
        if equations.constraints is not None:
            self._args += (list(equations.layout.dependent_speeds),)
        self._known = L.symbols()
        self._cache: dict = {}

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

    def _mf(self, t, x, p, r):
        eq, n = self.equations, self._n_u
        M = self._lambdify("M", lambda: eq.mass_matrix)(t, x, p, r)
        F = self._lambdify("F", lambda: eq.forcing)(t, x, p, r)
        return np.array(M, dtype=float).reshape(n, n), np.array(F, dtype=float).reshape(-1)

    def _sensitivity(self, output, t, x, p, r):
        eq, L = self.equations, self.layout
        variables = {Output.JACOBIAN: L.states, Output.PARAMETER_JACOBIAN: L.parameters,
                     Output.TIME_DERIVATIVE: (L.time,), Output.INPUT_JACOBIAN: L.inputs}[output]
        if output is Output.PARAMETER_JACOBIAN:  # as generated: parameters of M, F and G
            variables = tuple(v for v in variables if v in dynamic_parameters(eq))
        acc = list(sm.symbols(f"acc0:{L.n_u}"))
        dG = self._lambdify(("dG", output),
                            lambda: sm.Matrix(differentiate(list(eq.kinematics), variables)),
                            (acc,))
        dR = self._lambdify(("dR", output), lambda: sm.Matrix(differentiate(list(
            sm.Matrix(eq.forcing) - sm.Matrix(eq.mass_matrix) * sm.Matrix(acc)), variables)),
                            (acc,))
        M, F = self._mf(t, x, p, r)
        a = np.linalg.solve(M, F)
        G_v = np.array(dG(t, x, p, r, a), dtype=float).reshape(-1, len(variables))
        R_v = np.array(dR(t, x, p, r, a), dtype=float).reshape(self._n_u, len(variables))
        out = np.vstack([G_v, np.linalg.solve(M, R_v)])
        return out.reshape(-1) if output is Output.TIME_DERIVATIVE else out

    def _evaluate(self, output, t, x, p, r):
        self._require(output)
        t = self._t(t)
        xa, pa, ra = self._x(x), self._p(p), self._r(r)
        eq = self.equations
        if eq.constraints is not None:
            out = self._constrained(output, t, xa, pa, ra)
            if not np.all(np.isfinite(out)):
                self._fail(2, output.value, t, xa)
            return out
        if output is Output.MASS_MATRIX:
            out = self._mf(t, xa, pa, ra)[0]
        elif output is Output.FORCING:
            out = self._mf(t, xa, pa, ra)[1]
        elif output is Output.ENERGY:
            pot = eq.potential_energy if eq.potential_energy is not None else sm.S.Zero
            f = self._lambdify("E", lambda: sm.Matrix([eq.kinetic_energy, pot]))
            out = np.array(f(t, xa, pa, ra), dtype=float).reshape(-1)
        elif output in (Output.POSITIONS, Output.VELOCITIES):
            attr = "position" if output is Output.POSITIONS else "velocity"
            f = self._lambdify(output, lambda: sm.Matrix.hstack(
                *(getattr(pk, attr) for pk in eq.points)).T)
            out = np.array(f(t, xa, pa, ra), dtype=float).reshape(len(eq.points), 3)
        elif output in _SENSITIVITY:
            out = self._sensitivity(output, t, xa, pa, ra)
        elif output is Output.REACTIONS:
            M, F = self._mf(t, xa, pa, ra)
            acc = list(acceleration_symbols(self._n_u))
            f = self._lambdify("reactions", lambda: eq.reactions.matrix, (acc,))
            out = np.array(f(t, xa, pa, ra, np.linalg.solve(M, F)), dtype=float).reshape(-1, 6)
        else:
            M, F = self._mf(t, xa, pa, ra)
            G = np.array(self._lambdify("G", lambda: eq.kinematics)(t, xa, pa, ra),
                         dtype=float).reshape(-1)
            try:
                np.linalg.cholesky(M)
            except np.linalg.LinAlgError:
                self._fail(1, output.value, t, xa)
            out = np.concatenate([G, np.linalg.solve(M, F)])
        if not np.all(np.isfinite(out)):
            self._fail(2, output.value, t, xa)
        return out


def _constrained(self, output, t, x, p, r):
    """Every output of a constrained model, with numpy's dense solves.

    ``u_r`` from ``A_r u_r = -(A_s u_s + b)``; accelerations and multipliers from
    the whole saddle-point system ``[M -A^T; A 0] [a; lambda] = [F; -beta]``
    (the generated code reduces it instead); sensitivities by implicit
    differentiation of the same equations with numpy.
    """
    eq, L = self.equations, self.layout
    c = eq.constraints
    n, m, ns = L.n_u + L.n_d, c.m, L.n_u
    args = (t, x, p, r)
    zero = np.zeros(m)

    def ev(key, make, extra=(), ur=zero, *values):
        f = self._lambdify(key, make, extra)
        return np.array(f(*args, ur, *values), dtype=float)

    if output is Output.HOLONOMIC:
        return ev("fh", lambda: c.holonomic).reshape(-1)
    if output is Output.HOLONOMIC_JACOBIAN:
        return ev("dfh", lambda: c.holonomic_jacobian).reshape(c.m_h, L.n_q)
    if output is Output.MASS_MATRIX:
        return ev("M", lambda: eq.mass_matrix).reshape(n, n)
    if output is Output.POSITIONS:
        return ev("pos", lambda: sm.Matrix.hstack(*(pk.position for pk in eq.points)).T
                  ).reshape(len(eq.points), 3)
    A = ev("CA", lambda: c.velocity_matrix).reshape(m, n)
    b = ev("CB", lambda: c.velocity_bias).reshape(-1)
    Ar, As = A[:, ns:], A[:, :ns]
    if np.linalg.matrix_rank(Ar) < m:
        self._fail(7, output.value, t, x)
    ur = np.linalg.solve(Ar, -(As @ x[L.n_q:] + b))
    if output is Output.VELOCITIES:
        return ev("vel", lambda: sm.Matrix.hstack(*(pk.velocity for pk in eq.points)).T,
                  (), ur).reshape(len(eq.points), 3)
    if output is Output.ENERGY:
        pot = eq.potential_energy if eq.potential_energy is not None else sm.S.Zero
        return ev("E", lambda: sm.Matrix([eq.kinetic_energy, pot]), (), ur).reshape(-1)
    M = ev("M", lambda: eq.mass_matrix).reshape(n, n)
    F = ev("F", lambda: eq.forcing, (), ur).reshape(-1)
    if output is Output.FORCING:
        return F
    beta = ev("beta", lambda: c.acceleration_bias, (), ur).reshape(-1)
    G = ev("G", lambda: eq.kinematics, (), ur).reshape(-1)
    K = np.block([[M, -A.T], [A, np.zeros((m, m))]])
    try:
        np.linalg.cholesky(_null_space_matrix(M, A))
    except np.linalg.LinAlgError:
        self._fail(1, output.value, t, x)
    sol = np.linalg.solve(K, np.concatenate([F, -beta]))
    acc, lam = sol[:n], sol[n:]
    if output is Output.RHS:
        return np.concatenate([G, acc[:ns]])
    if output is Output.CONSTRAINT_FORCES:
        return lam
    if output is Output.REACTIONS:
        accs, lams = list(acceleration_symbols(n)), list(lambda_symbols(m))
        return ev("reactions", lambda: eq.reactions.matrix, (accs, lams), ur, acc, lam
                  ).reshape(-1, 6)
    # sensitivities: implicit differentiation of C = A u + b, E = M a - F - A^T lam, B = A a + beta
    variables = {Output.JACOBIAN: L.states, Output.PARAMETER_JACOBIAN: L.parameters,
                 Output.TIME_DERIVATIVE: (L.time,), Output.INPUT_JACOBIAN: L.inputs}[output]
    if output is Output.PARAMETER_JACOBIAN:
        variables = tuple(v for v in variables if v in dynamic_parameters(eq))
    nv = len(variables)
    accs, lams = list(sm.symbols(f"ra0:{n}")), list(sm.symbols(f"rl0:{m}"))
    u = list(L.all_speeds)
    Ms, As_ = sm.Matrix(eq.mass_matrix), sm.Matrix(c.velocity_matrix)
    Cx = As_ * sm.Matrix(u) + sm.Matrix(c.velocity_bias)
    Ex = Ms * sm.Matrix(accs) - sm.Matrix(eq.forcing) - As_.T * sm.Matrix(lams)
    Bx = As_ * sm.Matrix(accs) + sm.Matrix(c.acceleration_bias)
    everything = list(variables) + list(L.dependent_speeds)
    D = ev(("implicit", output), lambda: sm.Matrix(differentiate(
        list(Cx) + list(eq.kinematics) + list(Ex) + list(Bx), everything)),
           (accs, lams), ur, acc, lam).reshape(-1, nv + m)
    nq = L.n_q
    dC, dG, dE, dB = D[:m], D[m:m + nq], D[m + nq:m + nq + n], D[m + nq + n:]
    dur = -np.linalg.solve(Ar, dC[:, :nv])
    rhs = -np.vstack([dE[:, :nv] + dE[:, nv:] @ dur, dB[:, :nv] + dB[:, nv:] @ dur])
    da = np.linalg.solve(K, rhs)[:n]
    out = np.vstack([dG[:, :nv] + dG[:, nv:] @ dur, da[:ns]])
    return out.reshape(-1) if output is Output.TIME_DERIVATIVE else out


def _null_space_matrix(M, A):
    """``Z^T M Z`` for an orthonormal basis ``Z`` of the null space of ``A`` (positive definite
    when the constrained system has a well-defined motion)."""
    _, sv, vt = np.linalg.svd(A)
    rank = int(np.sum(sv > 1e-12 * max(1.0, sv.max() if sv.size else 1.0)))
    Z = vt[rank:].T
    return Z.T @ M @ Z


LambdifiedModel._constrained = _constrained


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
    points = tuple(replace(pk, position=rest[2 * i], velocity=rest[2 * i + 1])
                   for i, pk in enumerate(eq.points))
    reactions = (replace(eq.reactions, matrix=rest[-1]) if eq.reactions is not None else None)
    return replace(eq, mass_matrix=M, forcing=F, kinematics=G,
                   kinetic_energy=None if eq.kinetic_energy is None else T,
                   potential_energy=None if eq.potential_energy is None else V,
                   points=points, program=Program(), accelerations=None, reactions=reactions)
