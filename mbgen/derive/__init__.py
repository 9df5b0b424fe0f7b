"""Derivation of equations of motion: ``derive(model, Method.KANE) -> Equations``."""

from __future__ import annotations

from enum import Enum

from ..equations import Equations
from ..errors import ModelError
from ..model import Model
from .kane import kane


class Method(str, Enum):
    """Derivation methods."""

    KANE = "kane"


def derive(model: Model, method: Method = Method.KANE, *, energy: bool = True,
           points=()) -> Equations:
    """Derive the equations of motion of ``model``.

    Parameters
    ----------
    model : Model
        The multibody model.
    method : Method
        ``Method.KANE`` (Kane's method with partial velocities).
    energy : bool
        Also derive the kinetic and potential energy (needed for ``Output.ENERGY``).
    points : sequence of str
        Points whose Newtonian position and velocity the equations carry
        (needed for ``Output.POSITIONS`` and ``Output.VELOCITIES``).

    Returns
    -------
    Equations
        ``M(q, t) u' = F(q, u, r, t)``, ``q' = G(q, u, t)`` and the layout.
    """
    if not isinstance(model, Model):
        raise ModelError(f"derive() needs an mbgen.Model, got {type(model).__name__}")
    method = Method(method)
    if method is Method.KANE:
        return kane(model, energy, tuple(points))
    raise ModelError(f"unknown derivation method {method!r}")  # pragma: no cover


__all__ = ["Method", "derive"]
