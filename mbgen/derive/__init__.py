"""Derivation of equations of motion: ``derive(model, Method.KANE) -> Equations``."""

from __future__ import annotations

from enum import Enum

from ..symbolic.equations import Equations
from ..errors import ModelError
from ..model.builder import Model
from .constraints import constrain
from .kane import kane
from .newton_euler import newton_euler
from .prepare import prepare


class Method(str, Enum):
    """Derivation methods: both give the same ``M u' = F``."""

    KANE = "kane"
    NEWTON_EULER = "newton_euler"


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
        method = Method(method)
    except ValueError:
        raise ModelError(f"unknown derivation method {method!r}; choose from "
                         f"{', '.join(m.value for m in Method)}") from None
    prep = prepare(model)
    if method is Method.KANE:
        eq = kane(model, energy, tuple(points), reactions, prep=prep)
    else:
        eq = newton_euler(model, energy, tuple(points), reactions,
                          articulated=not model.constraints_, prep=prep)
    return constrain(eq, prep)


__all__ = ["Method", "derive"]
