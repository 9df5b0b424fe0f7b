r"""A compliant ground to stand on: the half-space :math:`z \le 0` of the Newtonian frame.

:meth:`Model.ground(points, ...) <mbgen.model.builder.Model.ground>` calls
:func:`add_ground`, which writes the contact law below into ordinary loads of the model
(a :class:`~mbgen.model.elements.Force` at each point, and for a sphere a
:class:`~mbgen.model.elements.Torque` on its body), so every derivation, output and back
end (C, generated Python, lambdified sympy, Jacobians) carries it with nothing added
downstream, and records what it did as a :class:`~mbgen.model.elements.Ground`.

The law, per contact point :math:`P` with a sphere of radius :math:`\rho \ge 0` centred on
it (0: the point itself), fixed in the frame :math:`B`, with :math:`e_z` the Newtonian
frame's upward axis:

.. math::

    h = z_P - \rho, \qquad \dot h = \dot z_P, \qquad
    s = -k\,h - c\,\dot h, \qquad
    f_n = \begin{cases} s & h < 0 \text{ and } s > 0 \\ 0 & \text{otherwise,} \end{cases}

    v_t = (v_C \cdot e_x,\; v_C \cdot e_y), \qquad
    f_t = -\mu\, f_n\, \frac{v_t}{\sqrt{|v_t|^2 + v_s^2}}, \qquad
    F = f_{t,x}\,e_x + f_{t,y}\,e_y + f_n\,e_z,

with :math:`v_C = v_P + \omega_B \times (-\rho\, e_z)` the velocity of the body's material
point at the bottom of the sphere :math:`C = P - \rho\, e_z`.  The normal force is a
spring-damper that acts only while the sphere penetrates and only pushes (a Kelvin-Voigt
contact that never pulls, released as soon as it would: Hunt and Crossley without the
exponent).  The friction is Coulomb's, regularised: at :math:`|v_t| = v_s` it is 71 % of
:math:`\mu f_n`, at :math:`10\,v_s` 99.5 %; a body on the ground creeps at speeds of order
:math:`v_s` under a tangential load below :math:`\mu f_n` instead of sticking, and its
slope :math:`\mu f_n / v_s` at rest is the fastest time scale of a standing robot, which
is why a ground asks for an implicit integrator (:mod:`mbgen.runtime.simulate`).  ``F``
acts at :math:`C`: as a force at :math:`P` plus, for :math:`\rho > 0`, the moment
:math:`(-\rho\, e_z) \times F` on :math:`B` (the same generalized force).  The conditions
are a sympy ``Piecewise``: a C ternary, a Python conditional expression, and its
derivatives are the branch's on either side of the kink.

Energy.  With :math:`E = T + V + \sum \tfrac12 k \min(h, 0)^2` (kinetic, gravity and
springs, and the ground's spring while pressed), the ground's power is
:math:`f_n \dot h + k h \dot h + F_t \cdot v_t`: :math:`-c\,\dot h^2` while it pushes,
:math:`k h \dot h < 0` where it has let go while penetrating (then :math:`\dot h > -k h / c
> 0`), and friction's :math:`-\mu f_n |v_t|^2 / \sqrt{|v_t|^2 + v_s^2} \le 0`: a ground
never feeds energy in, so :math:`E` of a body dropped on it falls monotonically
(``tests/model/test_ground.py``).

Parameters, by name: the constants ``k_ground`` (N/m), ``c_ground`` (N s/m), ``mu`` and
``v_slip`` (m/s) (:data:`CONSTANTS`), declared with the values given as defaults (run-time
parameters: ``-p k_ground=2e4``), or any expression of the model's symbols given instead.
When ``k`` and ``c`` are not given they follow from the model's total mass :math:`M`
(numbers, or constants with defaults) shared by the :math:`n` points:
:math:`k = M g / (n\,\delta)` with :math:`\delta` = :data:`PENETRATION` (1 mm: the static
sinking under the weight at standard gravity :math:`g` = :data:`STANDARD_GRAVITY`) and
:math:`c = 2\sqrt{k M / n}`, critical damping of that share (no bounce; a drop bounces with
a smaller ``c``).  :data:`FRICTION` and :data:`SLIP_VELOCITY` are the other two defaults.
"""

