"""Multibody models in the SOPHIA style, on top of :mod:`sympy.physics.vector`.

A :class:`Model` collects what Kane's method needs:

* generalized coordinates ``q`` and speeds ``u`` (time-dependent symbols),
  constants (parameters) and inputs (forces or torques given at run time);
* the Newtonian frame ``N`` with its origin ``O``, and frames built from chains
  of simple rotations about axis 1, 2 or 3 (the lecture notes' ``&rot[N,B,3,q1]``
  and ``chainSimpRot([[N,B,3,phi],[B,S,2,theta]])``);
* points placed by an offset vector from a parent point, particles and rigid
  bodies (mass, inertia dyad about the mass centre in a body frame);
* loads: forces at points, torques on frames (with optional reactions), uniform
  gravity, linear springs and dampers between two points;
* kinematic differential equations (default ``u_i = q_i'``) and prescribed
  motions (angles or offsets that are given functions of time).

Frames are :class:`sympy.physics.vector.ReferenceFrame` objects and vectors are
:class:`sympy.physics.vector.Vector` objects, so everything sympy offers on them
(``express``, ``dot``, ``cross``, ``dt``, ``ang_vel_in``, ``dcm``) works on a
model's frames; :mod:`mbgen.model.kinematics` adds the SOPHIA-named helpers.
Each method appends a frozen record (:mod:`mbgen.model.elements`) after checking
its arguments and the model's size (:mod:`mbgen.model.limits`).

Example
-------
The pendulum hanging from a rotating disc (lecture 1, example 3)::

    m = Model("disc_pendulum")
    q1, q2 = m.coordinates("q1 q2")
    u1, u2 = m.speeds("u1 u2")
    s, l, g, mass = m.constants("s l g m")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)          # disc frame
    B = m.rotate(A, "B", 2, -q2)         # pendulum frame (hangs along -B.z)
    E = m.point("E", m.origin, s * A.x)   # suspension point on the disc
    P = m.point("P", E, -l * B.z)
    m.particle("bob", P, mass)
    m.gravity(-g * N.z)
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import sympy as sm
from sympy.physics import vector as spv

from ..errors import ModelError
from ..names import check_name, model_prefix
from .elements import (
    Armature,
    Bound,
    Constraint,
    Contact,
    Force,
    FrameDef,
    Gravity,
    Joint,
    LineElement,
    Particle,
    PointDef,
    RigidBody,
    Torque,
    armature_record,
    axis_index,
    bound_record,
    constant_defaults,
    contact_record,
    inertia_matrix,
)
from .expressions import expression
from .ground import FRICTION, SLIP_VELOCITY, add_ground
from .limits import MAX_BODIES, MAX_SPEEDS, check_count, guard_range
from .summary import model_html

#: The time symbol used by sympy.physics.vector's dynamicsymbols.
t = spv.dynamicsymbols._t


def _symbols(names, factory, what: str, force: bool = False) -> tuple:
    parts = [names] if isinstance(names, str) else \
        list(names) if isinstance(names, (list, tuple)) else None
    if parts is None or not all(isinstance(n, str) for n in parts):
        raise ModelError(f"{what} names must be a string such as 'q1 q2' or 'q1:3' (or a list of "
                         f"such strings); got {type(names).__name__}")
    out = []
    for part in parts:
        if what in ("coordinate", "speed") and not force:
            guard_range(part, what)
        try:
            made = factory(part)
        except ValueError:  # sympy: "no symbols given"
            made = ()
        out.extend(made if isinstance(made, (list, tuple)) else [made])
    out = tuple(out)
    if not out:
        raise ModelError(f"no {what} names in {names!r}; give e.g. 'q1 q2' or 'q1:3'")
    return out


class Model:
    """A multibody model under construction.

    Parameters
    ----------
    name : str
        Model name; it becomes the prefix of every generated C symbol, so it
        must follow the name rule (:mod:`mbgen.names`) and not be a C keyword.
    force : bool
        Build the model even when it has more than
        :data:`~mbgen.model.limits.MAX_SPEEDS` speeds or
        :data:`~mbgen.model.limits.MAX_BODIES` bodies (default: refuse with
        :class:`~mbgen.errors.ModelSizeError`).

    Notes
    -----
    Every name (of a frame, point, body, symbol, ...) must follow the name
    rule of :mod:`mbgen.names`.  Every value may be a number, a sympy
    expression, or a string such as ``"k*l/2"``, which is parsed without
    ``eval`` against the model's own symbols (:mod:`mbgen.model.expressions`).
    Every ``add`` method validates its arguments at once (unknown frames or
    points, wrong types, a body without inertia) and raises
    :class:`~mbgen.errors.ModelError` naming the problem.  Derivation
    (:func:`mbgen.derive`) then checks that every symbol in the model is a
    declared coordinate, speed, constant or input.
    """

    def __init__(self, name: str, *, force: bool = False):
        self.name = check_name(name, "model")
        self.prefix = model_prefix(name)
        self.force_size = bool(force)
        self.coordinates_: list[sm.Function] = []
        self.speeds_: list[sm.Function] = []
        self.constants_: list[sm.Symbol] = []
        self.inputs_: list[sm.Function] = []
        self.frames: dict[spv.ReferenceFrame, FrameDef] = {}
        self.points: dict[spv.Point, PointDef] = {}
        self.particles: list[Particle] = []
        self.bodies: list[RigidBody] = []
        self.loads: list[Force | Torque | Gravity | LineElement] = []
        self.kinematic_equations_: list[sm.Expr] = []
        self.prescribed_: dict[str, sm.Expr] = {}
        self.joints_: list[Joint] = []
        self.armatures_: list[Armature] = []
        self.contacts_: list[Contact] = []
        self.constraints_: list[Constraint] = []
        self.defaults_: dict[str, float] = {}     # constant name -> default value
        self.bounds_: dict[str, Bound] = {}       # name -> its range (data only)
        self.ground_ = None                       # Ground record (model.ground)
        self._names: set[str] = set()
        self.N: spv.ReferenceFrame | None = None
        self.origin: spv.Point | None = None

    # ----------------------------------------------------------------- symbols
    def coordinates(self, names: str):
        """Declare generalized coordinates (functions of time), ``sympy.symbols`` syntax.

        ``m.coordinates("q1 q2")`` and ``m.coordinates("q1:3")`` return a tuple;
        a single name returns a tuple of one (unpack it: ``q, = m.coordinates("q")``).
        """
        syms = _symbols(names, spv.dynamicsymbols, "coordinate", self.force_size)
        check_count(self.name, len(self.coordinates_) + len(syms), "coordinates", MAX_SPEEDS,
                    self.force_size)
        self._claim((str(s.func) for s in syms), "coordinate")
        self.coordinates_.extend(syms)
        return syms

    def speeds(self, names: str):
        """Declare generalized speeds (functions of time); see :meth:`coordinates`."""
        syms = _symbols(names, spv.dynamicsymbols, "speed", self.force_size)
        check_count(self.name, len(self.speeds_) + len(syms), "speeds", MAX_SPEEDS,
                    self.force_size)
        self._claim((str(s.func) for s in syms), "speed")
        self.speeds_.extend(syms)
        return syms

    def constants(self, names: str, defaults=None):
        """Declare constant parameters (plain symbols); see :meth:`coordinates`.  ``defaults``
        (a number per name) are their values where none is given (compiled code, ``rhs``)."""
        syms = _symbols(names, sm.symbols, "constant")
        values = constant_defaults(syms, defaults)
        self._claim((str(s) for s in syms), "constant")
        self.constants_.extend(syms)
        self.defaults_.update(values)
        return syms

    def bound(self, symbol, lower=None, upper=None) -> Bound:
        """Record that a coordinate, speed or input stays in ``[lower, upper]`` (None: no bound
        that way), e.g. a URDF ``<limit>``: data the equations never use (:meth:`bounds`)."""
        record = bound_record(self, symbol, lower, upper)
        self.bounds_[record.name] = record
        return record

    def bounds(self, kind: str = "inputs") -> dict[str, tuple[float, float]]:
        """``{name: (lower, upper)}`` of the bounded inputs (or "coordinates", "speeds")."""
        return {b.name: (b.lower, b.upper) for b in self.bounds_.values() if b.kind == kind}

    def inputs(self, names: str):
        """Declare inputs: forces or torques given at run time (functions of time)."""
        syms = _symbols(names, spv.dynamicsymbols, "input")
        self._claim((str(s.func) for s in syms), "input")
        self.inputs_.extend(syms)
        return syms

    def prescribed(self, name: str, expression) -> sm.Expr:
        """Record a prescribed motion: a quantity that is a given function of time.

        Returns ``expression`` (a sympy expression in ``mbgen.model.builder.t`` and
        constants) so it can be used as a rotation angle or in an offset.
        Example: a wire spun at constant rate, ``m.rotate(N, "B", 3,
        m.prescribed("theta", omega * t))``.
        """
        check_name(name, "prescribed motion")
        expr = self._scalar(expression, f"prescribed motion {name!r}")
        if name in self.prescribed_:
            raise ModelError(f"prescribed motion {name!r} is already defined")
        self.prescribed_[name] = expr
        return expr

    def _claim(self, names: Iterable[str], what: str) -> None:
        for n in names:
            check_name(n, what)
            if n in self._names:
                raise ModelError(f"the name {n!r} is already used in model {self.name!r}; "
                                 f"every coordinate, speed, constant, input, frame and point "
                                 f"needs its own name")
            self._names.add(n)

    # ------------------------------------------------------------------ frames
    def newtonian(self, name: str = "N", origin: str = "O") -> spv.ReferenceFrame:
        """Create the Newtonian (inertial) frame and its origin point."""
        if self.N is not None:
            raise ModelError(f"model {self.name!r} already has a Newtonian frame {self.N}")
        self._claim([name], "frame")
        self._claim([origin], "point")
        self.N = spv.ReferenceFrame(name)
        self.frames[self.N] = FrameDef(self.N, None, None, None)
        self.origin = spv.Point(origin)
        self.origin.set_vel(self.N, 0)
        self.points[self.origin] = PointDef(self.origin, None, spv.Vector(0))
        return self.N

    def rotate(self, parent: spv.ReferenceFrame, name: str, axis, angle) -> spv.ReferenceFrame:
        """Create frame ``name`` by a simple rotation of ``parent``
        (SOPHIA ``&rot[P,B,axis,angle]``).

        Parameters
        ----------
        parent : ReferenceFrame
            A frame of this model.
        name : str
            Name of the new frame.
        axis : {1, 2, 3}
            Rotation axis, shared by ``parent`` and the new frame.
        angle : sympy expression
            Rotation angle: a coordinate, a constant, or a function of time.

        Returns
        -------
        ReferenceFrame
            The new frame; ``parent.dcm(frame)`` is the lecture notes' ``R_PB``
            (its columns are the new basis vectors in ``parent`` components).
        """
        self._check_frame(parent)
        k = axis_index(axis)
        angle = self._scalar(angle, f"angle of frame {name!r}")
        self._claim([name], "frame")
        unit = (parent.x, parent.y, parent.z)[k - 1]
        frame = parent.orientnew(name, "Axis", [angle, unit])
        self.frames[frame] = FrameDef(frame, parent, k, angle)
        return frame

    def chain_rotations(self, chain: Sequence[Sequence]) -> tuple[spv.ReferenceFrame, ...]:
        """Build frames from a chain of simple rotations (SOPHIA ``chainSimpRot``).

        ``chain`` lists ``[parent, name, axis, angle]`` rows; ``parent`` may be a
        frame or the name of a frame created earlier in the same chain::

            B, S = m.chain_rotations([[N, "B", 3, phi], ["B", "S", 2, theta]])
        """
        made: dict[str, spv.ReferenceFrame] = {}
        out = []
        for row in chain:
            if len(row) != 4:
                raise ModelError(f"chain row {row!r} must be [parent, name, axis, angle]")
            parent, name, axis, angle = row
            if isinstance(parent, str):
                parent = made.get(parent) or self.frame(parent)
            frame = self.rotate(parent, name, axis, angle)
            made[name] = frame
            out.append(frame)
        return tuple(out)

    def orient(self, parent: spv.ReferenceFrame, name: str, dcm, rates, *,
               relative: bool = False) -> spv.ReferenceFrame:
        """Frame ``name`` turned from ``parent`` by the matrix ``dcm`` (``R_PF``: its columns
        are the new basis in ``parent`` components, functions of the coordinates), with
        angular velocity in N of components ``rates`` in the new frame (body rates, e.g.
        three speeds; ``relative=True``: in ``parent``, i.e. ``parent``'s own added, as for
        a ball joint); the kinematic equations that relate them are the caller's
        (:meth:`kinematics`).  A floating base's quaternion is one use (``from_urdf``)."""
        self._check_frame(parent)
        R = sm.ImmutableMatrix(3, 3, [self._scalar(v, f"rotation of frame {name!r}")
                                      for v in sm.Matrix(dcm)])
        w = [self._scalar(v, f"angular velocity of frame {name!r}") for v in rates]
        self._claim([name], "frame")
        frame = parent.orientnew(name, "DCM", R)
        omega = w[0] * frame.x + w[1] * frame.y + w[2] * frame.z
        if relative:
            omega = parent.ang_vel_in(self.N) + omega
        self.frames[frame] = FrameDef(frame, parent, None, None, omega, R)
        frame.set_ang_vel(self.N, omega)
        return frame

    def frame(self, name: str) -> spv.ReferenceFrame:
        """Return the model's frame called ``name``."""
        for f in self.frames:
            if f.name == name:
                return f
        raise ModelError(f"model {self.name!r} has no frame {name!r}; "
                         f"frames: {', '.join(f.name for f in self.frames) or 'none'}")

    def angular_velocity(self, frame: spv.ReferenceFrame, vector: spv.Vector) -> None:
        """Set the angular velocity of ``frame`` in N to ``vector`` (e.g. body rates).

        The usual use is speeds defined as body-fixed angular-velocity components,
        ``m.angular_velocity(B, u1*B.x + u2*B.y + u3*B.z)``.  mbgen adds
        ``omega_chain(q, q') . b_i = vector . b_i`` (i = 1, 2, 3) to the kinematic
        equations, where ``omega_chain`` is the angular velocity implied by the
        frame's chain of simple rotations; do not also give kinematics for the
        chain's angles.
        """
        self._check_frame(frame)
        self._check_vector(vector, f"angular velocity of {frame}")
        fd = self.frames[frame]
        if fd.parent is None:
            raise ModelError("the Newtonian frame cannot be given an angular velocity")
        chain = frame.ang_vel_in(self.N)
        self.frames[frame] = FrameDef(fd.frame, fd.parent, fd.axis, fd.angle, vector)
        self.kinematic_equations_.extend(
            (chain - vector).dot(e) for e in (frame.x, frame.y, frame.z))
        frame.set_ang_vel(self.N, vector)

    # ------------------------------------------------------------------ points
    def point(self, name: str, parent: spv.Point | None = None, offset=0) -> spv.Point:
        """Place point ``name`` at ``offset`` (a vector) from ``parent`` (default: origin)."""
        parent = self.origin if parent is None else parent
        self._check_point(parent)
        offset = spv.Vector(0) if offset == 0 else offset
        self._check_vector(offset, f"offset of point {name!r}")
        self._claim([name], "point")
        p = parent.locatenew(name, offset)
        self.points[p] = PointDef(p, parent, offset)
        return p

    def particle(self, name: str, point: spv.Point, mass) -> Particle:
        """Add a point mass ``mass`` at ``point``."""
        self._check_point(point)
        mass = self._scalar(mass, f"mass of particle {name!r}")
        check_count(self.name, len(self.particles) + len(self.bodies) + 1, "particles and bodies",
                    MAX_BODIES, self.force_size)
        self._claim([name], "particle")
        p = Particle(name, point, mass)
        self.particles.append(p)
        return p

    def body(self, name: str, frame: spv.ReferenceFrame, mass, inertia,
             center: spv.Point) -> RigidBody:
        """Add a rigid body fixed in ``frame`` with mass centre ``center``.

        Parameters
        ----------
        inertia : Dyadic, 3x3 matrix, or tuple
            Inertia about the mass centre: a sympy ``Dyadic`` (any frames), a
            3x3 matrix in ``frame`` components, or ``(Ixx, Iyy, Izz[, Ixy, Iyz,
            Izx])`` in ``frame`` components.
        """
        self._check_frame(frame)
        self._check_point(center)
        mass = self._scalar(mass, f"mass of body {name!r}")
        matrix = inertia_matrix(name, frame, inertia,
                                lambda v: self._scalar(v, f"inertia of body {name!r}"))
        check_count(self.name, len(self.particles) + len(self.bodies) + 1, "particles and bodies",
                    MAX_BODIES, self.force_size)
        self._claim([name], "body")
        b = RigidBody(name, frame, center, mass, matrix)
        self.bodies.append(b)
        return b

    # ------------------------------------------------------------------- loads
    def force(self, point: spv.Point, vector: spv.Vector,
              reaction: spv.Point | None = None) -> Force:
        """Apply ``vector`` at ``point`` (and ``-vector`` at ``reaction`` if given)."""
        self._check_point(point)
        if reaction is not None:
            self._check_point(reaction)
        self._check_vector(vector, f"force at {point}")
        f = Force(point, vector, reaction)
        self.loads.append(f)
        return f

    def torque(self, frame: spv.ReferenceFrame, vector: spv.Vector,
               reaction: spv.ReferenceFrame | None = None) -> Torque:
        """Apply torque ``vector`` to ``frame`` (and ``-vector`` to ``reaction`` if given)."""
        self._check_frame(frame)
        if reaction is not None:
            self._check_frame(reaction)
        self._check_vector(vector, f"torque on {frame}")
        tq = Torque(frame, vector, reaction)
        self.loads.append(tq)
        return tq

    def gravity(self, vector: spv.Vector) -> Gravity:
        """Uniform gravity: every particle and body gets ``mass * vector`` at its centre."""
        self._check_vector(vector, "gravity")
        if any(isinstance(ld, Gravity) for ld in self.loads):
            raise ModelError("gravity is already set for this model")
        g = Gravity(vector)
        self.loads.append(g)
        return g

    def spring(self, name: str, a: spv.Point, b: spv.Point, stiffness, natural_length=0,
               damping=0) -> LineElement:
        """A linear spring (and optional damper) between points ``a`` and ``b``."""
        return self._line(name, a, b, stiffness, damping, natural_length)

    def damper(self, name: str, a: spv.Point, b: spv.Point, damping) -> LineElement:
        """A linear damper between ``a`` and ``b`` (force ``-c L'`` along the line)."""
        return self._line(name, a, b, 0, damping, 0)

    def _line(self, name, a, b, stiffness, damping, natural_length) -> LineElement:
        self._check_point(a)
        self._check_point(b)
        if a is b:
            raise ModelError(f"line element {name!r} joins point {a} to itself")
        el = LineElement(name, a, b,
                         self._scalar(stiffness, f"stiffness of {name!r}"),
                         self._scalar(damping, f"damping of {name!r}"),
                         self._scalar(natural_length, f"natural length of {name!r}"))
        self._claim([name], "line element")
        self.loads.append(el)
        return el

    def ground(self, points, *, k=None, c=None, mu=FRICTION, slip=SLIP_VELOCITY, radius=0.0,
               frames=None):
        """A compliant ground ``z <= 0`` under ``points`` (points or names; one call): per
        point (a sphere of ``radius``), the normal force ``max(0, -k h - c h')`` while its
        height ``h`` is negative and the friction ``-mu f_n v_t / sqrt(|v_t|^2 + slip^2)``,
        as loads (:mod:`mbgen.model.ground`: the law, energy, defaults).  Numbers become
        the parameters ``k_ground``, ``c_ground``, ``mu``, ``v_slip``; ``k``, ``c`` left out
        follow from the mass; ``frames``: where each sphere is fixed, if not inferred.
        Returns the :class:`~mbgen.model.elements.Ground` record (``model.ground_``)."""
        return add_ground(self, points, k=k, c=c, mu=mu, slip=slip, radius=radius,
                          frames=frames)

    # ------------------------------------------------------------------ joints
    def joint(self, child, parent=None, point: spv.Point | None = None, *,
              frame: spv.ReferenceFrame | None = None, name: str | None = None) -> Joint:
        """State the joint of ``child`` (a particle or rigid body, or its name).

        Joints are inferred from the frame and point tree (a body hangs from the
        nearest body in which a point of its chain is fixed); state one where the
        inference is ambiguous, to name it, or to report its reaction in another
        frame.  The joint's free motion is whatever the rotations and offsets
        between parent and child allow; nothing here constrains it.

        Parameters
        ----------
        child : Particle, RigidBody or str
        parent : Particle, RigidBody, str, the Newtonian frame, or None
            The body the child hangs from; the Newtonian frame for the ground;
            None to infer it.
        point : Point, optional
            The joint point, fixed in the child (default: inferred).
        frame : ReferenceFrame, optional
            Frame of the reaction components (default: the child's frame).
        name : str, optional
            Joint name (default: the child's name); names the rows of the
            ``reactions`` output.
        """
        child_name = self._mass_name(child, "child")
        if parent is not None and parent is not self.N:
            parent = self._mass_name(parent, "parent")
            if parent == child_name:
                raise ModelError(f"joint of {child_name!r}: a body cannot hang from itself")
        if point is not None:
            self._check_point(point)
        if frame is not None:
            self._check_frame(frame)
        if any(j.child == child_name for j in self.joints_):
            raise ModelError(f"the joint of {child_name!r} is already stated")
        name = child_name if name is None else check_name(name, "joint")
        if any(j.name == name for j in self.joints_):
            raise ModelError(f"a joint named {name!r} already exists")
        j = Joint(name, child_name, parent, point, frame)
        self.joints_.append(j)
        return j

    def armature(self, speed, value) -> Armature:
        """Add the generalized inertia ``value`` to the speed ``speed`` alone: a joint's
        armature (a geared rotor's reflected inertia, MuJoCo's ``dof_armature``).

        The mass matrix gets ``value`` on its diagonal entry of ``speed`` (and the kinetic
        energy ``value * speed**2 / 2``), as if a rotor of that inertia turned with the
        speed and with nothing else.  ``value`` is a number >= 0 or an expression in
        constants; ``speed`` a speed of the model (or its name), one armature each.
        Every derivation keeps it on the joint's diagonal (Newton–Euler inside the
        recursion), so it costs no joint tree of its own.
        """
        record = armature_record(self, speed, value)
        self.armatures_.append(record)
        return record

    def _mass_name(self, element, what: str) -> str:
        names = [p.name for p in self.particles] + [b.name for b in self.bodies]
        name = element if isinstance(element, str) else getattr(element, "name", None)
        if name not in names or (not isinstance(element, str) and
                                 element not in self.particles + self.bodies):
            raise ModelError(f"joint {what} {element!r} is not a particle or rigid body of model "
                             f"{self.name!r}; bodies: {', '.join(names) or 'none'}")
        return name

    # -------------------------------------------------------------- kinematics
    def kinematics(self, mapping: Mapping) -> None:
        """Give the kinematic differential equations explicitly: ``{q_i: q_i'(q, u, t)}``."""
        for q, rhs in mapping.items():
            if q not in self.coordinates_:
                raise ModelError(f"{q} is not a coordinate of model {self.name!r}")
            self.kinematic_equations_.append(
                q.diff(t) - self._scalar(rhs, f"kinematic equation of {q}"))

    def kinematic_equations(self, equations: Iterable) -> None:
        """Give kinematic differential equations implicitly: expressions in q, q', u, t that vanish.

        They must be linear in the q'.  Example: ``[q1.diff(t) - u1, q2.diff(t) - u2/q1]``.
        """
        self.kinematic_equations_.extend(self._scalar(e, "kinematic equation")
                                         for e in equations)

    # ------------------------------------------------------------- constraints
    def holonomic(self, expressions, dependent, *, speeds=None, names=None) -> tuple:
        """Configuration constraints ``f_h(q, t) = 0``, one dependent coordinate each.

        Their time derivative constrains the speeds too; each holonomic
        constraint makes one speed dependent: ``speeds`` (default: the speed
        ``u`` with ``q' = u`` of each dependent coordinate).  Dependent
        coordinates stay in the state (the C integrators project them back onto
        the constraint after every step); dependent speeds are computed from the
        constraints and are not states.  ``names`` name the constraints' forces
        (default ``<dependent>_constraint``).

        Example: close a four-bar loop, ``m.holonomic([xc - xr, yc - yr], [q2, q3])``.
        """
        exprs, deps = self._listed(expressions), self._listed(dependent)
        spds = [None] * len(exprs) if speeds is None else self._listed(speeds)
        if len(deps) != len(exprs) or len(spds) != len(exprs):
            raise ModelError(f"{len(exprs)} holonomic constraint(s) need as many dependent "
                             f"coordinates (got {len(deps)}) and speeds (got {len(spds)})")
        for q in deps:
            if q not in self.coordinates_:
                raise ModelError(f"dependent coordinate {q} is not a coordinate of model "
                                 f"{self.name!r}; declare it with model.coordinates()")
        for u in spds:
            if u is not None and u not in self.speeds_:
                raise ModelError(f"dependent speed {u} is not a speed of model {self.name!r}")
        out = []
        for k, (e, q, u) in enumerate(zip(exprs, deps, spds)):
            name = self._constraint_name(names, k, f"{q.func}_constraint")
            out.append(self._add_constraint(Constraint(name, "holonomic", self._constraint_expr(
                e, name), q, u)))
        return tuple(out)

    def nonholonomic(self, expressions, dependent, *, names=None) -> tuple:
        """Motion constraints ``f_n(q, u, t) = 0``, linear in the speeds, one dependent speed each.

        ``q'`` may appear in them (it is replaced by the kinematic equations).
        The dependent speeds are computed from the constraints; they are not
        states.  ``names`` name the constraints' forces (multipliers).
        """
        exprs, deps = self._listed(expressions), self._listed(dependent)
        if len(deps) != len(exprs):
            raise ModelError(f"{len(exprs)} motion constraint(s) need as many dependent speeds "
                             f"(got {len(deps)})")
        for u in deps:
            if u not in self.speeds_:
                raise ModelError(f"dependent speed {u} is not a speed of model {self.name!r}; "
                                 f"declare it with model.speeds()")
        out = []
        for k, (e, u) in enumerate(zip(exprs, deps)):
            name = self._constraint_name(names, k, f"{u.func}_constraint")
            out.append(self._add_constraint(Constraint(name, "motion", self._constraint_expr(
                e, name), u)))
        return tuple(out)

    def no_slip(self, point: spv.Point, body, dependent, *,
                frame: spv.ReferenceFrame | None = None, axes=(1, 2, 3),
                name: str | None = None) -> tuple:
        """Rolling without slip: the point of ``body`` at ``point`` has zero velocity in ``frame``.

        ``point`` is where the body touches (it may move over the body, as the
        contact point of a wheel does); the constrained velocity is that of the
        body's material point there, ``v_G + w_body x (r_point - r_G)``.  One
        motion constraint ``v . e_k = 0`` per axis ``k`` of ``frame`` (default the
        Newtonian frame), one dependent speed each (in the order of ``axes``).
        Its multiplier is the force the ground exerts on the body at ``point``
        along ``e_k`` (``constraint_forces``), and it enters the joint reactions.

        Parameters
        ----------
        body : RigidBody or Particle
            The rolling body (a particle: its own point).
        """
        self._check_point(point)
        if body not in self.bodies + self.particles:
            raise ModelError(f"no_slip: {body!r} is not a rigid body or particle of model "
                             f"{self.name!r}")
        frame = self.N if frame is None else frame
        self._check_frame(frame)
        axes = [axis_index(a) for a in self._listed(axes)]
        deps = self._listed(dependent)
        if len(deps) != len(axes):
            raise ModelError(f"no_slip at {point} over {len(axes)} axes needs {len(axes)} "
                             f"dependent speeds, got {len(deps)}")
        base = f"{point.name}_contact" if name is None else check_name(name, "constraint")
        out = []
        for k, u in zip(axes, deps):
            if u not in self.speeds_:
                raise ModelError(f"dependent speed {u} is not a speed of model {self.name!r}")
            cname = f"{base}_{'xyz'[k - 1]}"
            out.append(self._add_constraint(Constraint(cname, "motion", None, u, None, (point,),
                                                       frame, k, body)))
        return tuple(out)

    def coincident(self, a: spv.Point, b: spv.Point, dependent, *,
                   frame: spv.ReferenceFrame | None = None, axes=(1, 2, 3), speeds=None,
                   name: str | None = None) -> tuple:
        """Close a loop: points ``a`` and ``b`` coincide along ``axes`` of ``frame`` (holonomic).

        One configuration constraint ``(r_a - r_b) . e_k = 0`` per axis, one
        dependent coordinate (and speed, see :meth:`holonomic`) each.  Its
        multiplier is the force on the body holding ``a`` along ``e_k`` (the body
        holding ``b`` gets the opposite), and it enters the joint reactions.
        """
        self._check_point(a)
        self._check_point(b)
        frame = self.N if frame is None else frame
        self._check_frame(frame)
        axes = [axis_index(x) for x in self._listed(axes)]
        deps = self._listed(dependent)
        spds = [None] * len(axes) if speeds is None else self._listed(speeds)
        if len(deps) != len(axes) or len(spds) != len(axes):
            raise ModelError(f"coincident {a} and {b} over {len(axes)} axes needs {len(axes)} "
                             f"dependent coordinates and speeds")
        base = f"{a.name}_{b.name}" if name is None else check_name(name, "constraint")
        out = []
        for k, q, u in zip(axes, deps, spds):
            if q not in self.coordinates_:
                raise ModelError(f"dependent coordinate {q} is not a coordinate of model "
                                 f"{self.name!r}")
            cname = f"{base}_{'xyz'[k - 1]}"
            out.append(self._add_constraint(Constraint(cname, "holonomic", None, q, u, (a, b),
                                                       frame, k)))
        return tuple(out)

    def contact(self, point: spv.Point, *, name: str | None = None, anchor=None) -> Contact:
        r"""Hold ``point`` fixed in the Newtonian frame: a rigid 3D point contact (a foot).

        Unlike the constraints above it makes no speed dependent: every speed stays a
        state and the contact acts on the accelerations, :math:`J u' + \gamma = -k_d v -
        k_p (r - r_0)` with the point's velocity ``v = J u`` and position ``r`` in N
        (Pinocchio's ``CONTACT_3D`` in ``LOCAL_WORLD_ALIGNED``).  Its force, the one the
        ground exerts on the model at the point in N components, is three rows of
        ``constraint_forces`` (contacts in the order stated).  Declares the constants
        ``<name>_x0, <name>_y0, <name>_z0`` (the anchor :math:`r_0`, default ``anchor``
        or the origin) and, with the first contact, the Baumgarte gains ``contact_kp`` and
        ``contact_kd`` (default 0: no correction).  See :mod:`mbgen.derivation.contacts`.
        """
        name = None if name is None else check_name(name, "contact")
        record = contact_record(self, point, name, anchor)
        self.contacts_.append(record)
        return record

    @staticmethod
    def _listed(value) -> list:
        if isinstance(value, (list, tuple)):
            return list(value)
        if isinstance(value, sm.MatrixBase):
            return list(value)
        return [value]

    def _constraint_name(self, names, k, default) -> str:
        if names is None:
            return default
        names = self._listed(names)
        if len(names) <= k:
            raise ModelError(f"names= must give one name per constraint; got {len(names)}")
        return check_name(names[k], "constraint")

    def _constraint_expr(self, expr, name):
        if isinstance(expr, str):
            raise ModelError(f"constraint {name!r} must be a sympy expression of the model's "
                             f"symbols, not the string {expr!r}")
        if isinstance(expr, sm.Equality):
            expr = expr.lhs - expr.rhs
        value = self._scalar(expr, f"constraint {name!r}")
        if value == 0:
            raise ModelError(f"constraint {name!r} is identically zero")
        return value

    def _add_constraint(self, c: Constraint) -> Constraint:
        if any(x.name == c.name for x in self.constraints_):
            raise ModelError(f"a constraint named {c.name!r} already exists; pass names=")
        if c.kind == "holonomic" and any(x.kind == "holonomic" and x.dependent == c.dependent
                                         for x in self.constraints_):
            raise ModelError(f"{c.dependent} is already the dependent coordinate of a constraint")
        self.constraints_.append(c)
        return c

    # ------------------------------------------------------------- validation
    def _check_frame(self, frame) -> None:
        if not isinstance(frame, spv.ReferenceFrame):
            raise ModelError(f"expected a ReferenceFrame, got {frame!r}")
        if frame not in self.frames:
            raise ModelError(f"frame {frame} is not part of model {self.name!r}; create it "
                             f"with model.newtonian() or model.rotate()")

    def _check_point(self, point) -> None:
        if not isinstance(point, spv.Point):
            raise ModelError(f"expected a Point, got {point!r}")
        if point not in self.points:
            raise ModelError(f"point {point} is not part of model {self.name!r}; create it "
                             f"with model.point()")

    def _check_vector(self, vector, what: str) -> None:
        if isinstance(vector, (int, float)) and vector == 0:
            return
        if not isinstance(vector, spv.Vector):
            raise ModelError(f"{what} must be a sympy.physics.vector Vector, got {vector!r}")
        for _, frame in vector.args:
            if frame not in self.frames:
                raise ModelError(f"{what} uses frame {frame}, which is not part of model "
                                 f"{self.name!r}")

    def symbol_table(self) -> dict:
        """Names an expression string may use: every symbol of the model, and ``t``."""
        table = {str(s.func): s for s in self.coordinates_ + self.speeds_ + self.inputs_}
        table.update((str(s), s) for s in self.constants_)
        table.setdefault("t", t)
        return table

    def _scalar(self, value, what: str) -> sm.Expr:
        """``value`` (number, sympy expression, or string parsed without eval) as a scalar."""
        if isinstance(value, (spv.Vector, sm.MatrixBase, spv.Dyadic)):
            raise ModelError(f"{what} must be a scalar, got {type(value).__name__} {value!r}")
        expr = expression(value, self.symbol_table(), what)
        if not isinstance(expr, sm.Expr):
            raise ModelError(f"{what} must be a scalar, got {value!r}")
        return expr

    # --------------------------------------------------------------- summary
    def __repr__(self) -> str:
        return (f"Model({self.name!r}: {len(self.coordinates_)} coordinates, "
                f"{len(self.speeds_)} speeds, {len(self.constants_)} constants, "
                f"{len(self.frames)} frames, {len(self.points)} points, "
                f"{len(self.particles)} particles, {len(self.bodies)} bodies, "
                f"{len(self.loads)} loads)")

    def _repr_html_(self) -> str:
        """Notebook summary: sizes and names, never expressions (:mod:`mbgen.model.summary`)."""
        return model_html(self)
