r"""Derivation of equations of motion: ``derive(model, Method.KANE) -> Equations``.

The package turns a :class:`~mbgen.model.builder.Model` into
:class:`~mbgen.symbolic.equations.Equations` in three steps, the same for
every method:

1. :mod:`~mbgen.derive.prepare` -- plain symbols instead of functions of time,
   the kinematic differential equations solved for ``q'``, and the kinematic
   tree (:mod:`~mbgen.derive.tree`);
2. the derivation method, looked up in :data:`METHODS` -- the equations of motion;
3. :mod:`~mbgen.derive.constraints` -- the model's stated constraints.

Equations that sympy's own methods formed come in through
:func:`~mbgen.derive.from_sympy.from_sympy` instead.

What a derivation method gives
------------------------------
A method is a function ``(prep: Prepared, wants: Wants) -> Equations``.  With
``q`` the ``n_q`` coordinates, ``u`` the ``n_u`` speeds (all of them: step 3
splits off the dependent ones), ``r`` the inputs and ``t`` time, in the order
of ``prep.layout``, it fills

* ``mass_matrix`` and ``forcing``: :math:`M(q, t)` (``n_u x n_u``, symmetric
  positive definite) and :math:`F(q, u, r, t)` (``n_u``) of the unconstrained
  system

  .. math:: M(q, t)\, u' = F(q, u, r, t)

  (step 3 adds the constraints, :math:`M u' = F + A^T \lambda`, for every method);
* ``kinematics``: :math:`G(q, u, t)` of :math:`q' = G` (``n_q``: ``prep.qdot``
  in layout order);
* ``layout`` (``prep.layout``), ``name``, ``source``, and ``method`` (the
  :class:`Method` value);

and, where :class:`~mbgen.derive.common.Wants` asks for them,

* ``kinetic_energy`` and ``potential_energy`` (gravity and springs),
  :math:`T = \tfrac12 \sum_k (m_k v_k\cdot v_k + \omega_k\cdot I_k\omega_k)` and
  :math:`V = -\sum_k m_k\, g\cdot r_k + \sum_s \tfrac12 k_s (L_s - L_{0,s})^2`
  (:func:`~mbgen.derive.common.energies`);
* ``points``: position and velocity of the named points in Newtonian
  components (:func:`~mbgen.derive.common.point_kinematics`);
* ``reactions``: force and moment of every joint, in acceleration placeholders
  (:func:`~mbgen.derive.reactions.reactions_for`).

A recursive method may also fill ``program``, named intermediates
:math:`w_k = e_k(q, u, r, t, w_1, \dots, w_{k-1})` that every other expression
may use, and ``accelerations``, :math:`u' = A(q, u, r, t)` in program symbols
(the alternative to solving :math:`M u' = F`).

How to add a derivation
-----------------------
1. Write ``mbgen/derive/<method>.py`` with one function
   ``<method>(prep: Prepared, wants: Wants) -> Equations`` that fills the
   fields above (shared pieces: :mod:`~mbgen.derive.common`,
   :mod:`~mbgen.derive.reactions`).
2. Add a member to :class:`Method` and its row to :data:`METHODS` (the CLI's
   ``--derivation`` choices and a scene's ``method`` follow :class:`Method`).
3. Run ``tests/derive/test_derive.py``: it fails for a member of :class:`Method`
   without a row, and checks that every method's ``M``, ``F``, ``G`` and
   energies agree with Kane's on small models.
"""

from __future__ import annotations

from enum import Enum
from typing import Callable

from ..symbolic.equations import Equations
from ..errors import ModelError
from ..model.builder import Model
from .common import Wants
from .constraints import constrain
from .kane import kane
from .newton_euler import newton_euler
from .prepare import Prepared, prepare


class Method(str, Enum):
    """Derivation methods: both give the same ``M u' = F``."""

    KANE = "kane"
    NEWTON_EULER = "newton_euler"


#: The derivation of each method, ``(prep, wants) -> Equations``.
METHODS: dict[Method, Callable[[Prepared, Wants], Equations]] = {
    Method.KANE: kane,
    Method.NEWTON_EULER: newton_euler,
}


def derive(model: Model, method: Method = Method.KANE, *, energy: bool = True,
           points=(), reactions: bool = False) -> Equations:
    """Derive the equations of motion of ``model``.

    Parameters
    ----------
    model : Model
        The multibody model.
    method : Method
        ``Method.KANE`` (Kane's method with partial velocities) or
        ``Method.NEWTON_EULER`` (body by body over the joint tree, with the
        articulated-body recursion for ``u'`` where the joints allow it).
    energy : bool
        Also derive the kinetic and potential energy (needed for ``Output.ENERGY``).
    points : sequence of str
        Points whose Newtonian position and velocity the equations carry
        (needed for ``Output.POSITIONS`` and ``Output.VELOCITIES``).
    reactions : bool
        Also derive the joint reactions (needed for ``Output.REACTIONS``).

    Returns
    -------
    Equations
        ``M(q, t) u' = F(q, u, r, t)``, ``q' = G(q, u, t)`` and the layout.
    """
    if not isinstance(model, Model):
        raise ModelError(f"derive() needs an mbgen.Model, got {type(model).__name__}")
    try:
        derivation = METHODS[Method(method)]
    except (ValueError, KeyError):
        raise ModelError(f"unknown derivation method {method!r}; choose from "
                         f"{', '.join(m.value for m in METHODS)}") from None
    prep = prepare(model)
    eq = derivation(prep, Wants(energy, tuple(points), reactions))
    return constrain(eq, prep)


__all__ = ["METHODS", "Method", "Wants", "derive"]
