r"""Derivation of equations of motion: ``derive(model, Method.KANE) -> Equations``.

The package turns a :class:`~mbgen.model.builder.Model` into
:class:`~mbgen.symbolic.equations.Equations` in three steps, the same for
every method:

1. :mod:`~mbgen.derivation.prepare` -- plain symbols instead of functions of time,
   the kinematic differential equations solved for ``q'``, and the kinematic
   tree (:mod:`~mbgen.derivation.tree`);
2. the derivation method, looked up in :data:`METHODS` -- the equations of motion;
3. :mod:`~mbgen.derivation.constraints` -- the model's stated constraints, and
   :mod:`~mbgen.derivation.contacts` -- its rigid point contacts.

Equations that sympy's own methods formed come in through
:func:`~mbgen.derivation.from_sympy.from_sympy` instead.

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

and, where :class:`~mbgen.derivation.common.Wants` asks for them,

* ``kinetic_energy`` and ``potential_energy`` (gravity and springs),
  :math:`T = \tfrac12 \sum_k (m_k v_k\cdot v_k + \omega_k\cdot I_k\omega_k)` and
  :math:`V = -\sum_k m_k\, g\cdot r_k + \sum_s \tfrac12 k_s (L_s - L_{0,s})^2`
  (:func:`~mbgen.derivation.common.energies`);
* ``points``: position and velocity of the named points in Newtonian
  components (:func:`~mbgen.derivation.common.point_kinematics`);
* ``reactions``: force and moment of every joint, in acceleration placeholders
  (:func:`~mbgen.derivation.reactions.reactions_for`).

A recursive method may also fill ``program``, named intermediates
:math:`w_k = e_k(q, u, r, t, w_1, \dots, w_{k-1})` that every other expression
may use, and ``accelerations``, :math:`u' = A(q, u, r, t)` in program symbols
(the alternative to solving :math:`M u' = F`).

How to add a derivation
-----------------------
1. Write ``mbgen/derivation/<method>.py`` with one function
   ``<method>(prep: Prepared, wants: Wants) -> Equations`` that fills the
   fields above (shared pieces: :mod:`~mbgen.derivation.common`,
   :mod:`~mbgen.derivation.reactions`; a method over the body tree starts from
   :func:`~mbgen.derivation.recursion.outward_pass`, which forks the outward pass
   the choice already ran).
2. Add a member to :class:`Method` and its row to :data:`METHODS` (the CLI's
   ``--derivation`` choices and a scene's ``method`` follow :class:`Method`),
   and its name in :data:`mbgen.symbolic.equations.METHOD_TITLES`.
3. Run ``tests/derivation/test_derive.py``: it fails for a member of :class:`Method`
   without a row or a title, and checks that every method's ``M``, ``F``, ``G``
   and energies agree with Kane's on small models.
4. Decide where :func:`choose_method` should take it, and extend
   ``tests/derivation/test_choice.py``.

The default derivation
----------------------
With no method named, :func:`choose_method` looks at the joint tree
(:mod:`mbgen.derivation.choice`, where the measurements behind the rule are):

1. a model whose bodies and joints Newton–Euler cannot infer
   (:mod:`mbgen.derivation.joints`): Kane's method;
2. a tree of joints that own their speeds (relative joint coordinates) with a
   chain of at least :data:`~mbgen.derivation.choice.CHAIN` speeds (bodies, for
   joints of one speed; a floating base counts six), or with more
   than :data:`~mbgen.derivation.choice.COMPARE_SPEEDS` speeds: Newton–Euler, and
   Kane's method is not derived;
3. any other model with more than ``COMPARE_SPEEDS`` speeds: Kane's method;
4. otherwise it leaves the choice open.  The pipeline (:func:`mbgen.pipeline.run`,
   so ``mbgen.compile`` and ``mbgen generate``) then derives both and keeps,
   for every output asked, the one whose right-hand side has fewer operations
   (after CSE, the L D L^T solve included); a tie goes to Kane.  :func:`derive` alone,
   which cannot count generated operations, takes Kane's method.

The equations record which method was used and why (``Equations.method`` and
``Equations.method_reason``; ``Equations.derivation`` says both in words).  The
choice hands on what it computed (:attr:`Choice.prepared`: the prepared model with
its Newton–Euler outward pass), so that ``prepare`` and the outward pass run once per
derivation, or per comparison of both.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import Enum

from ..errors import ModelError
from ..model.builder import Model
from ..symbolic.build import interned
from ..symbolic.equations import Equations
from . import kane, newton_euler, prepare
from .choice import CHAIN, COMPARE_SPEEDS, Structure, structure
from .common import Wants
from .constraints import constrain
from .contacts import with_contacts
from .prepare import Prepared


class Method(str, Enum):
    """Derivation methods: both give the same ``M u' = F``."""

    KANE = "kane"
    NEWTON_EULER = "newton_euler"


#: The derivation of each method, ``(prep, wants) -> Equations``.
METHODS: dict[Method, Callable[[Prepared, Wants], Equations]] = {
    Method.KANE: kane.kane,
    Method.NEWTON_EULER: newton_euler.newton_euler,
}

#: ``Equations.method_reason`` of a method the caller named.
NAMED = "named: method="
#: ``Equations.method_reason`` of :func:`derive`'s default when :func:`choose_method` leaves
#: it open.
UNDECIDED = ("no method named; a small model: derive() takes Kane's, mbgen.compile keeps the "
             "cheaper of both")


