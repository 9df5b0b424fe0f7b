"""The frozen records a :class:`~mbgen.model.builder.Model` is made of.

Each ``Model`` method that adds something validates its arguments and appends
one of these records: frames (:class:`FrameDef`) and points (:class:`PointDef`)
of the kinematic tree; masses (:class:`Particle`, :class:`RigidBody`); loads
(:class:`Force`, :class:`Torque`, :class:`Gravity`, :class:`LineElement`);
stated joints (:class:`Joint`) and constraints (:class:`Constraint`); generalized inertias
on single speeds (:class:`Armature`); rigid point contacts (:class:`Contact`); and, as data the
equations never use, the range a coordinate, speed or input is meant to stay in
(:class:`Bound`, :func:`bound_record`) and constants' default values
(:func:`constant_defaults`).  Vectors
are :class:`sympy.physics.vector.Vector` objects, scalars sympy expressions,
and an axis is its number 1, 2 or 3 in its frame (:func:`axis_index`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import sympy as sm
from sympy.matrices.exceptions import ShapeError
from sympy.physics import vector as spv

from ..errors import ModelError

#: How an axis may be named: 1, 2, 3 or x, y, z (either case).
AXES = {1: 1, 2: 2, 3: 3, "x": 1, "y": 2, "z": 3, "X": 1, "Y": 2, "Z": 3}


def axis_index(axis) -> int:
    """The axis number 1, 2 or 3 (as the records hold it) of an axis named as in :data:`AXES`."""
    try:
        return AXES[axis]
    except (KeyError, TypeError):
        raise ModelError(f"rotation axis {axis!r} is not 1, 2 or 3 (or 'x', 'y', 'z')") from None


@dataclass(frozen=True)
class FrameDef:
    """How a frame was built: a simple rotation of ``parent`` by ``angle`` about ``axis``
    (or, from :meth:`~mbgen.model.builder.Model.orient`, the matrix ``dcm``).

    ``angle`` may depend on coordinates and time (a prescribed motion).  When
    ``angular_velocity`` is set it overrides the rotation's own ``angle' * axis``
    as the angular velocity of the frame in the Newtonian frame (body rates).
    """

    frame: spv.ReferenceFrame
    parent: spv.ReferenceFrame | None
    axis: int | None
    angle: sm.Expr | None
    angular_velocity: spv.Vector | None = None
    dcm: sm.ImmutableMatrix | None = None   # ``R_PF`` of a frame made by Model.orient


@dataclass(frozen=True)
class PointDef:
    """A point at ``offset`` (a vector) from ``parent``; the origin has no parent."""

    point: spv.Point
    parent: spv.Point | None
    offset: spv.Vector


@dataclass(frozen=True)
class Particle:
    """A point mass ``mass`` at ``point``."""

    name: str
    point: spv.Point
    mass: sm.Expr


@dataclass(frozen=True)
class RigidBody:
    """A rigid body: mass centre ``center``, body-fixed ``frame``, inertia about the centre.

    ``inertia`` is the 3x3 inertia matrix (symmetric) in ``frame`` components.
    """

    name: str
    frame: spv.ReferenceFrame
    center: spv.Point
    mass: sm.Expr
    inertia: sm.ImmutableMatrix


@dataclass(frozen=True)
class Force:
    """A force ``vector`` at ``point``; ``reaction`` receives ``-vector`` when given."""

    point: spv.Point
    vector: spv.Vector
    reaction: spv.Point | None = None


@dataclass(frozen=True)
class Torque:
    """A torque ``vector`` on ``frame``; ``reaction`` receives ``-vector`` when given."""

    frame: spv.ReferenceFrame
    vector: spv.Vector
    reaction: spv.ReferenceFrame | None = None


@dataclass(frozen=True)
class Gravity:
    """Uniform gravitational acceleration ``vector`` acting on every mass."""

    vector: spv.Vector


@dataclass(frozen=True)
class LineElement:
    """A linear spring and/or damper between points ``a`` and ``b``.

    The force on ``a`` is ``-(stiffness * (L - natural_length) + damping * L') * e``
    with ``L = |r_a - r_b|`` and ``e`` the unit vector from ``b`` to ``a``; ``b``
    receives the opposite force.  With ``natural_length == 0`` the spring force
    is the linear ``-stiffness * (r_a - r_b)`` (no division by ``L``).
    """

    name: str
    a: spv.Point
    b: spv.Point
    stiffness: sm.Expr
    damping: sm.Expr
    natural_length: sm.Expr


@dataclass(frozen=True)
class Joint:
    """How a body hangs from its parent, stated by the user (else inferred at derivation).

    ``child`` and ``parent`` name particles or rigid bodies (``parent`` None:
    inferred; the Newtonian frame: the ground).  ``point`` is the joint point,
    fixed in the child; ``frame`` the frame in which the joint's reaction force
    and moment are reported (default: the child's).
    """

    name: str
    child: str
    parent: object = None
    point: spv.Point | None = None
    frame: spv.ReferenceFrame | None = None


@dataclass(frozen=True)
class Constraint:
    """A stated constraint, ``expression = 0`` (see :meth:`Model.holonomic`,
    :meth:`Model.nonholonomic`).

    ``kind`` is ``"holonomic"`` (configuration: ``f(q, t)``) or ``"motion"``
    (``f(q, u, t)``, linear in the speeds).  ``dependent`` is the dependent
    coordinate (holonomic) or speed (motion); ``speed`` the dependent speed of a
    holonomic constraint's time derivative (None: the speed ``u`` with
    ``q' = u`` for the dependent coordinate).  ``points``, ``frame`` and
    ``axis`` record a point constraint (``no_slip``: the velocity of
    ``points[0]`` along ``axis`` of ``frame``; ``coincident``: the position of
    ``points[0]`` minus ``points[1]``) so that its force can act on the bodies.
    """

    name: str
    kind: str
    expression: object
    dependent: object
    speed: object = None
    points: tuple = ()
    frame: spv.ReferenceFrame | None = None
    axis: int | None = None
    body: object = None


@dataclass(frozen=True)
class Armature:
    r"""A generalized inertia ``value`` on the speed ``speed`` alone (a joint's armature:
    the reflected inertia of a geared rotor, MuJoCo's ``dof_armature``).

    With :math:`a_k` the ``value`` on speed :math:`u_k` it adds :math:`a_k` to the
    diagonal entry :math:`M_{kk}` of the mass matrix and :math:`\tfrac12 a_k u_k^2` to the
    kinetic energy: the generalized force :math:`-a_k u_k'` in Kane's equations, which no
    other motion sees.  ``value`` is a constant (a number or constants, never
    coordinates, speeds, inputs or time), so it changes no partial derivative with respect
    to the state.
    """

    speed: object
    value: sm.Expr


def armature_record(model, speed, value) -> Armature:
    """``value`` on the speed ``speed`` of ``model`` (the speed, or its name), checked: a
    declared speed without armature yet, and a constant that is not negative."""
    name = speed if isinstance(speed, str) else str(getattr(speed, "func", speed))
    found = [s for s in model.speeds_ if str(s.func) == name]
    if not found:
        raise ModelError(f"armature on {speed!r}: not a speed of model {model.name!r}; "
                         f"speeds: {', '.join(str(s.func) for s in model.speeds_) or 'none'}")
    if any(str(a.speed.func) == name for a in model.armatures_):
        raise ModelError(f"speed {name!r} already has armature; give one armature per speed "
                         f"(the sum of its rotors' inertias)")
    value = model._scalar(value, f"armature on {name!r}")
    if value.free_symbols - set(model.constants_):     # q(t), u(t), r(t) hold t
        raise ModelError(f"armature on {name!r} must be a number or constants, not "
                         f"{value}: a constant inertia, free of coordinates, speeds, inputs "
                         f"and time")
    if value.is_number and not (value.is_real and value.is_finite and value >= 0):
        raise ModelError(f"armature on {name!r} must be a finite number >= 0, got {value}")
    return Armature(found[0], value)


@dataclass(frozen=True)
class Contact:
    r"""A rigid point contact: ``point`` held fixed in the Newtonian frame at ``anchor``.

    The constraint acts on the accelerations (every speed stays a state): with
    :math:`J` the point's velocity Jacobian and :math:`\gamma` its acceleration at
    :math:`u' = 0`, both in Newtonian components,
    :math:`J u' + \gamma + k_d v + k_p (r - r_0) = 0` (Baumgarte), and the ground's force
    :math:`\lambda` on the robot at the point enters :math:`M u' = F + J^T\lambda`
    (:mod:`mbgen.derivation.contacts`).  ``anchor`` are the constants :math:`r_0`
    (``<name>_x0``, ``_y0``, ``_z0``), ``gains`` the constants ``(k_p, k_d)``.
    """

    name: str
    point: object
    anchor: tuple
    gains: tuple


#: The names of the Baumgarte gains every contact of a model shares (default 0).
CONTACT_GAINS = ("contact_kp", "contact_kd")


def contact_record(model, point, name, anchor) -> Contact:
    """A contact at ``point`` of ``model`` named ``name`` (default: the point's), its anchor
    constants declared with the defaults ``anchor`` (three numbers; None: the origin), and
    the gains :data:`CONTACT_GAINS` on the first contact."""
    model._check_point(point)
    name = point.name if name is None else name
    if any(c.name == name for c in model.contacts_):
        raise ModelError(f"a contact named {name!r} already exists; pass name=")
    if any(c.point is point for c in model.contacts_):
        raise ModelError(f"point {point.name!r} already has a contact: two contacts at one point "
                         f"leave their forces undetermined")
    values = (0.0, 0.0, 0.0) if anchor is None else anchor
    if isinstance(values, str) or not hasattr(values, "__len__") or len(values) != 3:
        raise ModelError(f"anchor of contact {name!r} must be three numbers (x, y, z), got "
                         f"{anchor!r}")
    if not model.contacts_:
        model.constants(list(CONTACT_GAINS), defaults=[0.0, 0.0])
    r0 = model.constants([f"{name}_{axis}0" for axis in "xyz"], defaults=list(values))
    gains = tuple(next(s for s in model.constants_ if str(s) == g) for g in CONTACT_GAINS)
    return Contact(name, point, tuple(r0), gains)


#: What a :class:`Bound` may bound: the Model's list attribute of each kind.
BOUNDED = {"coordinates": "coordinates_", "speeds": "speeds_", "inputs": "inputs_"}


@dataclass(frozen=True)
class Bound:
    """``lower <= name <= upper`` for the coordinate, speed or input ``name`` of ``kind``
    (a key of :data:`BOUNDED`); ``-inf`` or ``inf`` where unbounded.  Data only: a
    joint's effort, velocity or range limit (URDF ``<limit>``) kept for whoever saturates
    or samples; the equations of motion never see it."""

    name: str
    kind: str
    lower: float
    upper: float


def bound_record(model, symbol, lower, upper) -> Bound:
    """``symbol`` (a coordinate, speed or input of ``model``, or its name) bounded to
    ``[lower, upper]`` (None: unbounded that way), checked: numbers, not NaN, in order."""
    name = symbol if isinstance(symbol, str) else str(getattr(symbol, "func", symbol))
    kind = next((kind for kind, attr in BOUNDED.items()
                 if name in [str(s.func) for s in getattr(model, attr)]), None)
    if kind is None:
        raise ModelError(f"cannot bound {symbol!r}: not a coordinate, speed or input of model "
                         f"{model.name!r}")
    ends = [(-math.inf, math.inf)[k] if v is None else v for k, v in enumerate((lower, upper))]
    try:
        lo, hi = (float(v) for v in ends)
    except (TypeError, ValueError):
        lo = hi = math.nan
    if math.isnan(lo) or math.isnan(hi) or lo > hi:
        raise ModelError(f"the bounds of {name!r} must be numbers (or None) with lower <= "
                         f"upper; got {lower!r}, {upper!r}")
    return Bound(name, kind, lo, hi)


def constant_defaults(symbols, values) -> dict[str, float]:
    """``{name: value}`` of constants ``symbols`` and their default ``values`` (one finite
    number each; None: no defaults)."""
    if values is None:
        return {}
    values = list(values) if isinstance(values, (list, tuple)) else [values]
    try:
        numbers = [float(v) for v in values]
    except (TypeError, ValueError):
        numbers = []
    if len(numbers) != len(symbols) or not all(math.isfinite(v) for v in numbers):
        raise ModelError(f"defaults of constants {', '.join(map(str, symbols))} must be one "
                         f"finite number each; got {values!r}")
    return {str(s): v for s, v in zip(symbols, numbers)}


def inertia_matrix(name: str, frame, inertia, scalar) -> sm.ImmutableMatrix:
    """Body ``name``'s inertia (a ``Dyadic``, a 3x3 matrix or ``(Ixx, Iyy, Izz[, Ixy, Iyz,
    Izx])``) as a symmetric 3x3 matrix in ``frame`` components; ``scalar`` reads a value."""
    if inertia is None:
        raise ModelError(f"rigid body {name!r} has no inertia; give inertia=(Ixx, Iyy, Izz) "
                         f"in the body frame, a Dyadic, or use particle() for a point mass")
    if isinstance(inertia, spv.Dyadic):
        mat = inertia.to_matrix(frame)
    elif isinstance(inertia, (tuple, list)) and len(inertia) in (3, 6) and not any(
            isinstance(v, (tuple, list)) for v in inertia):
        ixx, iyy, izz, *rest = (scalar(v) for v in inertia)
        ixy, iyz, izx = rest if rest else (0, 0, 0)
        mat = sm.Matrix([[ixx, ixy, izx], [ixy, iyy, iyz], [izx, iyz, izz]])
    else:
        try:
            rows = inertia.tolist() if hasattr(inertia, "tolist") else list(inertia)
            mat = sm.Matrix([[scalar(v) for v in row] for row in rows])
        except ModelError:  # an entry that is not a value: its own message
            raise
        except (TypeError, ValueError, sm.SympifyError, ShapeError):
            mat = None
        if mat is None or mat.shape != (3, 3):
            raise ModelError(f"inertia of body {name!r} must be a Dyadic, a 3x3 matrix or "
                             f"(Ixx, Iyy, Izz[, Ixy, Iyz, Izx]); got {inertia!r}")
    if (mat - mat.T).applyfunc(sm.expand) != sm.zeros(3, 3):
        raise ModelError(f"inertia matrix of body {name!r} is not symmetric: {mat.tolist()}")
    return sm.ImmutableMatrix(mat)



@dataclass(frozen=True)
class Ground:
    r"""A compliant ground: the half-space :math:`z \le 0` of the Newtonian frame, touched
    by ``points`` (:meth:`~mbgen.model.builder.Model.ground`, :mod:`mbgen.model.ground`).

    ``radii`` are the radii of spheres centred on the points (0: the point itself),
    ``frames`` the frame each point is fixed in (where the friction's moment acts),
    ``gaps`` and ``rates`` each contact's height above the ground and its rate
    (expressions in the model's coordinates and speeds), and ``stiffness``, ``damping``,
    ``friction`` and ``slip`` the constants (or expressions) :math:`k`, :math:`c`,
    :math:`\mu` and :math:`v_s` of the law.  The forces themselves are ordinary
    :class:`Force` (and, for a sphere, :class:`Torque`) loads of the model.
    """

    points: tuple
    radii: tuple
    frames: tuple
    gaps: tuple
    rates: tuple
    stiffness: sm.Expr
    damping: sm.Expr
    friction: sm.Expr
    slip: sm.Expr

__all__ = ["AXES", "BOUNDED", "Bound", "bound_record", "constant_defaults", "axis_index",
           "FrameDef", "inertia_matrix",
           "PointDef", "Particle", "RigidBody", "Force",
           "Torque", "Gravity", "LineElement", "Joint", "Constraint", "Armature",
           "armature_record", "Contact", "CONTACT_GAINS", "contact_record"]
__all__ += ["Ground"]
