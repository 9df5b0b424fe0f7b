r"""Equations of motion from :mod:`sympy.physics.mechanics`.

``from_sympy(obj)`` turns what sympy derived into an :class:`~mbgen.symbolic.equations.Equations`
value, so its equations go through the same CSE, C and Python generation as
mbgen's own.

What is mapped to what
----------------------
=========================================  =============================================
sympy                                      mbgen
=========================================  =============================================
``KanesMethod.mass_matrix``                ``M`` (``M u' = F``, kinematics substituted;
                                           re-formed unconstrained, see below)
``KanesMethod.forcing``                    ``F``
``kindiffdict()[q_i']``                    ``G_i`` (``q' = G``)
``q_dependent``, ``u_dependent``           ``constraints.dependent_coordinates``,
                                           ``layout.dependent_speeds``
``configuration_constraints``              ``constraints.holonomic`` (``f_h = 0``)
``velocity_constraints``                   ``A u + b = 0``, rows named ``configuration_<i>``
                                           and ``velocity_<k>``
``u_auxiliary``                            zero (with their derivatives)
``LagrangesMethod.mass_matrix``            ``M`` (its first ``n`` columns) with ``u = q'``
``LagrangesMethod.forcing``                ``F``
``hol_coneqs``; ``coneqs``; ``lam_vec``    ``constraints.holonomic``; ``A u + b = 0``;
                                           the rows' names ``lam1 ...`` (multipliers)
``q_i(t)``, ``u_i(t)``                     ``Symbol("q_i")``, ``Symbol("u_i")``, in
                                           sympy's order
``q_i'(t)`` (LagrangesMethod speeds)       ``Symbol("q_i_dot")``
other functions of time, e.g. ``F(t)``     inputs ``Symbol("F")``, natural name order
remaining plain symbols                    parameters, natural name order (``m2 < m10``)
                                           or the order given by ``parameters=``
``dynamicsymbols._t``                      time
=========================================  =============================================

A :class:`~sympy.physics.mechanics.System` is converted through its
``eom_method``; ``form_eoms`` is not called here, because it would change the
caller's System and choose the method for them.  A PyDy ``System``
(``pydy.system.System``) is converted through its ``eom_method`` too, and its
numeric ``constants`` become the parameters' defaults.  Every function of time
that is not a coordinate or speed becomes an input, as in sympy's own
``specified``; derivatives of inputs are refused with a
:class:`~mbgen.errors.ModelError`.  No expression is simplified: the conversion
only renames atoms (one DAG pass).

Constraints
-----------
A KanesMethod with dependent coordinates and speeds (``q_dependent``,
``configuration_constraints``, ``u_dependent``, ``velocity_constraints``) and a
LagrangesMethod with ``hol_coneqs`` / ``nonhol_coneqs`` give constrained
``Equations`` (:mod:`mbgen.derivation.sympy_constraints` builds the constraint data).
mbgen wants ``M`` and ``F`` of the *unconstrained* system over every speed;
a constrained KanesMethod keeps only the reduced ``Fr + Fr* = 0``, so the
unconstrained ones are re-formed: a second KanesMethod over the same frame,
coordinates, kinematic equations, bodies and loads, with every speed
independent, through sympy's public ``kanes_equations``.  That doubles sympy's
own derivation time (0.20 s of the 0.27 s import of the rolling disc, medians
of 5) but reads nothing of sympy's beyond the stated constraints and the frame;
sympy discards its full-size matrices after reducing them with
``Ars = -B_dep^-1 B_ind`` (a symbolic inverse), so reading them back would mean
copying its private ``_form_frstar``.  A LagrangesMethod keeps its unconstrained ``M`` (the first
``n`` columns of ``mass_matrix``) and ``forcing``.  How the constraint rows,
their names and the dependent speeds of a LagrangesMethod are chosen:
:mod:`mbgen.derivation.sympy_constraints`.

Auxiliary speeds (``u_auxiliary``) are zero in the motion: they and their
derivatives are set to zero everywhere, as sympy does in ``M`` and ``F``.
The noncontributing forces they bring into evidence are the multipliers
``constraint_forces`` where the velocity constraints state that the contact
point has zero velocity (the rolling disc of sympy's ``test_aux_dep``: the
contact force ``Fx, Fy, Fz`` in frame ``A``); sympy's ``auxiliary_eqs``
themselves are not converted.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import KanesMethod, LagrangesMethod, System, dynamicsymbols

from ..errors import ModelError
from ..model.scene import UNNAMED
from ..names import model_prefix
from ..symbolic.equations import Equations
from ..symbolic.graph import walk_unique, xreplace_dag
from ..symbolic.layout import Layout
from . import sympy_constraints
from .sympy_constraints import Stated

SUPPORTED = ("a KanesMethod after kanes_equations(), a LagrangesMethod after "
             "form_lagranges_equations(), a System after form_eoms(), or a PyDy System")


class _Formed(NamedTuple):
    """What a formed sympy method holds, still in functions of time."""

    coordinates: list        # q_i(t)
    speeds: list             # u_i(t) (independent, then dependent), or q_i'(t) for LagrangesMethod
    speed_names: list[str]
    mass_matrix: sm.Matrix   # unconstrained, over every speed
    forcing: sm.Matrix
    kinematics: list         # G_i with q_i' = G_i
    vanishing: tuple = ()    # zero in the motion: auxiliary speeds and their derivatives
    constraints: Stated | None = None


def from_sympy(obj: KanesMethod | LagrangesMethod | System, *, name: str | None = None,
               parameters: Sequence[str | sm.Symbol] | None = None,
               dependent: Sequence | None = None) -> Equations:
    """Convert equations of motion formed by ``sympy.physics.mechanics``.

    Parameters
    ----------
    obj : KanesMethod, LagrangesMethod, System or pydy.system.System
        With its equations formed: ``kanes_equations(...)``,
        ``form_lagranges_equations()`` or ``System.form_eoms(...)`` called.
        Constraints and auxiliary speeds are converted (see the module notes).
    name : str, optional
        Model name, the C prefix of the generated code.  Default
        ``"sympy_model"`` (:data:`mbgen.model.scene.UNNAMED`), which a scene holding
        the equations replaces by its own name: ``Scene(name="cart",
        model=from_sympy(kane))`` generates ``cart.h`` with ``cart_rhs``.
    parameters : sequence of str or Symbol, optional
        Order of the parameter vector ``p``: every remaining symbol of the
        equations, once.  Default: natural order of the names.
    dependent : sequence, optional
        LagrangesMethod only: the coordinates whose speeds ``q'`` the
        constraints determine, one per constraint (``q3`` as ``q3(t)``, its
        derivative or the name ``"q3"``); the configuration constraints'
        dependent coordinates are the first of them, in this order, that they
        determine.  Default: a sympy System's ``q_dep`` and ``u_dep``, else chosen
        from the constraint Jacobian, from the last coordinate backwards
        (``Equations.layout.dependent_speeds`` tells which).  A KanesMethod names
        its own (``q_dependent``, ``u_dependent``).

    Returns
    -------
    Equations
        ``M(q, t) u' = F(q, u, r, t)``, ``q' = G(q, u, t)`` in plain symbols, with
        ``constraints`` for a constrained method (``M``, ``F`` then unconstrained,
        over every speed).

    Raises
    ------
    ModelError
        For an unsupported object, equations not formed yet, constraints that
        are redundant, not linear in the speeds or do not determine the
        dependent speeds, derivatives of inputs or a wrong ``parameters`` or
        ``dependent`` list.
    """
    name = UNNAMED if name is None else name
    model_prefix(name)  # refuse a name that cannot prefix C symbols before any work
    system_speeds: set[str] = set()
    source, defaults = "sympy {}", {}
    if _is_pydy_system(obj):
        defaults = {str(k): float(v) for k, v in obj.constants.items()
                    if isinstance(v, (int, float, np.number))}
        source, obj = "PyDy System ({})", obj.eom_method
    if isinstance(obj, System):
        if obj.eom_method is None:
            raise ModelError("the System has no equations of motion yet (or it changed since "
                             "they were formed); call system.form_eoms() first")
        system_speeds = {str(u.func) for u in obj.u if isinstance(u, AppliedUndef)}
        if dependent is None and isinstance(obj.eom_method, LagrangesMethod):
            dependent = _system_dependent(obj)
        source, obj = "sympy System ({})", obj.eom_method
    if dependent is not None and not isinstance(obj, LagrangesMethod):
        raise ModelError("dependent= is for a LagrangesMethod; a KanesMethod names its "
                         "dependent coordinates and speeds itself (q_dependent=, u_dependent=)")
    if isinstance(obj, KanesMethod):
        method, formed = "KanesMethod", _kane(obj)
    elif isinstance(obj, LagrangesMethod):
        method, formed = "LagrangesMethod", _lagrange(obj, dependent)
    else:
        raise ModelError(f"from_sympy() cannot convert a {type(obj).__name__}; pass {SUPPORTED}")
    eq = _convert(name, formed, parameters, source=source.format(method),
                  method=f"sympy.{method}")
    leaked = sorted(system_speeds & set(eq.layout.input_names))
    if leaked:
        raise ModelError(f"the {method} equations contain the System speeds {leaked}, which it "
                         f"does not know; for LagrangesMethod give the joints the coordinates' "
                         f"derivatives as speeds (e.g. PinJoint(..., speeds=q.diff(t)))")
    if defaults:
        known = set(eq.layout.parameter_names)
        eq = replace(eq, defaults={k: v for k, v in defaults.items() if k in known})
    return eq


def _is_pydy_system(obj) -> bool:
    """A ``pydy.system.System`` (not imported: PyDy is optional)."""
    return (type(obj).__module__.split(".")[0] == "pydy" and type(obj).__name__ == "System"
            and hasattr(obj, "eom_method"))


def _system_dependent(system: System) -> list | None:
    """A sympy System's ``q_dep`` then the coordinates of ``u_dep`` (for a LagrangesMethod)."""
    t = dynamicsymbols._t
    out = list(system.q_dep)
    for u in system.u_dep:
        if not (isinstance(u, sm.Derivative) and u.args[1:] == ((t, 1),)):
            raise ModelError(f"the System's dependent speed {u} is not the derivative of a "
                             f"coordinate, as a LagrangesMethod needs; set system.u_dep to "
                             f"coordinates' derivatives or pass dependent=[...] to from_sympy")
        if u.expr not in out:
            out.append(u.expr)
    return out or None