from __future__ import annotations

import math
import numbers

import sympy as sm
from sympy.physics import vector as spv

from ..errors import ModelError
from ..names import did_you_mean
from .elements import Ground

#: What the law's constants are called when given as numbers.
CONSTANTS = {"k": "k_ground", "c": "c_ground", "mu": "mu", "slip": "v_slip"}

#: Static penetration (m) under the model's weight that sets the default stiffness.
PENETRATION = 1e-3

#: Gravity (m/s^2) the default stiffness and damping are computed with.
STANDARD_GRAVITY = 9.81

#: Default friction coefficient.
FRICTION = 1.0

#: Default velocity scale (m/s) of the regularised Coulomb friction.
SLIP_VELOCITY = 0.01

#: Default height (m) of a dropped robot's lowest contact above the ground.
DROP = 0.3


def normal_force(gap, rate, k, c):
    r""":math:`f_n` of the module docstring: ``-k gap - c rate`` where ``gap < 0`` and that is
    positive, else 0 (a ``Piecewise``)."""
    push = -k * gap - c * rate
    return sm.Piecewise((push, sm.And(sm.StrictLessThan(gap, 0), sm.StrictGreaterThan(push, 0))),
                        (0, True))


def contact_force(gap, rate, vx, vy, k, c, mu, slip) -> tuple:
    """``(F_x, F_y, F_z)`` of the module docstring from a contact's ``gap`` and its ``rate``,
    the tangential velocity ``(vx, vy)`` and the law's constants."""
    fn = normal_force(gap, rate, k, c)
    scale = -mu * fn / sm.sqrt(vx ** 2 + vy ** 2 + slip ** 2)
    return scale * vx, scale * vy, fn


def add_ground(model, points, *, k=None, c=None, mu=FRICTION, slip=SLIP_VELOCITY, radius=0.0,
               frames=None) -> Ground:
    """Give ``model`` the ground of the module docstring, touched by ``points`` (see
    :meth:`mbgen.model.builder.Model.ground`); returns the record it keeps."""
    if model.N is None:
        raise ModelError(f"model {model.name!r} has no Newtonian frame yet; call "
                         f"model.newtonian() before model.ground()")
    if getattr(model, "ground_", None) is not None:
        raise ModelError(f"model {model.name!r} already has a ground; give every contact "
                         f"point in one call of model.ground()")
    found = _points(model, points)
    radii = _radii(model, radius, len(found))
    bodies = _frames(model, found, radii, frames)
    if k is None or c is None:
        k0, c0 = default_stiffness(model, len(found))
        k, c = k0 if k is None else k, c0 if c is None else c
    law = _law(model, {"k": k, "c": c, "mu": mu, "slip": slip})
    N, gaps, rates = model.N, [], []
    for point, rho, body in zip(found, radii, bodies):
        r = point.pos_from(model.origin)
        v = r.dt(N)
        at = v if rho.is_zero else v + (body.ang_vel_in(N) ^ (-rho * N.z))
        gap, rate = r.dot(N.z) - rho, v.dot(N.z)
        fx, fy, fz = contact_force(gap, rate, at.dot(N.x), at.dot(N.y), law["k"], law["c"],
                                   law["mu"], law["slip"])
        force = fx * N.x + fy * N.y + fz * N.z
        model.force(point, force)
        if not rho.is_zero:
            model.torque(body, (-rho * N.z) ^ force)
        gaps.append(gap)
        rates.append(rate)
    record = Ground(tuple(found), tuple(radii), tuple(bodies), tuple(gaps), tuple(rates),
                    law["k"], law["c"], law["mu"], law["slip"])
    model.ground_ = record
    return record