@dataclass(frozen=True)
class Choice:
    """The default derivation of a model, as far as its structure decides it.

    ``method`` is None when the structure leaves the choice open: the caller
    derives both and keeps the one with fewer operations.  ``reason`` says why,
    in words (``Equations.method_reason``).  ``prepared`` is the model's
    :func:`~mbgen.derivation.prepare.prepare` value that the choice looked at, with the
    Newton–Euler outward pass it ran: :func:`derive` it, and neither runs again.
    """

    method: Method | None
    reason: str
    prepared: Prepared | None = field(default=None, compare=False, repr=False)


def choose_method(model: Model | Prepared) -> Choice:
    """The derivation mbgen uses when none is named, by the rule of this package's docstring.

    Parameters
    ----------
    model : Model or Prepared
        The model (or its :func:`~mbgen.derivation.prepare.prepare` output, to share it).

    Returns
    -------
    Choice
        ``Choice(Method.NEWTON_EULER, ...)`` or ``Choice(Method.KANE, ...)`` where
        the model's joint tree decides; ``Choice(None, ...)`` where both should
        be derived and compared.  Its ``prepared`` carries the outward pass.
    """
    prep = model if isinstance(model, Prepared) else prepare.prepare(_model(model))
    s = structure(prep)
    if s.outward is not None and prep.outward is None:
        prep = replace(prep, outward=s.outward)
    method, reason = _rule(s)
    return Choice(method, reason, prep)


def _rule(s: Structure) -> tuple[Method | None, str]:
    """The rule of this package's docstring, applied to the model's joint tree."""
    if s.unfit:
        return Method.KANE, f"chosen: Newton-Euler cannot infer this model's joints ({s.unfit})"
    if s.owned and s.chain_speeds >= CHAIN:
        return Method.NEWTON_EULER, f"chosen: {s.joint_tree}; Kane's method not derived"
    if s.speeds > COMPARE_SPEEDS:
        if s.owned:
            return Method.NEWTON_EULER, (f"chosen: {s.speeds} speeds on a tree of joints "
                                         f"that own them; Kane's method not derived")
        return Method.KANE, (f"chosen: {s.speeds} speeds, too many to derive both, and "
                             f"no tree of joints that own them; Newton-Euler not derived")
    tree = s.joint_tree if s.owned else "no tree of joints that own their speeds"
    return None, f"{s.speeds} speeds, {tree}: both are compared"


def derive(model: Model | Prepared, method: Method | None = None, *, energy: bool = True,
           points=(), reactions: bool = False, jacobian: bool = False) -> Equations:
    """Derive the equations of motion of ``model``.

    Parameters
    ----------
    model : Model or Prepared
        The multibody model, or its prepared value (a :class:`Choice`'s ``prepared``, to
        share what the choice computed: nothing is prepared, and no outward pass run,
        again).
    method : Method, optional
        ``Method.KANE`` (Kane's method with partial velocities) or
        ``Method.NEWTON_EULER`` (body by body over the joint tree, with the
        articulated-body recursion for ``u'`` where the joints allow it).
        Default: :func:`choose_method`'s choice, Kane's method where it leaves
        the choice open (``mbgen.compile`` then compares both; this function
        cannot count the generated operations).
    energy : bool
        Also derive the kinetic and potential energy (needed for ``Output.ENERGY``).
    points : sequence of str
        Points whose Newtonian position and velocity the equations carry
        (needed for ``Output.POSITIONS`` and ``Output.VELOCITIES``).
    reactions : bool
        Also derive the joint reactions (needed for ``Output.REACTIONS``).
    jacobian : bool
        Also derive ``Equations.residual_jacobian`` where the method has an analytic
        one (Newton–Euler on revolute joints; used by ``Output.JACOBIAN``).

    Returns
    -------
    Equations
        ``M(q, t) u' = F(q, u, r, t)``, ``q' = G(q, u, t)`` and the layout;
        ``method`` and ``method_reason`` say which derivation and why.
    """
    with interned():     # sums and products built directly (mbgen.symbolic.build)
        return _derive(model, method, Wants(energy, tuple(points), reactions, jacobian))


def _derive(model, method, wants: Wants) -> Equations:
    prep = model if isinstance(model, Prepared) else None
    model = prep.model if prep is not None else _model(model)
    named = None if method is None else method_of(method)
    prep = prep or prepare.prepare(model)
    if named is None:
        choice = choose_method(prep)
        prep = choice.prepared
        named, reason = (choice.method, choice.reason) if choice.method else (Method.KANE,
                                                                               UNDECIDED)
    else:
        reason = NAMED
    eq = METHODS[named](prep, wants)
    return replace(with_contacts(constrain(eq, prep), prep), method_reason=reason,
                   defaults={**eq.defaults, **model.defaults_})   # Model.constants(defaults=)


def method_of(method) -> Method:
    """``method`` (a :class:`Method` or its value) as a :class:`Method` with a row in
    :data:`METHODS`."""
    try:
        found = Method(method)
        METHODS[found]
    except (ValueError, KeyError):
        raise ModelError(f"unknown derivation method {method!r}; choose from "
                         f"{', '.join(m.value for m in METHODS)}") from None
    return found


def _model(model) -> Model:
    if not isinstance(model, Model):
        raise ModelError(f"derive() needs an mbgen.Model, got {type(model).__name__}")
    return model


__all__ = ["CHAIN", "COMPARE_SPEEDS", "METHODS", "Choice", "Method", "Wants", "choose_method",
           "derive", "method_of"]
