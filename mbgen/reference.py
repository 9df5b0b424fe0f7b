"""The reference: a ``sympy.lambdify`` of the *unoptimised* equations.

No CSE, no printer of ours: expressions go straight from the derivation into
NumPy code, and ``M u' = F`` is solved with :func:`numpy.linalg.cholesky` and
:func:`numpy.linalg.solve`.  This is what the compiled C and the generated
Python are checked against.
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
        outputs = tuple(o for o in Output.parse(outputs)
                        if o is not Output.ENERGY or equations.kinetic_energy is not None)
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