def default_stiffness(model, n: int) -> tuple[float, float]:
    """``(k, c)`` of the module docstring for ``n`` points of ``model`` (its masses numbers)."""
    masses = [p.mass for p in model.particles] + [b.mass for b in model.bodies]
    defaults = {s: model.defaults_[str(s)] for s in model.constants_
                if str(s) in model.defaults_}
    try:
        total = float(sm.sympify(sum(masses)).xreplace(defaults))
    except TypeError:
        total = math.nan
    if not (total > 0 and math.isfinite(total)):
        raise ModelError(f"model.ground() of {model.name!r}: the default stiffness and damping "
                         f"follow from the total mass, which is not a positive number here "
                         f"({sum(masses) if masses else 'no masses yet'}); give k= and c=")
    share = total / n
    k = share * STANDARD_GRAVITY / PENETRATION
    return k, 2.0 * math.sqrt(k * share)


def heights(model, state, parameters=None) -> list[float]:
    """Each contact's height ``h`` above the ground (module docstring) in ``model`` at
    ``state`` (``{coordinate: value}``, others 0) with ``parameters`` (``{constant: value}``,
    others their defaults): where a scene places a robot to drop it."""
    record = getattr(model, "ground_", None)
    if record is None:
        raise ModelError(f"model {model.name!r} has no ground; call model.ground() first")
    values = {**model.defaults_, **dict(parameters or {})}
    table = {q: float(state.get(str(q.func), 0.0)) for q in model.coordinates_}
    table.update((s, values[str(s)]) for s in model.constants_ if str(s) in values)
    return [float(gap.xreplace(table)) for gap in record.gaps]


def free_height(model) -> str | None:
    """The coordinate that lifts a floating base: ``root_z`` (:func:`mbgen.from_urdf`), else
    the first ``<joint>_z`` beside a ``<joint>_qw`` (an MJCF free joint); None if neither."""
    names = [str(q.func) for q in model.coordinates_]
    if "root_z" in names:
        return "root_z"
    return next((n for n in names if n.endswith("_z") and n[:-2] + "_qw" in names), None)


def drop_state(model, state, drop: float = DROP, height: str | None = None) -> dict:
    """``state`` with the coordinate ``height`` (default :func:`free_height`: a floating
    base's vertical position) raised or lowered so that the lowest contact starts ``drop``
    above the ground."""
    if not (isinstance(drop, (int, float)) and math.isfinite(drop) and drop >= 0):
        raise ModelError(f"drop={drop!r}: give the starting height of the lowest contact "
                         f"above the ground, a finite number >= 0 (m)")
    height = free_height(model) if height is None else height
    if height not in {str(q.func) for q in model.coordinates_}:
        what = f"coordinate {height!r}" if height else \
            "floating base (root_z, or an MJCF free joint's <joint>_z)"
        raise ModelError(f"drop: model {model.name!r} has no {what} to lift")
    out = dict(state)
    out[height] = out.get(height, 0.0) + drop - min(heights(model, out))
    return out


def _points(model, points) -> list:
    items = [points] if isinstance(points, (str, spv.Point)) else list(points or ())
    if not items:
        raise ModelError("model.ground() needs at least one contact point (a point of the "
                         "model or its name)")
    by_name = {p.name: p for p in model.points}
    found = []
    for item in items:
        point = by_name.get(item) if isinstance(item, str) else item
        if point is None:
            listed = [n for n, p in by_name.items() if p is not model.origin]
            raise ModelError(f"model.ground(): model {model.name!r} has no point {item!r}"
                             f"{did_you_mean(item, listed)} (points: "
                             f"{', '.join(listed[:12]) or 'none'})")
        model._check_point(point)
        if point is model.origin:
            raise ModelError("model.ground(): the origin is fixed on the ground; name points "
                             "that move")
        if point in found:
            raise ModelError(f"model.ground(): point {point.name!r} is named twice")
        found.append(point)
    return found


