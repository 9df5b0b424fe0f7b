r"""A MuJoCo model as a :class:`~mbgen.model.builder.Model`: :func:`from_mjcf`, :func:`from_mujoco`.

MuJoCo's own compiler reads the file (the ``mujoco`` extra: ``pip install 'mbgen[mujoco]'``),
so defaults, classes, ``<compiler>`` units and angles, and inertia from geoms are resolved
as MuJoCo resolves them; this module reads the compiled ``mjModel``: the body tree
(``body_parentid``, ``body_pos``, ``body_quat``, ``body_ipos``, ``body_iquat``,
``body_mass``, ``body_inertia``), the joints (``jnt_type``, ``jnt_axis``, ``jnt_pos``,
``qpos0``, ``jnt_stiffness``, ``qpos_spring``, ``dof_armature``, ``dof_damping``); what
else changes the dynamics (gravity and its flag, actuators, ...) is honoured, refused or
dropped with one warning by :mod:`~mbgen.model.mjcf_physics`.  :func:`from_mjcf` names
the model after the file (``cartpole.xml``: ``cartpole``), :func:`from_mujoco` after
``<mujoco model>`` unless given a name.

Conventions (MuJoCo's, so that a state compares one to one with ``mj_forward``):

* coordinates, speeds and inputs in MuJoCo's ``qpos``, ``qvel`` and ``qfrc_applied``
  order (joint by joint, in the order of the file).  For a joint ``<j>`` (its name
  sanitised to an identifier; ``joint<k>`` when it has none):

  =====  ===========================  =======================  ===========================
  type   coordinates                  speeds                   inputs (generalized forces)
  =====  ===========================  =======================  ===========================
  hinge  ``q_<j>``                    ``u_<j>``                ``tau_<j>``
  slide  ``q_<j>``                    ``u_<j>``                ``tau_<j>``
  ball   ``q_<j>_qw, _qx, _qy, _qz``  ``u_<j>_wx, _wy, _wz``   ``tau_<j>_tx, _ty, _tz``
  free   ``q_<j>_x, _y, _z``, then    ``u_<j>_vx, _vy, _vz``,  ``tau_<j>_fx, _fy, _fz``,
         ``q_<j>_qw, _qx, _qy, _qz``  ``u_<j>_wx, _wy, _wz``   ``tau_<j>_tx, _ty, _tz``
  =====  ===========================  =======================  ===========================

  A quaternion is MuJoCo's ``(w, x, y, z)``: a ball joint's turns the body from its
  reference orientation, a free joint's is the body's orientation in the world.  A ball
  joint's speeds (and a free joint's ``w``) are the angular velocity relative to the
  parent, in the body's own components; a free joint's ``v`` is the velocity of the
  body's origin in **world** components (MuJoCo's; the URDF free-flyer, Pinocchio's, has
  it in the body's components).  So ``q' = u`` for hinge and slide, ``(x, y, z)' = v``
  and :math:`\dot q = \tfrac12 q \otimes (0, \omega)` for the quaternions, which are
  normalised where read (the rotation matrix divides by :math:`|q|^2`).  Hinge and
  slide angles count from ``qpos0`` (a joint's ``ref``), as in MuJoCo.
* the inputs are MuJoCo's ``qfrc_applied``: a torque about a hinge axis, a force along a
  slide; a ball joint's torque in the body's components; a free joint's force at the
  body's origin in world components and its torque in body components.  Then MuJoCo's
  ``ctrl`` of each actuator read (:class:`~mbgen.model.mjcf_physics.Actuator`), in the
  file's order, named ``ctrl_<actuator>``, never clamped: so ``r = (qfrc_applied, ctrl)``.
* passive forces as MuJoCo states them: damping :math:`-d\,u` per degree of freedom
  (``dof_damping``), hinge and slide springs :math:`-k\,(q - q_\mathrm{spring})`; joint
  armature (``dof_armature``, with the actuators' reflected through their gear) adds to
  the diagonal of the mass matrix, :meth:`Model.armature <mbgen.Model.armature>` on the
  joint's speed (a rotor inertia that sees no other motion: no body of its own, so the
  Newton–Euler tree stays the file's).
* gravity ``g`` times the direction of ``opt.gravity``, ``g = |opt.gravity|`` the model's
  one constant (none, and ``g = 0``, under ``<flag gravity="disable"/>``); every inertial
  number is baked in.  Bodies without joints are welded to
  their parent and their masses merged, as fixed URDF joints are.

Dropped with one :class:`~mbgen.errors.ModelWarning` naming each, so compare with
``mj_forward`` with them off (``opt.disableflags`` with ``mjDSBL_CONTACT | mjDSBL_LIMIT |
mjDSBL_EQUALITY | mjDSBL_FRICTIONLOSS``, or a model without them): contacts, joint limits,
equality constraints, friction loss, actuators mbgen does not read.  Refused with
:class:`~mbgen.errors.MjcfError`: gravity compensation, fluid forces (``density`` or
``viscosity``), tendons with stiffness, damping or armature, and springs on ball or free
joints (the full lists: :mod:`~mbgen.model.mjcf_physics`).  An inertia that breaks the
triangle inequality is MuJoCo's compiler's to refuse (or to mend, with
``balanceinertia``); a compiled model with one, its fields set by hand, is read as it is,
as ``mj_forward`` reads it.

Before MuJoCo reads a file, :func:`compile_mjcf` reads it and what it brings in
(:mod:`~mbgen.model.mjcf_xml`): a path that is not a regular file, a number that is not
finite or whose square overflows, a file that multiplies into a huge model are refused by
name.  A compiled model (:func:`from_mujoco`) is checked by MuJoCo's fields the same way,
and its axes and quaternions are normalised dividing by the largest component first.
"""

