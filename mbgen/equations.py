r"""Equations of motion: one frozen value.

.. math::

    M(q, t)\,u' = F(q, u, r, t), \qquad q' = G(q, u, t)

with ``M`` symmetric positive definite (``n_u x n_u``), ``F`` of length ``n_u``
and ``G`` of length ``n_q``.  Time dependence is gone: ``q1(t)`` is the plain
symbol ``q1`` here, and every symbol is in :attr:`Equations.layout`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import sympy as sm

from .errors import ModelError
from .layout import Layout
from .symbolic import applied_functions, free_symbols


@dataclass(frozen=True)
class PointKinematics:
    """Position and velocity of a named point, 3x1 each, in Newtonian-frame components."""

    name: str
    position: sm.ImmutableMatrix
    velocity: sm.ImmutableMatrix


@dataclass(frozen=True)
class Equations:
    """Mass matrix, forcing and kinematics of a model, plus optional extras.

    Attributes
    ----------
    name : str
        Model name (the C prefix is derived from it).
    layout : Layout
        Order of states, parameters and inputs.
    mass_matrix : ImmutableMatrix, shape (n_u, n_u)
        ``M(q, t)``, symmetric.
    forcing : ImmutableMatrix, shape (n_u, 1)
        ``F(q, u, r, t)``.
    kinematics : ImmutableMatrix, shape (n_q, 1)
        ``G(q, u, t)`` with ``q' = G``.
    kinetic_energy, potential_energy : Expr or None
        Energies when the derivation knows them (potential: gravity and springs).
    points : tuple of PointKinematics
        Positions and velocities of the points asked for at derivation.
    source : str
        Where the equations came from (shown in generated headers).
    method : str
        Derivation method (``"kane"``, ``"sympy.KanesMethod"``, ...).
    defaults : mapping
        Default numeric values of parameters, by symbol name (may be partial).
    """

    name: str
    layout: Layout
    mass_matrix: sm.ImmutableMatrix
    forcing: sm.ImmutableMatrix
    kinematics: sm.ImmutableMatrix
    kinetic_energy: sm.Expr | None = None
    potential_energy: sm.Expr | None = None
    points: tuple[PointKinematics, ...] = ()
    source: str = ""
    method: str = ""
    defaults: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        L = self.layout
        if self.mass_matrix.shape != (L.n_u, L.n_u):
            raise ModelError(f"mass matrix has shape {self.mass_matrix.shape}, "
                             f"expected ({L.n_u}, {L.n_u})")
        if self.forcing.shape != (L.n_u, 1):
            raise ModelError(f"forcing has shape {self.forcing.shape}, expected ({L.n_u}, 1)")
        if self.kinematics.shape != (L.n_q, 1):
            raise ModelError(f"kinematics has shape {self.kinematics.shape}, "
                             f"expected ({L.n_q}, 1)")
        known = L.symbols()
        for what, exprs in (("mass matrix", self.mass_matrix), ("forcing", self.forcing),
                            ("kinematics", self.kinematics)):
            unknown = free_symbols(exprs) - known
            if unknown:
                names = ", ".join(sorted(map(str, unknown)))
                raise ModelError(f"the {what} contains symbol(s) {names} that are neither "
                                 f"coordinates, speeds, parameters, inputs nor time; declare "
                                 f"them (e.g. model.constants('{names.split(', ')[0]}'))")
            funcs = applied_functions(exprs)
            if funcs:
                raise ModelError(f"the {what} still contains function(s) of time "
                                 f"{sorted(map(str, funcs))}; declare them as coordinates, "
                                 f"speeds or inputs")

    @property
    def energy(self) -> sm.Expr | None:
        """Total mechanical energy ``T + V`` when both are known."""
        if self.kinetic_energy is None or self.potential_energy is None:
            return None
        return self.kinetic_energy + self.potential_energy

    def mass_matrix_full(self) -> sm.ImmutableMatrix:
        """Block-diagonal ``diag(I_nq, M)`` of the first-order system ``[I 0; 0 M] x' = [G; F]``."""
        L = self.layout
        out = sm.zeros(L.n_x, L.n_x)
        out[:L.n_q, :L.n_q] = sm.eye(L.n_q)
        out[L.n_q:, L.n_q:] = self.mass_matrix
        return sm.ImmutableMatrix(out)

    def forcing_full(self) -> sm.ImmutableMatrix:
        """``[G; F]`` of length ``n_x``."""
        return sm.ImmutableMatrix(sm.Matrix.vstack(sm.Matrix(self.kinematics), sm.Matrix(self.forcing)))
