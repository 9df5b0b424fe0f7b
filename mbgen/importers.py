r"""Equations of motion from :mod:`sympy.physics.mechanics`.

``from_sympy(obj)`` turns what sympy derived into an :class:`~mbgen.equations.Equations`
value, so its equations go through the same CSE, C and Python generation as
mbgen's own.

What is mapped to what
----------------------
=========================================  =============================================
sympy                                      mbgen
=========================================  =============================================
``KanesMethod.mass_matrix``                ``M`` (``M u' = F``, kinematics substituted)
``KanesMethod.forcing``                    ``F``
``kindiffdict()[q_i']``                    ``G_i`` (``q' = G``)
``LagrangesMethod.mass_matrix``            ``M`` with the speeds ``u = q'``
``LagrangesMethod.forcing``                ``F``
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
caller's System and choose the method for them.  Dependent coordinates or
speeds, auxiliary speeds, Lagrange multipliers and derivatives of inputs are
refused with a :class:`~mbgen.errors.ModelError`.  Every function of time that
is not a coordinate or speed becomes an input, as in sympy's own ``specified``.
No expression is simplified: the conversion only renames atoms.
"""

from __future__ import annotations

import re
from collections import Counter
from typing import NamedTuple, Sequence

import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import KanesMethod, LagrangesMethod, System, dynamicsymbols

from .equations import Equations
from .errors import ModelError
from .layout import Layout
from .names import model_prefix
from .symbolic import walk_unique

SUPPORTED = ("a KanesMethod after kanes_equations(), a LagrangesMethod after "
             "form_lagranges_equations(), or a System after form_eoms()")


class _Formed(NamedTuple):
    """What a formed sympy method holds, still in functions of time."""

    coordinates: list        # q_i(t)
    speeds: list             # u_i(t), or q_i'(t) for LagrangesMethod
    speed_names: list[str]
    mass_matrix: sm.Matrix
    forcing: sm.Matrix
    kinematics: list         # G_i with q_i' = G_i


def from_sympy(obj: KanesMethod | LagrangesMethod | System, *, name: str | None = None,
               parameters: Sequence[str | sm.Symbol] | None = None) -> Equations:
    """Convert equations of motion formed by ``sympy.physics.mechanics``.

    Parameters
    ----------
    obj : KanesMethod, LagrangesMethod or System
        With its equations formed: ``kanes_equations(...)``,
        ``form_lagranges_equations()`` or ``System.form_eoms(...)`` called.
    name : str, optional
        Model name, the C prefix of the generated code (default ``"sympy_model"``).
    parameters : sequence of str or Symbol, optional
        Order of the parameter vector ``p``: every remaining symbol of the
        equations, once.  Default: natural order of the names.

    Returns
    -------
    Equations
        ``M(q, t) u' = F(q, u, r, t)``, ``q' = G(q, u, t)`` in plain symbols.

    Raises
    ------
    ModelError
        For an unsupported object, equations not formed yet, constraints,
        auxiliary speeds, derivatives of inputs or a wrong ``parameters`` list.
    """
    name = "sympy_model" if name is None else name
    model_prefix(name)  # refuse a name that cannot prefix C symbols before any work
    system_speeds: set[str] = set()
    source = "sympy {}"
    if isinstance(obj, System):
        if obj.eom_method is None:
            raise ModelError("the System has no equations of motion yet (or it changed since "
                             "they were formed); call system.form_eoms() first")
        system_speeds = {str(u.func) for u in obj.u if isinstance(u, AppliedUndef)}
        source, obj = "sympy System ({})", obj.eom_method
    if isinstance(obj, KanesMethod):
        method, formed = "KanesMethod", _kane(obj)
    elif isinstance(obj, LagrangesMethod):
        method, formed = "LagrangesMethod", _lagrange(obj)
    else:
        raise ModelError(f"from_sympy() cannot convert a {type(obj).__name__}; pass {SUPPORTED}")
    eq = _convert(name, formed, parameters, source=source.format(method),
                  method=f"sympy.{method}")
    leaked = sorted(system_speeds & set(eq.layout.input_names))
    if leaked:
        raise ModelError(f"the {method} equations contain the System speeds {leaked}, which it "
                         f"does not know; for LagrangesMethod give the joints the coordinates' "
                         f"derivatives as speeds (e.g. PinJoint(..., speeds=q.diff(t)))")
    return eq


def _kane(km: KanesMethod) -> _Formed:
    """The equations of a KanesMethod; refuses constrained and auxiliary speeds.

    ``_uaux``, ``_qdep`` and ``_udep`` are private to sympy (checked with 1.14):
    KanesMethod has no public accessor for them.
    """
    try:
        M, F = km.mass_matrix, km.forcing
    except ValueError:
        raise ModelError("the KanesMethod has no equations yet; call "
                         "kane.kanes_equations(bodies, loads) first") from None
    if km._uaux:
        raise ModelError(f"auxiliary speeds {list(km._uaux)} are not supported; form the "
                         f"KanesMethod without u_auxiliary")
    if km._qdep or km._udep:
        raise ModelError("dependent coordinates or speeds (configuration or velocity "
                         "constraints) are not supported yet; use a minimal set of "
                         "independent coordinates and speeds")
    qdot = km.kindiffdict()
    q, u = list(km.q), list(km.u)
    G = [qdot[qi.diff(dynamicsymbols._t)] for qi in q]
    return _Formed(q, u, [str(ui.func) for ui in u], M, F, G)


def _lagrange(lm: LagrangesMethod) -> _Formed:
    """The equations of a LagrangesMethod, with speeds ``u = q'``; refuses multipliers."""
    if lm.eom is None:
        raise ModelError("the LagrangesMethod has no equations yet; call "
                         "lagrange.form_lagranges_equations() first")
    if lm.coneqs:
        raise ModelError("constraint equations (Lagrange multipliers) are not supported yet; "
                         "use a minimal set of independent coordinates")
    q, qd = list(lm.q), list(lm.u)
    return _Formed(q, qd, [f"{qi.func}_dot" for qi in q], lm.mass_matrix, lm.forcing, qd)


def _natural(name: str) -> tuple[tuple, str]:
    """Sort key with digit runs compared as numbers: ``m2 < m10``."""
    parts = re.split(r"(\d+)", name)
    return tuple(int(p) if i % 2 else p for i, p in enumerate(parts)), name


def _convert(name: str, formed: _Formed, parameters: Sequence[str | sm.Symbol] | None, *,
             source: str, method: str) -> Equations:
    """Replace functions of time by plain symbols and collect inputs and parameters."""
    t = dynamicsymbols._t
    coords = tuple(sm.Symbol(str(qi.func)) for qi in formed.coordinates)
    speeds = tuple(sm.Symbol(s) for s in formed.speed_names)
    known = dict(zip(formed.coordinates, coords)) | dict(zip(formed.speeds, speeds))
    M, F, G = formed.mass_matrix, formed.forcing, formed.kinematics

    symbols: set[sm.Symbol] = set()
    inputs: dict[AppliedUndef, sm.Symbol] = {}
    stray = []
    for node in walk_unique([*M, *F, *G]):
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

    known |= inputs
    M, F, G = (sm.ImmutableMatrix(e).xreplace(known) for e in (M, F, G))
    layout = Layout(coords, speeds, _order(params, parameters), tuple(inputs.values()), t)
    return Equations(name=name, layout=layout, mass_matrix=M, forcing=F, kinematics=G,
                     source=source, method=method)


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
