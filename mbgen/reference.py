r"""The reference: a ``sympy.lambdify`` of the *unoptimised* equations.

No CSE, no printer of ours: expressions go straight from the derivation into
NumPy code, and ``M u' = F`` is solved with :func:`numpy.linalg.cholesky` and
:func:`numpy.linalg.solve`.  This is what the compiled C and the generated
Python are checked against.

Jacobians are sympy's ``Matrix.jacobian`` of ``G`` and of ``R = F - M a`` (the
accelerations ``a`` held fixed), lambdified, with
:math:`\partial u'/\partial v = M^{-1} \partial R/\partial v` solved numerically.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from .equations import Equations
from .optimize import Output
from .runtime import ModelBase


class LambdifiedModel(ModelBase):
    """``Equations`` evaluated through ``sympy.lambdify`` (NumPy backend)."""

    backend = "lambdify"

    def __init__(self, equations: Equations, outputs=tuple(Output)):
        outputs = tuple(o for o in Output.parse(outputs) if not o.is_integrator and (
            o is not Output.ENERGY or equations.kinetic_energy is not None) and (
            o is not Output.PARAMETER_JACOBIAN or equations.layout.n_p))
        super().__init__(equations.name, equations.layout, equations.defaults, outputs)
        L = equations.layout
        args = (L.time, list(L.states), list(L.parameters), list(L.inputs))
        self._M = sm.lambdify(args, equations.mass_matrix, modules="numpy", cse=False)
        self._F = sm.lambdify(args, equations.forcing, modules="numpy", cse=False)
        self._G = sm.lambdify(args, equations.kinematics, modules="numpy", cse=False)
        self._E = None
        if equations.kinetic_energy is not None:
            pot = equations.potential_energy if equations.potential_energy is not None else 0
            self._E = sm.lambdify(args, [equations.kinetic_energy, pot], modules="numpy",
                                  cse=False)
        self.equations = equations
        self._n_u = L.n_u
        self._args = args
        self._sensitivities: dict = {}

    def _sensitivity(self, output):
        """Lambdified ``(dG/dv, dR/dv)`` for the variables of ``output`` (built on first use)."""
        hit = self._sensitivities.get(output)
        if hit is None:
            eq, L = self.equations, self.equations.layout
            variables = {Output.JACOBIAN: L.states, Output.PARAMETER_JACOBIAN: L.parameters,
                         Output.TIME_DERIVATIVE: (L.time,)}[output]
            acc = sm.symbols(f"acc0:{L.n_u}")
            R = sm.Matrix(eq.forcing) - sm.Matrix(eq.mass_matrix) * sm.Matrix(acc)
            args = self._args + (list(acc),)
            dG = sm.lambdify(args, sm.Matrix(eq.kinematics).jacobian(variables), "numpy")
            dR = sm.lambdify(args, R.jacobian(variables), "numpy")
            hit = self._sensitivities[output] = (dG, dR, len(variables))
        return hit

    def _evaluate(self, output, t, x, p, r):
        self._require(output)
        t = self._t(t)
        xa, pa, ra = self._x(x), self._p(p), self._r(r)
        if output is Output.MASS_MATRIX:
            out = np.array(self._M(t, xa, pa, ra), dtype=float).reshape(self._n_u, self._n_u)
        elif output is Output.FORCING:
            out = np.array(self._F(t, xa, pa, ra), dtype=float).reshape(-1)
        elif output is Output.ENERGY:
            out = np.array(self._E(t, xa, pa, ra), dtype=float).reshape(-1)
        elif output in (Output.JACOBIAN, Output.PARAMETER_JACOBIAN, Output.TIME_DERIVATIVE):
            dG, dR, nv = self._sensitivity(output)
            M = np.array(self._M(t, xa, pa, ra), dtype=float).reshape(self._n_u, self._n_u)
            a = np.linalg.solve(M, np.array(self._F(t, xa, pa, ra), dtype=float).reshape(-1))
            G_v = np.array(dG(t, xa, pa, ra, a), dtype=float).reshape(-1, nv)
            R_v = np.array(dR(t, xa, pa, ra, a), dtype=float).reshape(self._n_u, nv)
            out = np.vstack([G_v, np.linalg.solve(M, R_v)])
            if output is Output.TIME_DERIVATIVE:
                out = out.reshape(-1)
        else:
            M = np.array(self._M(t, xa, pa, ra), dtype=float).reshape(self._n_u, self._n_u)
            F = np.array(self._F(t, xa, pa, ra), dtype=float).reshape(-1)
            G = np.array(self._G(t, xa, pa, ra), dtype=float).reshape(-1)
            try:
                np.linalg.cholesky(M)
            except np.linalg.LinAlgError:
                self._fail(1, output.value, t, xa)
            out = np.concatenate([G, np.linalg.solve(M, F)])
        if not np.all(np.isfinite(out)):
            self._fail(2, output.value, t, xa)
        return out