from __future__ import annotations

import math
import os

import numpy as np
import sympy as sm

from ..errors import MissingExtraError, MjcfError
from ..names import C_KEYWORDS, MAX_NAME_LENGTH, did_you_mean
from . import free_base
from .builder import Model
from .mjcf_physics import FLAG, read_physics, warn_dropped
from .mjcf_xml import MAX_MAGNITUDE, scan_mjcf
from .urdf import (
    Group,
    contact_names,
    frame_vector,
    identifier,
    quaternion_matrix,
    turned_frame,
)

HINGE, SLIDE, BALL, FREE = 3, 2, 1, 0   # mjtJoint
SPHERE = 2                              # mjtGeom


def import_mujoco():
    """The ``mujoco`` module, or :class:`MissingExtraError` naming the extra that has it."""
    try:
        import mujoco
    except ImportError:
        raise MissingExtraError("MJCF models are read by MuJoCo, which is not installed: "
                                "pip install 'mbgen[mujoco]'") from None
    return mujoco


def compile_mjcf(path):
    """The ``mujoco.MjModel`` of the file at ``path`` (MJCF, or URDF as MuJoCo reads it).

    The files are read first (:func:`~mbgen.model.mjcf_xml.scan_mjcf`), so that what would
    make MuJoCo wait forever, grow without bound or compile a different model is refused by
    name before it reads a byte; MuJoCo's own complaints come back as :class:`MjcfError`
    naming the file."""
    mujoco = import_mujoco()
    scan_mjcf(path)
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        raise MjcfError(f"MuJoCo could not compile {str(path)!r}: "
                        f"{' '.join(str(exc).split())}") from None