def _kane(km: KanesMethod) -> _Formed:
    """The equations of a KanesMethod, its constraints and auxiliary speeds.

    ``_qdep``, ``_udep``, ``_uaux``, ``_f_h``, ``_k_nh``, ``_f_nh`` and
    ``_inertial`` are private to sympy (checked with 1.14): KanesMethod has no
    public accessor for the dependent and auxiliary speeds, the stated
    constraints or its frame.
    """
    try:
        M, F = km.mass_matrix, km.forcing
    except ValueError:
        raise ModelError("the KanesMethod has no equations yet; call "
                         "kane.kanes_equations(bodies, loads) first") from None
    t = dynamicsymbols._t
    qdot = km.kindiffdict()
    q, u, aux = list(km.q), list(km.u), list(km._uaux)
    G = [qdot[qi.diff(t)] for qi in q]
    vanishing = tuple(aux + [a.diff(t) for a in aux])
    stated = None
    if km._udep or km._qdep:
        M, F = _unconstrained(km, q, u, aux, G)
        rows = list(km._k_nh * sm.Matrix(u) + km._f_nh) if km._udep else []
        stated = Stated("kane", list(km._f_h), rows, [], list(km._qdep), len(km._udep))
    return _Formed(q, u, [str(ui.func) for ui in u], M, F, G, vanishing, stated)