def _radii(model, radius, n: int) -> list:
    values = list(radius) if isinstance(radius, (list, tuple)) else [radius] * n
    if len(values) != n:
        raise ModelError(f"model.ground(): {len(values)} radii for {n} points; give one "
                         f"radius, or one per point")
    out = []
    for value in values:
        rho = model._scalar(value, "a contact sphere's radius")
        if rho.is_number and not (rho.is_real and rho.is_finite and rho >= 0):
            raise ModelError(f"model.ground(): a sphere's radius must be a finite number >= 0, "
                             f"got {value!r}")
        out.append(sm.S.Zero if rho.is_zero else rho)   # 0.0 is no sphere (nor == 0)
    return out


def _frames(model, points, radii, frames) -> list:
    """The frame each point is fixed in (None where its radius is 0 and none was given)."""
    given = list(frames) if isinstance(frames, (list, tuple)) else [frames] * len(points)
    if len(given) != len(points):
        raise ModelError(f"model.ground(): {len(given)} frames for {len(points)} points")
    out = []
    for point, rho, frame in zip(points, radii, given):
        if frame is not None:
            model._check_frame(frame)
        elif not rho.is_zero:
            frame = body_frame(model, point)
        out.append(frame)
    return out


def body_frame(model, point) -> spv.ReferenceFrame:
    """The frame ``point`` is fixed in: the frame of the rigid body centred on it, else the
    deepest frame its chain of offsets uses, each of the others one of that frame's
    ancestors (else a :class:`ModelError` asking for it)."""
    centred = [b.frame for b in model.bodies if b.center is point]
    if centred:
        return centred[0]
    used, p = set(), point
    while model.points[p].parent is not None:
        used.update(frame for _, frame in model.points[p].offset.args)
        p = model.points[p].parent

    def chain(frame) -> list:
        out = [frame]
        while model.frames[out[-1]].parent is not None:
            out.append(model.frames[out[-1]].parent)
        return out
    deepest = max(used, key=lambda f: len(chain(f)), default=model.N)
    if not used <= set(chain(deepest)):
        raise ModelError(f"model.ground(): point {point.name!r} is placed along frames "
                         f"{', '.join(sorted(f.name for f in used))}, which are not one chain; "
                         f"give the frame its sphere is fixed in (frames=)")
    return deepest


def _law(model, given: dict) -> dict:
    """The law's constants (``given``: :data:`CONSTANTS`' keys to values), all checked
    before any is declared: a number becomes the constant :data:`CONSTANTS` ``[key]`` with it
    as default; anything else is an expression of the model's symbols."""
    numbers_given = {}
    for key, value in given.items():
        if isinstance(value, bool):
            raise ModelError(f"model.ground(): {key}={value!r} is not a number or an "
                             f"expression")
        if not isinstance(value, numbers.Real):
            continue
        number, positive, name = float(value), key == "slip", CONSTANTS[key]
        if not math.isfinite(number) or number < 0 or (positive and number == 0):
            raise ModelError(f"model.ground(): {key}={value!r}; give a finite number "
                             f"{'> 0' if positive else '>= 0'}")
        if name in {str(s) for s in model.constants_}:
            raise ModelError(f"model.ground(): model {model.name!r} already has a constant "
                             f"{name!r}; pass {key}={name} (or another expression) to use it")
        numbers_given[key] = number
    law = {key: model._scalar(value, f"the ground's {key}") for key, value in given.items()
           if key not in numbers_given}
    for key, number in numbers_given.items():
        law[key] = model.constants(CONSTANTS[key], defaults=[number])[0]
    return law


__all__ = ["CONSTANTS", "PENETRATION", "STANDARD_GRAVITY", "FRICTION", "SLIP_VELOCITY",
           "normal_force", "contact_force", "add_ground", "default_stiffness", "body_frame",
           "heights", "drop_state", "free_height", "DROP"]