def from_mjcf(path, *, ground=None, contacts=()) -> Model:
    """The model of the MJCF file at ``path``, compiled by MuJoCo (module docstring), named
    after the file (``cartpole.xml``: ``cartpole``, whatever its ``<mujoco model>``).

    :class:`MjcfError` for a file that is not safe to hand to MuJoCo, that MuJoCo cannot
    compile, or that holds what mbgen refuses (:mod:`~mbgen.model.mjcf_physics`);
    :class:`~mbgen.errors.ModelSizeError` for more than
    :data:`~mbgen.model.limits.MAX_BODIES` bodies (unless forced); one
    :class:`~mbgen.errors.ModelWarning` naming what it drops (contacts, limits, ...).
    ``ground``, ``contacts``: see :func:`from_mujoco`."""
    return from_mujoco(compile_mjcf(path), name=file_model_name(path), ground=ground,
                       contacts=contacts)


def from_mujoco(mj, *, name: str | None = None, ground=None, contacts=()) -> Model:
    """The model of a compiled ``mujoco.MjModel`` (see the module docstring), named ``name``
    (an identifier) or else after MuJoCo's model name (``<mujoco model>``).

    ``ground``: names of sphere geoms (each a contact sphere of its radius) and sites (each
    a contact point), a sequence or ``"a,b"``, that touch a compliant ground
    (:meth:`Model.ground <mbgen.Model.ground>`; MuJoCo's own contacts stay dropped).

    ``contacts``: names of sites and bodies whose point (a site's position, a body's frame
    origin) is a rigid point contact with the ground (:meth:`mbgen.Model.contact`, named
    after the site or body, in the order given; its force is ``constraint_forces``)."""
    return _Builder(mj).build(name or model_name(mj), ground, contact_names(contacts,
                                                                            "from_mujoco"))


# ------------------------------------------------------------------ the compiled model
#: The numbers read from a compiled model, and what a row of each belongs to.
_FIELDS = (("body_pos", "body"), ("body_quat", "body"), ("body_ipos", "body"),
           ("body_iquat", "body"), ("body_mass", "body"), ("body_inertia", "body"),
           ("jnt_pos", "joint"), ("jnt_axis", "joint"), ("jnt_stiffness", "joint"),
           ("qpos0", "qpos"), ("qpos_spring", "qpos"), ("dof_damping", "dof"),
           ("dof_armature", "dof"))


def _unit(values, what: str) -> np.ndarray:
    """``values / |values|``, divided by the largest component first: the square of
    ``1e200`` overflows and that of ``1e-200`` underflows, either way to a zero vector (an
    axis about which a joint would not turn); :class:`MjcfError` if it is zero or not finite."""
    v = np.asarray(values, dtype=float)
    top = float(np.abs(v).max(initial=0.0))
    if not math.isfinite(top) or top == 0:
        raise MjcfError(f"MuJoCo model: {what} is {v.tolist()}, no direction (zero or not "
                        f"finite: MuJoCo's own normalisation overflows past about 1e154); "
                        f"give it with components of ordinary size, e.g. '1 0 0'")
    v = v / top
    return v / np.linalg.norm(v)


def _quat(wxyz, what: str) -> np.ndarray:
    """The rotation matrix of MuJoCo's quaternion ``(w, x, y, z)``, normalised scale-safely."""
    w, x, y, z = (float(c) for c in _unit(wxyz, what))
    return np.array(quaternion_matrix(x, y, z, w), dtype=float)


def names_of(mj, kind: str, count: int) -> list[str]:
    """Names of MuJoCo objects of one kind (``"joint"``, ``"body"``), sanitised, ``""`` if none."""
    mujoco = import_mujoco()
    obj = getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}")
    return [identifier(mujoco.mj_id2name(mj, obj, i) or "") for i in range(count)]


def model_name(mj) -> str:
    """MuJoCo's model name (``<mujoco model>``) as an identifier; ``mjcf`` if it has none."""
    raw = bytes(mj.names[:max(0, bytes(mj.names).find(b"\0"))]).decode(errors="replace")
    return _model_identifier(raw)