def _unconstrained(km: KanesMethod, q, u, aux, G) -> tuple[sm.Matrix, sm.Matrix]:
    """``M`` and ``F`` over every speed: Kane's equations re-formed with no dependent speed."""
    t = dynamicsymbols._t
    full = KanesMethod(km._inertial, q, u, kd_eqs=[qi.diff(t) - g for qi, g in zip(q, G)],
                       u_auxiliary=aux or None)
    try:
        full.kanes_equations(km.bodies, km.loads)
    except (ValueError, TypeError, AttributeError) as e:
        raise ModelError(f"re-forming the KanesMethod's equations without its constraints "
                         f"failed ({e}); pass bodies and loads to kanes_equations()") from None
    return full.mass_matrix, full.forcing


def _lagrange(lm: LagrangesMethod, dependent) -> _Formed:
    """The equations of a LagrangesMethod with speeds ``u = q'``, and its constraints.

    ``lm._hol_coneqs`` is private to sympy (checked with 1.14): the holonomic
    constraints themselves, before differentiation.
    """
    if lm.eom is None:
        raise ModelError("the LagrangesMethod has no equations yet; call "
                         "lagrange.form_lagranges_equations() first")
    q, qd = list(lm.q), list(lm.u)
    n = len(q)
    M, stated = lm.mass_matrix, None
    if lm.coneqs:
        M = M[:, :n]
        requested = None if dependent is None else _positions(dependent, q, qd)
        stated = Stated("lagrange", list(lm._hol_coneqs), list(lm.coneqs),
                        [str(lam.func) for lam in lm.lam_vec], [], requested=requested)
    return _Formed(q, qd, [f"{qi.func}_dot" for qi in q], M, lm.forcing, qd, (), stated)


