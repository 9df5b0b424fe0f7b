r"""A floating root must move mass whichever way it moves, or the mass matrix is singular.

The six speeds of a free joint are the root's twist :math:`V`.  With every joint
below it free, the root feels the *articulated-body inertia* :math:`I^A` of its
subtree (Featherstone's inward pass), and the mass matrix :math:`M` is positive
definite only if :math:`I^A` is: a twist with :math:`V^T I^A V = 0` is a motion of
the root that the joints below can undo so that nothing with mass or inertia moves,
and that motion with the joints' undoing is a null vector of :math:`M`.  Then the
:math:`LDL^T` factorisation meets pivots of rounding size and either sign: finite
garbage at about half the states, ``SingularMassMatrixError`` at the rest.

The *composite* inertia (everything welded), which is :math:`M`'s 6x6 block on the
free joint, does not tell: a massless trunk on one revolute leg has the leg's full-rank
inertia there, yet the trunk can turn about the hip while the hip turns back.

In world coordinates about the world origin, at one configuration (so no transforms)::

    I^A_i = I_i + sum over children c of  I^A_c - I^A_c S_c (S_c^T I^A_c S_c)^+ S_c^T I^A_c

with :math:`S_c` (6 x k, rotation first) the motion subspace of the joint above
:math:`c` (k = 0 for a fixed joint: the child adds whole).  A rank lost at every
configuration (the structure) is lost at a pseudo-random one with probability one;
a rank lost at isolated configurations only stays a run-time
``SingularMassMatrixError``.  The test keeps the units apart: with
:math:`I^A = [[A, B], [B^T, C]]`, the translational block :math:`C` (kg) must be
positive definite against the total mass, and the Schur complement
:math:`A - B C^{-1} B^T` (kg m^2, the same about any point) against the total mass
times the robot's extent squared (both to :data:`RANK_TOL`).

A reader builds :class:`Part` rows of its tree (:func:`body_inertia`,
:func:`revolute_motion`, :func:`prismatic_motion`) and calls :func:`lack`;
:func:`mbgen.model.urdf.build_model` does for ``floating=True``,
:func:`mbgen.model.mjcf.from_mujoco` for every free joint.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Smallest eigenvalue, relative to its scale, of a block counted as positive: far above
#: rounding (1e-16), far below a real body's (a 1 mm by 1 m rod has 3e-6).
RANK_TOL = 1e-9

NO_MOTION = np.zeros((6, 0))


@dataclass(frozen=True)
class Part:
    """A body of the floating subtree at one configuration, in world coordinates about the
    world origin: ``parent`` its index (-1 for the root, index 0), ``motion`` the 6 x k
    motion subspace of the joint to its parent, ``inertia`` its 6 x 6 spatial inertia,
    ``mass`` and ``centre`` for the scale of the test.  A joint's ``armature`` (rotor
    inertia per column, MuJoCo's) adds to its pivot :math:`S^T I^A S`: a massless subtree
    behind a joint with armature still resists the joint's motion."""

    parent: int
    motion: np.ndarray
    inertia: np.ndarray
    mass: float
    centre: np.ndarray
    #: k rotor inertias added to the joint's pivots (MuJoCo's ``armature``), or None.
    armature: np.ndarray | None = None


def skew(r) -> np.ndarray:
    """``skew(r) @ x == cross(r, x)``."""
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def body_inertia(mass: float, centre, inertia) -> np.ndarray:
    """6 x 6 spatial inertia about the origin of ``mass`` at ``centre`` with ``inertia``
    (3 x 3, about the centre): kinetic energy ``V^T I V / 2`` of the twist ``(w, v_O)``."""
    c = skew(centre)
    return np.block([[np.asarray(inertia) + mass * c @ c.T, mass * c],
                     [mass * c.T, mass * np.eye(3)]])


def revolute_motion(axis, point) -> np.ndarray:
    """Twist of a unit turn about ``axis`` through ``point``: ``(a, point x a)``."""
    return np.concatenate([axis, np.cross(point, axis)])[:, None]


def prismatic_motion(axis) -> np.ndarray:
    """Twist of a unit slide along ``axis``: ``(0, a)``."""
    return np.concatenate([np.zeros(3), axis])[:, None]


def articulated_root(parts: list[Part]) -> np.ndarray:
    """:math:`I^A` of ``parts[0]`` (parents before children; module docstring)."""
    acc = [p.inertia.astype(float) for p in parts]
    for k in range(len(parts) - 1, 0, -1):
        part, inertia = parts[k], acc[k]
        S = part.motion
        if S.shape[1]:
            U = inertia @ S
            pivot = S.T @ U if part.armature is None else S.T @ U + np.diag(part.armature)
            inertia = inertia - U @ np.linalg.pinv(pivot) @ U.T
        acc[part.parent] = acc[part.parent] + inertia
    return acc[0]


def lack(parts: list[Part]) -> str | None:
    """None if the root of ``parts`` moves mass whichever way it moves, else what is
    missing, in words (a direction in world components)."""
    mass = sum(p.mass for p in parts)
    if not mass > 0:
        return "no mass at all"
    centre = sum(p.mass * p.centre for p in parts) / mass
    extent2 = max([float(centre @ centre)] +
                  [float((p.centre - centre) @ (p.centre - centre)) for p in parts])
    shift = np.block([[np.eye(3), np.zeros((3, 3))], [skew(centre), np.eye(3)]])
    I = shift.T @ articulated_root(parts) @ shift   # about the centre: less cancellation
    A, B, C = I[:3, :3], I[:3, 3:], I[3:, 3:]
    moments, axes = np.linalg.eigh((C + C.T) / 2)
    if moments[0] <= RANK_TOL * mass:
        return f"no mass against a translation along {_direction(axes[:, 0])}"
    schur = A - B @ np.linalg.solve(C, B.T)
    moments, axes = np.linalg.eigh((schur + schur.T) / 2)
    if moments[0] <= RANK_TOL * mass * extent2:
        return f"no inertia against a rotation about {_direction(axes[:, 0])}"
    return None


def _direction(v) -> str:
    v = v if v[np.argmax(np.abs(v))] > 0 else -v
    return "(" + ", ".join(f"{x + 0.0:.3g}" for x in v) + ")"