def file_model_name(path) -> str:
    """The model name of a file: its name without the suffix, as an identifier (what
    :func:`from_mjcf` and ``mbgen simulate robot.xml`` name the model and its outputs)."""
    return _model_identifier(os.path.splitext(os.path.basename(os.fspath(path)))[0])


def _model_identifier(raw: str) -> str:
    name = identifier(raw)[:48] or "mjcf"
    if not name[0].isalpha():
        name = "mjcf_" + name
    return name + "_model" if name in C_KEYWORDS or name.startswith("__") else name


def joint_symbols(mj) -> list[tuple[int, str, list[str], list[str], list[str]]]:
    """Per joint ``(type, base name, coordinate names, speed names, input names)``."""
    out, seen = [], set()
    for j, name in enumerate(names_of(mj, "joint", mj.njnt)):
        base = name if name[:1].isalpha() else f"joint{j}" if not name else f"joint_{name}"
        kind = int(mj.jnt_type[j])
        if kind in (HINGE, SLIDE):
            sfx_q, sfx_u, sfx_r = [""], [""], [""]
        elif kind == BALL:
            sfx_q, sfx_u, sfx_r = ["_qw", "_qx", "_qy", "_qz"], ["_wx", "_wy", "_wz"], \
                ["_tx", "_ty", "_tz"]
        else:
            sfx_q = ["_x", "_y", "_z", "_qw", "_qx", "_qy", "_qz"]
            sfx_u = ["_vx", "_vy", "_vz", "_wx", "_wy", "_wz"]
            sfx_r = ["_fx", "_fy", "_fz", "_tx", "_ty", "_tz"]
        row = (kind, base, [f"q_{base}{s}" for s in sfx_q], [f"u_{base}{s}" for s in sfx_u],
               [f"tau_{base}{s}" for s in sfx_r])
        for n in row[2] + row[3] + row[4]:
            if n in seen or len(n) > MAX_NAME_LENGTH:
                raise MjcfError(f"MuJoCo model: joint {j} ({base!r}) gives the name {n!r}, "
                                f"{'taken by another joint' if n in seen else 'too long'}; "
                                f"rename the joint in the file")
            seen.add(n)
        out.append(row)
    return out