def _positions(dependent, q, qd) -> list[int]:
    """Positions of the coordinates named by ``dependent`` (functions, derivatives or names)."""
    names = [str(qi.func) for qi in q]
    out = []
    for d in ([dependent] if isinstance(dependent, (str, sm.Basic)) else list(dependent)):
        key = d if isinstance(d, str) else None
        if isinstance(d, sm.Basic):
            key = (str(d.func) if d in q else str(q[qd.index(d)].func) if d in qd
                   else str(d))
        key = key[:-4] if key.endswith("_dot") and key[:-4] in names else key
        if key not in names:
            raise ModelError(f"dependent= names {d}, which is not a coordinate of the "
                             f"LagrangesMethod {names}")
        if names.index(key) in out:
            raise ModelError(f"dependent= names {key} twice")
        out.append(names.index(key))
    return out


def _natural(name: str) -> tuple[tuple, str]:
    """Sort key with digit runs compared as numbers: ``m2 < m10``."""
    parts = re.split(r"(\d+)", name)
    return tuple(int(p) if i % 2 else p for i, p in enumerate(parts)), name


def _convert(name: str, formed: _Formed, parameters: Sequence[str | sm.Symbol] | None, *,
             source: str, method: str) -> Equations:
    """Replace functions of time by plain symbols, collect inputs and parameters, and
    build the constraints (one DAG pass over every expression)."""
    t = dynamicsymbols._t
    coords = tuple(sm.Symbol(str(qi.func)) for qi in formed.coordinates)
    speeds = tuple(sm.Symbol(s) for s in formed.speed_names)
    known = dict(zip(formed.coordinates, coords)) | dict(zip(formed.speeds, speeds))
    known |= {v: sm.S.Zero for v in formed.vanishing}
    stated = formed.constraints
    exprs = [*formed.mass_matrix, *formed.forcing, *formed.kinematics]
    exprs += stated.expressions() if stated is not None else []

    symbols: set[sm.Symbol] = set()
    inputs: dict[AppliedUndef, sm.Symbol] = {}
    stray = []
    for node in walk_unique(exprs):
        if isinstance(node, sm.Symbol):
            symbols.add(node)
        elif isinstance(node, (AppliedUndef, sm.Derivative)) and node not in known:
            if isinstance(node, AppliedUndef) and node.args == (t,):
                inputs[node] = sm.Symbol(str(node.func))
            else:
                stray.append(node)
    if stray:
        raise ModelError(f"the equations contain {sorted(map(str, stray))}, which are neither "
                         f"coordinates, speeds nor inputs (functions of time alone); derivatives "
                         f"of inputs are not supported: make such a derivative an input itself")
    inputs = dict(sorted(inputs.items(), key=lambda kv: _natural(kv[1].name)))
    params = symbols - {t}
    names = Counter(s.name for s in (*coords, *speeds, *inputs.values(), *params))
    clash = sorted(n for n, k in names.items() if k > 1)
    if clash:
        raise ModelError(f"the name(s) {clash} belong to two different symbols (a plain symbol "
                         f"named like a coordinate, speed or input, or symbols with different "
                         f"assumptions); rename one of them")

    plain = iter(xreplace_dag(exprs, known | inputs))
    n, nq = len(speeds), len(coords)
    M = sm.ImmutableMatrix(n, n, [next(plain) for _ in range(n * n)])
    F = sm.ImmutableMatrix(n, 1, [next(plain) for _ in range(n)])
    G = sm.ImmutableMatrix(nq, 1, [next(plain) for _ in range(nq)])
    params, inputs = _order(params, parameters), tuple(inputs.values())
    if stated is None:
        layout = Layout(coords, speeds, params, inputs, t)
        return Equations(name=name, layout=layout, mass_matrix=M, forcing=F, kinematics=G,
                         source=source, method=method)
    holonomic = [next(plain) for _ in stated.holonomic]
    stated = stated._replace(holonomic=holonomic, velocity=list(plain),
                             dependent_coordinates=[known[q] for q in
                                                    stated.dependent_coordinates])
    build = sympy_constraints.kane if stated.kind == "kane" else sympy_constraints.lagrange
    order, n_dep, cons = build(stated, list(coords), list(speeds), list(G), t)
    ordered = [speeds[j] for j in order]
    layout = Layout(coords, tuple(ordered[:n - n_dep]), params, inputs, t,
                    tuple(ordered[n - n_dep:]))
    return Equations(name=name, layout=layout,
                     mass_matrix=sm.ImmutableMatrix(n, n, [M[i, j] for i in order for j in order]),
                     forcing=sm.ImmutableMatrix(n, 1, [F[i] for i in order]), kinematics=G,
                     source=source, method=method, constraints=cons)


def _order(params: set[sm.Symbol],
           order: Sequence[str | sm.Symbol] | None) -> tuple[sm.Symbol, ...]:
    """Parameters in natural name order, or in ``order`` (which must name each exactly once)."""
    by_name = {s.name: s for s in params}
    if order is None:
        return tuple(by_name[n] for n in sorted(by_name, key=_natural))
    names = [str(p) for p in order]
    unknown = [n for n in names if n not in by_name]
    missing = sorted(set(by_name) - set(names), key=_natural)
    twice = sorted({n for n in names if names.count(n) > 1})
    if unknown or missing or twice:
        problems = [f"{what} {lst}" for what, lst in (
            ("not parameters of the equations:", unknown), ("missing:", missing),
            ("given twice:", twice)) if lst]
        raise ModelError(f"parameters= must list each parameter {sorted(by_name, key=_natural)} "
                         f"exactly once; " + "; ".join(problems))
    return tuple(by_name[n] for n in names)
