r"""The reference: a ``sympy.lambdify`` of the *unoptimised* equations.

No optimising CSE, no printer of ours: expressions go straight from the
derivation into NumPy code through sympy's own printer, and ``M u' = F`` is
solved with :func:`numpy.linalg.cholesky` and :func:`numpy.linalg.solve`.  This
is what the compiled C and the generated Python are checked against.  Nodes the
derived graph shares are named once (:func:`mbgen.symbolic.split_shared`), so
the printed code is as large as the graph, not as its expanded tree.

Jacobians are derivatives of ``G`` and of ``R = F - M a`` (the accelerations
``a`` held fixed), lambdified, with
:math:`\partial u'/\partial v = M^{-1} \partial R/\partial v` solved numerically.
Every expression is lambdified on first use.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from .equations import Equations
from .errors import ModelError
from .layout import Layout
from .optimize import Output
from .outputs import _derivatives, dynamic_parameters
from .runtime import ModelBase
from .symbolic import free_symbols, split_shared

_SENSITIVITY = (Output.JACOBIAN, Output.PARAMETER_JACOBIAN, Output.TIME_DERIVATIVE)


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
            o not in (Output.POSITIONS, Output.VELOCITIES) or equations.points))
        super().__init__(equations.name, L, equations.defaults, outputs)
        self.equations = equations
        self._n_u = L.n_u
        self._args = (L.time, list(L.states), list(L.parameters), list(L.inputs))
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
                     Output.TIME_DERIVATIVE: (L.time,)}[output]
        if output is Output.PARAMETER_JACOBIAN:  # as generated: parameters of M, F and G
            variables = tuple(v for v in variables if v in dynamic_parameters(eq))
        acc = list(sm.symbols(f"acc0:{L.n_u}"))
        dG = self._lambdify(("dG", output),
                            lambda: sm.Matrix(_derivatives(list(eq.kinematics), variables)),
                            (acc,))
        dR = self._lambdify(("dR", output), lambda: sm.Matrix(_derivatives(list(
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