class _Builder:
    def __init__(self, mj):
        self.mj = mj
        self.joints = joint_symbols(mj)
        self.taken = {n for row in self.joints for names in row[2:] for n in names} | {"g"}
        self.body_names = names_of(mj, "body", mj.nbody)
        self.physics = None             # read_physics's, once check() has run

    def internal(self, base: str) -> str:
        base = base[:MAX_NAME_LENGTH - 4]
        name, k = base, 2
        while name in self.taken:
            name, k = f"{base}_{k}", k + 1
        self.taken.add(name)
        return name

    def owner(self, kind: str, i: int) -> str:
        """The body or joint that row ``i`` of a ``kind`` field (:data:`_FIELDS`) belongs to."""
        mj = self.mj
        if kind == "body":
            return f"body {self.body_names[i] or i!r}"
        j = int(mj.dof_jntid[i]) if kind == "dof" else \
            int(np.searchsorted(mj.jnt_qposadr, i, side="right")) - 1 if kind == "qpos" else i
        return f"joint {self.joints[j][1]!r}"

    def check_numbers(self) -> None:
        """Every number read is finite and within :data:`MAX_MAGNITUDE` (a NaN damping
        would otherwise surface deep in the derivation); hinge and slide axes have a
        direction.  The error names the body or joint and MuJoCo's field."""
        mj = self.mj
        for field, kind in _FIELDS:
            values = np.asarray(getattr(mj, field), dtype=float)
            values = values.reshape(len(values), -1)
            bad = (~np.isfinite(values) | (np.abs(values) > MAX_MAGNITUDE)).any(axis=1)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise MjcfError(f"MuJoCo model: {self.owner(kind, i)}: {field} holds "
                                f"{values[i].tolist()}, not finite numbers within "
                                f"{MAX_MAGNITUDE:g}; fix the file it came from")
        gravity = np.asarray(mj.opt.gravity, dtype=float)
        if not np.isfinite(gravity).all() or np.abs(gravity).max() > MAX_MAGNITUDE:
            raise MjcfError(f"MuJoCo model: opt.gravity is {gravity.tolist()}, not finite "
                            f"numbers within {MAX_MAGNITUDE:g}; fix <option gravity>")
        for j, (kind, base, *_) in enumerate(self.joints):
            if kind in (HINGE, SLIDE):
                _unit(mj.jnt_axis[j], f"joint {base!r}: jnt_axis")

    def check(self) -> None:
        """Numbers (:meth:`check_numbers`), then what mbgen refuses, drops and reads beyond
        the tree (:func:`~mbgen.model.mjcf_physics.read_physics`), then free bodies."""
        self.check_numbers()
        mj = self.mj
        self.physics = read_physics(mj, [row[1] for row in self.joints], self.taken)
        for j, (kind, base, *_) in enumerate(self.joints):
            if kind == FREE:
                self.check_free_body(int(mj.jnt_bodyid[j]), j, base)

    def check_free_body(self, body: int, joint: int, base: str, samples: int = 2) -> None:
        """Refuse a free body whose subtree some motion moves without moving mass
        (:mod:`~mbgen.model.free_base`; a singular mass matrix at every state), tried at
        ``samples`` pseudo-random configurations.  Armature on the free joint itself
        keeps its block of the mass matrix positive: nothing to refuse then."""
        mj = self.mj
        dof = int(mj.jnt_dofadr[joint])
        if all(a > 0 for a in self.physics.armature[dof:dof + 6]):
            return
        found = [free_base.lack(self.free_parts(body, rng_state))
                 for rng_state in range(samples)]
        if all(found):
            name = self.body_names[body] or f"body{body}"
            raise MjcfError(
                f"MuJoCo model: the free body {name!r} (joint {base!r}) with all it carries "
                f"has {found[0]} (some motion of it the joints below undo, so that nothing "
                f"with mass moves): the mass matrix is singular at every state; give body "
                f"{name!r} a positive mass and inertia (<inertial>, or a geom with density)")

    def free_parts(self, body: int, seed: int) -> list:
        """The subtree of ``body`` as :class:`~mbgen.model.free_base.Part` rows in world
        coordinates, at a pseudo-random configuration (``mj_kinematics``)."""
        mujoco = import_mujoco()
        mj = self.mj
        data = mujoco.MjData(mj)
        rng = np.random.default_rng(seed)
        qpos = rng.uniform(-math.pi, math.pi, mj.nq)
        for j in range(mj.njnt):
            a, kind = int(mj.jnt_qposadr[j]), int(mj.jnt_type[j])
            if kind in (BALL, FREE):
                at = a + (3 if kind == FREE else 0)
                quat = rng.normal(size=4)
                qpos[at:at + 4] = quat / np.linalg.norm(quat)
        data.qpos[:] = qpos
        mujoco.mj_kinematics(mj, data)
        index, parts = {body: 0}, []
        for b in range(body, mj.nbody):
            parent = int(mj.body_parentid[b])
            if b != body and parent not in index:
                continue
            index[b] = len(parts)
            columns, armature = [], []
            if b != body:
                for j in range(int(mj.body_jntadr[b]), int(mj.body_jntadr[b] + mj.body_jntnum[b])):
                    columns.append(self.joint_motion(data, j))
                    dof = int(mj.jnt_dofadr[j])
                    armature.extend(self.physics.armature[dof:dof + columns[-1].shape[1]])
            motion = np.hstack(columns) if columns else free_base.NO_MOTION
            R = np.array(data.ximat[b]).reshape(3, 3)
            centre = np.array(data.xipos[b], dtype=float)
            mass = float(mj.body_mass[b])
            inertia = free_base.body_inertia(
                mass, centre, R @ np.diag(np.array(mj.body_inertia[b], dtype=float)) @ R.T)
            parts.append(free_base.Part(-1 if b == body else index[parent], motion, inertia,
                                        mass, centre, np.array(armature) if armature else None))
        return parts

    def joint_motion(self, data, j: int) -> np.ndarray:
        """The 6 x k motion subspace (world, about the origin) of joint ``j`` now."""
        mj, kind = self.mj, int(self.mj.jnt_type[j])
        axis, anchor = np.array(data.xaxis[j]), np.array(data.xanchor[j])
        if kind == HINGE:
            return free_base.revolute_motion(axis, anchor)
        if kind == SLIDE:
            return free_base.prismatic_motion(axis)
        R = np.array(data.xmat[int(mj.jnt_bodyid[j])]).reshape(3, 3)   # a ball
        return np.hstack([free_base.revolute_motion(R[:, k], anchor) for k in range(3)])

    def build(self, title: str, ground=None, contacts=()) -> Model:
        self.check()
        mj = self.mj
        m = Model(title)
        N = m.newtonian(self.internal("N"), self.internal("O"))
        g, = m.constants("g")
        gvec = np.array(self.physics.gravity, dtype=float)
        gnorm = float(np.linalg.norm(gvec))
        self.symbols = {}
        for _kind, _base, qs, us, rs in self.joints:
            for names, make in ((qs, m.coordinates), (us, m.speeds), (rs, m.inputs)):
                made = make(" ".join(names))
                self.symbols.update(zip(names, made if isinstance(made, tuple) else (made,)))
        for actuator in self.physics.actuators:      # MuJoCo's ctrl, after qfrc_applied
            made = m.inputs(actuator.input)
            self.symbols[actuator.input] = made[0] if isinstance(made, tuple) else made
        groups = {0: Group(None, N, m.origin)}
        place = {0: (np.eye(3), np.zeros(3))}
        for b in range(1, mj.nbody):
            parent = int(mj.body_parentid[b])
            group = groups[parent]
            A0, d0 = place[parent]
            A = A0 @ _quat(mj.body_quat[b], f"body {self.body_names[b] or b!r}: body_quat")
            d = d0 + A0 @ np.array(mj.body_pos[b], dtype=float)
            label = self.body_names[b] or f"body{b}"
            label = label if label[:1].isalpha() else f"body_{label}"
            start, count = int(mj.body_jntadr[b]), int(mj.body_jntnum[b])
            for j in range(start, start + count):
                group, A, d = self.joint(m, j, group, A, d, label)
            groups[b], place[b] = group, (A, d)
            if mj.body_mass[b] > 0 or np.any(mj.body_inertia[b]):
                R = A @ _quat(mj.body_iquat[b], f"body {label!r}: body_iquat")
                group.parts.append((float(mj.body_mass[b]),
                                    d + A @ np.array(mj.body_ipos[b], dtype=float),
                                    R @ np.diag(np.array(mj.body_inertia[b], dtype=float)) @ R.T))
        for group in dict.fromkeys(groups.values()):
            if group.name is not None:
                self.add_body(m, group)
        if gnorm > 0:
            m.gravity(g * frame_vector(N, gvec / gnorm))
        if ground:
            _ground(self, m, groups, place, ground)
        if contacts:
            _contacts(self, m, groups, place, contacts)
        warn_dropped(title, self.physics.dropped)
        return m

    def add_body(self, m: Model, group: Group) -> None:
        made = group.combined()
        if made is None:
            return
        mass, centre, inertia = made
        point = group.point if not centre.any() else \
            m.point(self.internal(f"{group.name}_G"), group.point,
                    frame_vector(group.frame, centre))
        m.body(self.internal(group.name), group.frame, float(mass),
               [[float(v) for v in row] for row in inertia], point)

    def joint(self, m: Model, j: int, group: Group, A, d, label: str):
        """One joint of a body: the new ``(group, A, d)`` of the body's frame after it."""
        mj = self.mj
        kind, base, qs, us, rs = self.joints[j]
        q = [self.symbols[n] for n in qs]
        u = [self.symbols[n] for n in us]
        r = [self.symbols[n] for n in rs]
        dof = int(mj.jnt_dofadr[j])
        damping = list(self.physics.damping[dof:dof + len(u)])
        for k, s in enumerate(u):
            if self.physics.armature[dof + k]:
                m.armature(s, self.physics.armature[dof + k])
        axis = A @ _unit(mj.jnt_axis[j], f"joint {base!r}: jnt_axis") \
            if kind in (HINGE, SLIDE) else None
        jpos = np.array(mj.jnt_pos[j], dtype=float)
        anchor = d + A @ jpos
        parent = group
        if kind in (HINGE, SLIDE):
            q0 = float(mj.qpos0[mj.jnt_qposadr[j]])
            angle = q[0] - q0 if q0 else q[0]
            load = r[0] - damping[0] * u[0]
            k = float(mj.jnt_stiffness[j]) if self.physics.springs else 0.0
            if k:
                load = load - k * (q[0] - float(mj.qpos_spring[mj.jnt_qposadr[j]]))
            for actuator in self.physics.actuators:
                if actuator.joint == j:
                    load = load + actuator.force(q[0], u[0], self.symbols[actuator.input])
        if kind == SLIDE:
            point = m.point(self.internal(f"{label}_slide"), parent.point,
                            frame_vector(parent.frame, axis) * angle)
            m.force(point, load * frame_vector(parent.frame, axis), reaction=parent.point)
            return Group(label, parent.frame, point), A, d
        point = parent.point if not anchor.any() else \
            m.point(self.internal(f"{label}_J"), parent.point, frame_vector(parent.frame, anchor))
        if kind == HINGE:
            frame, C, k_axis, sign = turned_frame(m, parent.frame, self.internal, label, axis,
                                                  angle)
            m.torque(frame, sign * load * (frame.x, frame.y, frame.z)[k_axis - 1],
                     reaction=parent.frame)
            A_new = C.T @ A
            return Group(label, frame, point), A_new, -A_new @ jpos
        qw, qx, qy, qz = q[-4:]
        R = quaternion_matrix(qx, qy, qz, qw)
        w = u[-3:]
        half = sm.Rational(1, 2)
        kin = {qx: half * (qw * w[0] + qy * w[2] - qz * w[1]),
               qy: half * (qw * w[1] + qz * w[0] - qx * w[2]),
               qz: half * (qw * w[2] + qx * w[1] - qy * w[0]),
               qw: -half * (qx * w[0] + qy * w[1] + qz * w[2])}
        if kind == BALL:
            # A R: the joint turns the body from its reference orientation A, a constant
            # frame of its own (sympy differentiates a frame's matrix: A R in one would cost
            # seconds per joint, R alone a fraction)
            turned = parent.frame if np.array_equal(A, np.eye(3)) else \
                m.orient(parent.frame, self.internal(f"{label}_ref"), A.tolist(), (0, 0, 0),
                         relative=True)
            frame = m.orient(turned, self.internal(f"{label}_frame"), R, w, relative=True)
            torque = [r[i] - damping[i] * w[i] for i in range(3)]
            m.torque(frame, frame_vector_sym(frame, torque), reaction=parent.frame)
            m.kinematics(kin)
            return Group(label, frame, point), np.eye(3), -jpos
        # free: the body's origin and orientation in the world, whatever its parent
        N = m.N
        frame = m.orient(N, self.internal(f"{label}_frame"), R, w)
        point = m.point(self.internal(f"{label}_origin"), m.origin,
                        frame_vector_sym(N, q[:3]))
        m.kinematics({**kin, **{q[i]: u[i] for i in range(3)}})
        m.force(point, frame_vector_sym(N, [r[i] - damping[i] * u[i] for i in range(3)]))
        m.torque(frame, frame_vector_sym(frame, [r[3 + i] - damping[3 + i] * w[i]
                                                 for i in range(3)]))
        return Group(label, frame, point), np.eye(3), np.zeros(3)


