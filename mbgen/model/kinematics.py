"""SOPHIA-style kinematics helpers on :mod:`sympy.physics.vector`.

The lecture notes' SOPHIA operators map onto these functions:

==========================  ==========================================
SOPHIA (Maple)              mbgen / sympy
==========================  ==========================================
``&rot[N,B,3,q1]``           ``model.rotate(N, "B", 3, q1)``
``chainSimpRot(list)``       ``model.chain_rotations(list)``
``Rmx(N,B)``                 :func:`dcm` ``(N, B)``
``B &ev [a,b,c]``            :func:`vec` ``(B, [a, b, c])``
``N &to v``                  :func:`express` ``(v, N)``
``v &++ w``, ``&xx``, ``&**``  ``v + w``, ``v ^ w`` (cross), ``v & w`` (dot)
``N &fdt v``                 :func:`frame_dt` ``(v, N)``
``N &aV B``                  :func:`angular_velocity` ``(B, N)``
==========================  ==========================================

These work on vectors written with time-dependent symbols (``q1(t)``); the
derivation engine in :mod:`mbgen.derivation` uses its own faster representation and
is tested against these.  Components are numbers or sympy expressions; strings
are refused (they are never evaluated, see :mod:`mbgen.model.expressions`).
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sm
from sympy.physics import vector as spv

from ..errors import ModelError
from .expressions import expression

__all__ = ["vec", "components", "express", "dcm", "frame_dt", "angular_velocity",
           "position", "velocity", "acceleration"]


def vec(frame: spv.ReferenceFrame, components: Sequence) -> spv.Vector:
    """The vector with ``components`` (length 3) in ``frame``: SOPHIA ``frame &ev [a, b, c]``."""
    if len(components) != 3:
        raise ModelError(f"a vector needs 3 components, got {len(components)}")
    a, b, c = (expression(x, None, f"component {i} of a vector in {frame}")
               for i, x in enumerate(components, 1))
    return a * frame.x + b * frame.y + c * frame.z


def components(vector: spv.Vector, frame: spv.ReferenceFrame) -> sm.Matrix:
    """The 3x1 column of ``vector``'s components in ``frame`` (the notes' ``^n w``)."""
    if vector == 0:
        return sm.zeros(3, 1)
    return vector.to_matrix(frame)


def express(vector: spv.Vector, frame: spv.ReferenceFrame) -> spv.Vector:
    """Re-express ``vector`` in ``frame`` (SOPHIA ``frame &to vector``)."""
    return spv.Vector(0) if vector == 0 else vector.express(frame)


def dcm(a: spv.ReferenceFrame, b: spv.ReferenceFrame) -> sm.Matrix:
    """Direction-cosine matrix ``R_ab = a^T . b`` (SOPHIA ``Rmx(a, b)``).

    Its columns are the ``b`` basis vectors in ``a`` components, so
    ``components(w, a) = dcm(a, b) * components(w, b)``.
    """
    return a.dcm(b)


def frame_dt(vector: spv.Vector, frame: spv.ReferenceFrame) -> spv.Vector:
    """Time derivative of ``vector`` as seen from ``frame`` (SOPHIA ``frame &fdt vector``)."""
    return spv.Vector(0) if vector == 0 else vector.dt(frame)


def angular_velocity(body: spv.ReferenceFrame, frame: spv.ReferenceFrame) -> spv.Vector:
    """Angular velocity of ``body`` in ``frame`` (SOPHIA ``frame &aV body``)."""
    return body.ang_vel_in(frame)


def position(point: spv.Point, origin: spv.Point) -> spv.Vector:
    """Position of ``point`` relative to ``origin``."""
    return point.pos_from(origin)


def velocity(point: spv.Point, origin: spv.Point, frame: spv.ReferenceFrame) -> spv.Vector:
    """Velocity of ``point`` in ``frame``, ``origin`` being fixed in ``frame``."""
    return frame_dt(position(point, origin), frame)


def acceleration(point: spv.Point, origin: spv.Point, frame: spv.ReferenceFrame) -> spv.Vector:
    """Acceleration of ``point`` in ``frame``, ``origin`` being fixed in ``frame``."""
    return frame_dt(velocity(point, origin, frame), frame)
