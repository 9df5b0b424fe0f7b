r"""Linearisation: ``dx/dt ~ A dx + B dr`` at an operating point, from compiled Jacobians.

Exact (symbolic derivatives, compiled), not finite differences:
``A = df/dx`` is the ``jacobian`` output and ``B = df/dr`` the ``input_jacobian``
output.  For a model with configuration constraints, the state ``x = [q, u_s]``
holds dependent coordinates ``q_r`` that the constraints tie to the others;
the linearisation is then in the *independent* states ``z = [q_s, u_s]``: on
the constraint manifold :math:`\delta q_r = -H_r^{-1} H_s\,\delta q_s` with
``H = df_h/dq``, so with ``E`` the embedding of ``dz`` into ``dx`` and ``P`` the
rows of ``z``,

.. math::

    A_z = P\,\frac{\partial f}{\partial x}\,E, \qquad B_z = P\,\frac{\partial f}{\partial r}.

(Dependent speeds are not states: the compiled Jacobian already differentiates
through the velocity constraints.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..abi import Output
from ..errors import ConstraintError, MbgenError
from .arguments import tolerance


@dataclass(frozen=True)
class Linearization:
    """``A`` (n x n), ``B`` (n x n_r) in the independent ``states``; ``eigenvalues`` of ``A``."""

    A: np.ndarray
    B: np.ndarray
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    eigenvalues: np.ndarray
    x: np.ndarray

    def format(self) -> str:
        lines = [f"linearisation in {len(self.states)} states {list(self.states)}"
                 + (f" and {len(self.inputs)} inputs {list(self.inputs)}" if self.inputs else ""),
                 "eigenvalues of A:"]
        order = np.argsort(-self.eigenvalues.real)
        for ev in self.eigenvalues[order]:
            lines.append(f"  {ev.real: .10g} {'+' if ev.imag >= 0 else '-'} {abs(ev.imag):.10g}i")
        return "\n".join(lines)


def linearize(model, x, p=None, r=None, t: float = 0.0, *, tol: float = 1e-8) -> Linearization:
    """Linearise ``model`` (a compiled, Python or lambdified model) at state ``x``.

    The model needs the ``jacobian`` output (and ``input_jacobian`` when it has
    inputs, ``holonomic_jacobian`` when it has configuration constraints).  A
    state off the configuration constraints (residual above ``tol``) is refused:
    complete it with ``model.consistent(x)`` first.  ``tol`` must be a finite
    number >= 0 (:class:`~mbgen.errors.ArgumentError`).
    """
    tol = tolerance(tol, "tol")
    for o in (Output.JACOBIAN,) + ((Output.INPUT_JACOBIAN,) if model.n_r else ()):
        if o not in model.outputs:
            raise MbgenError(f"linearize needs the {o.value!r} output of {model.name!r}; "
                             f"compile with outputs including {o.value!r}")
    x = model._x(x)
    J = model.jacobian(t, x, p, r)
    Jr = model.input_jacobian(t, x, p, r) if model.n_r else np.zeros((model.n_x, 0))
    names = list(model.state_names)
    dep = [names.index(n) for n in getattr(model, "dependent_coordinates", ())]
    if not dep:
        A, B, states = J, Jr, tuple(names)
    else:
        for o in (Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN):
            if o not in model.outputs:
                raise MbgenError(f"linearize needs the {o.value!r} output of {model.name!r} "
                                 f"(it has configuration constraints)")
        res = float(np.max(np.abs(model.holonomic(t, x, p, r))))
        if not res <= tol:
            raise ConstraintError(f"{model.name}: the state violates the configuration "
                                  f"constraints (residual {res:.3g}); linearise at a consistent "
                                  f"state, e.g. model.consistent(x)")
        n_q = model.layout.n_q
        H = model.holonomic_jacobian(t, x, p, r)
        ind_q = [i for i in range(n_q) if i not in dep]
        keep = ind_q + list(range(n_q, model.n_x))
        try:
            dq = -np.linalg.solve(H[:, dep], H[:, ind_q])
        except np.linalg.LinAlgError:
            raise ConstraintError(f"{model.name}: the configuration constraints do not "
                                  f"determine the dependent coordinates here (singular "
                                  f"Jacobian)") from None
        E = np.zeros((model.n_x, len(keep)))
        for col, i in enumerate(keep):
            E[i, col] = 1.0
        E[np.ix_(dep, range(len(ind_q)))] = dq
        A, B, states = J[keep] @ E, Jr[keep], tuple(names[i] for i in keep)
    return Linearization(A, B, states, tuple(model.input_names), np.linalg.eigvals(A), x.copy())


def tangent_jacobian(model, x, p=None, r=None, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    r"""``(du'/d delta, du'/du)``: the accelerations' Jacobian in the speeds' tangent space.

    Where ``q' = G(q) u`` (the kinematic equations are linear in the speeds, as for
    every joint of :func:`mbgen.from_urdf` and :func:`mbgen.from_mjcf`), a configuration
    moved along the speeds, :math:`q \oplus \delta = q + G(q)\,\delta + O(\delta^2)`, gives

    .. math::

        \frac{\partial u'}{\partial \delta} = \frac{\partial u'}{\partial q}\,G,
        \qquad G = \frac{\partial q'}{\partial u}

    (``n_u x n_u``).  For a floating base (a quaternion in ``q``) this is Pinocchio's
    ``ddq_dq`` of ``computeABADerivatives`` (its ``integrate`` is :math:`q \oplus \delta`
    to first order), and ``du'/du`` its ``ddq_dv``; for joints whose ``q' = u`` the first
    block is the ``du'/dq`` block itself.

    A model compiled with the ``tangent_jacobian`` output computes both blocks in one
    generated function (the sum over ``G`` before the solve, no product at run time);
    otherwise they are read from the ``jacobian`` output and multiplied here.
    """
    n_u = model.layout.n_u
    if Output.TANGENT_JACOBIAN in model.outputs:
        T = model.tangent_jacobian(t, model._x(x), p, r)
        return T[:, :n_u], T[:, n_u:]
    if Output.JACOBIAN not in model.outputs:
        raise MbgenError(f"tangent_jacobian needs the 'tangent_jacobian' or 'jacobian' output "
                         f"of {model.name!r}; compile with outputs including 'jacobian'")
    n_q = model.layout.n_q
    if getattr(model, "dependent_coordinates", ()):
        raise MbgenError(f"{model.name}: tangent_jacobian takes models without configuration "
                         f"constraints")
    J = model.jacobian(t, model._x(x), p, r)
    G = J[:n_q, n_q:]
    return J[n_q:, :n_q] @ G, J[n_q:, n_q:].copy()


__all__ = ["Linearization", "linearize", "tangent_jacobian"]