def _ground(builder: _Builder, m: Model, groups, place, ground) -> None:
    """``m.ground`` at the named sphere geoms (their centres and radii) and sites (points)."""
    mj = builder.mj
    geoms, sites = names_of(mj, "geom", mj.ngeom), names_of(mj, "site", mj.nsite)
    names = [n.strip() for n in ground.split(",")] if isinstance(ground, str) else list(ground)
    points, radii = [], []
    for name in names:
        if name in geoms:
            i = geoms.index(name)
            if int(mj.geom_type[i]) != SPHERE:
                raise MjcfError(f"MuJoCo model: geom {name!r} is no sphere; the ground takes "
                                f"sphere geoms and sites")
            body, at, radius = int(mj.geom_bodyid[i]), mj.geom_pos[i], float(mj.geom_size[i, 0])
        elif name in sites:
            i = sites.index(name)
            body, at, radius = int(mj.site_bodyid[i]), mj.site_pos[i], 0.0
        else:
            raise MjcfError(f"MuJoCo model has no geom or site {name!r} for the ground"
                            f"{did_you_mean(name, [n for n in geoms + sites if n])}")
        (A, d), group = place[body], groups[body]
        points.append(m.point(builder.internal(name), group.point,
                              frame_vector(group.frame, d + A @ np.array(at, dtype=float))))
        radii.append(radius)
    m.ground(points, radius=radii)


def _contacts(builder: _Builder, m: Model, groups, place, contacts) -> None:
    """``m.contact`` at each named site (its position) or body (its frame's origin)."""
    mj = builder.mj
    sites, bodies = names_of(mj, "site", mj.nsite), names_of(mj, "body", mj.nbody)
    found = []
    for name in contacts:
        key = identifier(name)
        if key in sites:
            i = sites.index(key)
            body, at = int(mj.site_bodyid[i]), np.array(mj.site_pos[i], dtype=float)
        elif key in bodies[1:]:
            body, at = bodies.index(key), np.zeros(3)
        else:
            raise MjcfError(f"MuJoCo model has no site or body {name!r} for a contact"
                            f"{did_you_mean(name, [n for n in sites + bodies[1:] if n])}")
        found.append((key if key[:1].isalpha() else f"contact_{key}", body, at))
    for key, body, at in found:
        (A, d), group = place[body], groups[body]
        offset = d + A @ at
        point = group.point if not offset.any() else \
            m.point(builder.internal(f"{key}_contact"), group.point,
                    frame_vector(group.frame, offset))
        m.contact(point, name=key)


def frame_vector_sym(frame, comps):
    """``sum comps[i] * frame.axis_i`` of symbolic components (zeros dropped)."""
    terms = [c * e for c, e in zip(comps, (frame.x, frame.y, frame.z)) if c != 0]
    return sum(terms[1:], terms[0]) if terms else 0


def scene_values(mj) -> tuple[dict, dict]:
    """``(parameters, initial state)`` of a MuJoCo model: ``g`` (0 where gravity is
    disabled) and ``qpos0`` by name."""
    names = [n for row in joint_symbols(mj) for n in row[2]]
    gravity = int(mj.opt.disableflags) & FLAG["gravity"]
    return ({"g": 0.0 if gravity else float(np.linalg.norm(mj.opt.gravity))},
            {n: float(v) for n, v in zip(names, mj.qpos0) if v != 0})


__all__ = ["compile_mjcf", "file_model_name", "from_mjcf", "from_mujoco", "import_mujoco",
           "joint_symbols", "scene_values"]
