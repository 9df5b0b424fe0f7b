r"""A MuJoCo model as a :class:`~mbgen.model.builder.Model`: :func:`from_mjcf`, :func:`from_mujoco`.

MuJoCo's own compiler reads the file (the ``mujoco`` extra: ``pip install 'mbgen[mujoco]'``),
so defaults, classes, ``<compiler>`` units and angles, and inertia from geoms are resolved
as MuJoCo resolves them; this module reads the compiled ``mjModel``: the body tree
(``body_parentid``, ``body_pos``, ``body_quat``, ``body_ipos``, ``body_iquat``,
``body_mass``, ``body_inertia``), the joints (``jnt_type``, ``jnt_axis``, ``jnt_pos``,
``qpos0``, ``jnt_stiffness``, ``qpos_spring``, ``dof_armature``, ``dof_damping``) and
``opt.gravity``.

Conventions (MuJoCo's, so that a state compares one to one with ``mj_forward``):

* coordinates, speeds and inputs in MuJoCo's ``qpos``, ``qvel`` and ``qfrc_applied``
  order (joint by joint, in the order of the file).  For a joint ``<j>`` (its name
  sanitised to an identifier; ``joint<k>`` when it has none):

  ========  ===============================  ================================  ==============================
  type      coordinates                      speeds                            inputs (generalized forces)
  ========  ===============================  ================================  ==============================
  hinge     ``q_<j>``                        ``u_<j>``                         ``tau_<j>``
  slide     ``q_<j>``                        ``u_<j>``                         ``tau_<j>``
  ball      ``q_<j>_qw, _qx, _qy, _qz``      ``u_<j>_wx, _wy, _wz``            ``tau_<j>_tx, _ty, _tz``
  free      ``q_<j>_x, _y, _z``, then        ``u_<j>_vx, _vy, _vz``,           ``tau_<j>_fx, _fy, _fz``,
            ``q_<j>_qw, _qx, _qy, _qz``      ``u_<j>_wx, _wy, _wz``            ``tau_<j>_tx, _ty, _tz``
  ========  ===============================  ================================  ==============================

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
  body's origin in world components and its torque in body components.
* passive forces as MuJoCo states them: damping :math:`-d\,u` per degree of freedom
  (``dof_damping``), hinge and slide springs :math:`-k\,(q - q_\mathrm{spring})`; joint
  armature (``dof_armature``) adds to the diagonal of the mass matrix, a rotor inertia
  about the joint's axis that sees no other motion (modelled as a massless body turning
  with that one speed about a fixed axis).
* gravity ``g`` times the direction of ``opt.gravity``, ``g = |opt.gravity|`` the model's
  one constant; every inertial number is baked in.  Bodies without joints are welded to
  their parent and their masses merged, as fixed URDF joints are.

Not read, so compare with ``mj_forward`` with them off (``opt.disableflags`` with
``mjDSBL_CONTACT | mjDSBL_LIMIT | mjDSBL_EQUALITY | mjDSBL_FRICTIONLOSS | mjDSBL_ACTUATION``,
or a model without them): contacts, joint limits, equality constraints, friction loss,
actuators (apply their forces through the inputs).  Refused with
:class:`~mbgen.errors.MjcfError`: gravity compensation, fluid forces (``density`` or
``viscosity``), tendons with stiffness or damping, and springs on ball or free joints.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from ..errors import MissingExtraError, MjcfError
from ..names import C_KEYWORDS, MAX_NAME_LENGTH
from .builder import Model
from .urdf import Group, axis_rotation, frame_vector, identifier, quaternion_matrix, simple

HINGE, SLIDE, BALL, FREE = 3, 2, 1, 0   # mjtJoint


def import_mujoco():
    """The ``mujoco`` module, or :class:`MissingExtraError` naming the extra that has it."""
    try:
        import mujoco
    except ImportError:
        raise MissingExtraError("MJCF models are read by MuJoCo, which is not installed: "
                                "pip install 'mbgen[mujoco]'") from None
    return mujoco


def compile_mjcf(path):
    """The ``mujoco.MjModel`` of the file at ``path`` (MJCF, or URDF as MuJoCo reads it)."""
    mujoco = import_mujoco()
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        raise MjcfError(f"MuJoCo could not compile {str(path)!r}: {exc}") from None


def from_mjcf(path) -> Model:
    """The model of the MJCF file at ``path``, compiled by MuJoCo (module docstring)."""
    return from_mujoco(compile_mjcf(path))


def from_mujoco(mj) -> Model:
    """The model of a compiled ``mujoco.MjModel`` (see the module docstring)."""
    return _Builder(mj).build()


def _quat(wxyz) -> np.ndarray:
    w, x, y, z = (float(v) for v in wxyz)
    return np.array(quaternion_matrix(x, y, z, w), dtype=float)


def names_of(mj, kind: str, count: int) -> list[str]:
    """Names of MuJoCo objects of one kind (``"joint"``, ``"body"``), sanitised, ``""`` if none."""
    mujoco = import_mujoco()
    obj = getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}")
    return [identifier(mujoco.mj_id2name(mj, obj, i) or "") for i in range(count)]


def model_name(mj) -> str:
    raw = bytes(mj.names[:max(0, bytes(mj.names).find(b"\0"))]).decode(errors="replace")
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

    def internal(self, base: str) -> str:
        base = base[:MAX_NAME_LENGTH - 4]
        name, k = base, 2
        while name in self.taken:
            name, k = f"{base}_{k}", k + 1
        self.taken.add(name)
        return name

    def check(self) -> None:
        mj = self.mj
        problems = []
        if np.any(mj.body_gravcomp):
            problems.append("gravity compensation (gravcomp)")
        if mj.opt.density or mj.opt.viscosity:
            problems.append("fluid forces (option density or viscosity)")
        if mj.ntendon and (np.any(mj.tendon_stiffness) or np.any(mj.tendon_damping)):
            problems.append("tendons with stiffness or damping")
        for j, (kind, base, *_) in enumerate(self.joints):
            if kind in (BALL, FREE) and mj.jnt_stiffness[j]:
                problems.append(f"a spring on the ball or free joint {base!r}")
        if problems:
            raise MjcfError("MuJoCo model: mbgen does not model " + "; ".join(problems)
                            + "; remove them from the file")

    def build(self) -> Model:
        self.check()
        mj = self.mj
        m = Model(model_name(mj))
        N = m.newtonian(self.internal("N"), self.internal("O"))
        g, = m.constants("g")
        gvec = np.array(mj.opt.gravity, dtype=float)
        gnorm = float(np.linalg.norm(gvec))
        self.g_value = gnorm
        self.symbols = {}
        for kind, base, qs, us, rs in self.joints:
            for names, make in ((qs, m.coordinates), (us, m.speeds), (rs, m.inputs)):
                made = make(" ".join(names))
                self.symbols.update(zip(names, made if isinstance(made, tuple) else (made,)))
        groups = {0: Group(None, N, m.origin)}
        place = {0: (np.eye(3), np.zeros(3))}
        rotors = []
        for b in range(1, mj.nbody):
            parent = int(mj.body_parentid[b])
            group = groups[parent]
            A0, d0 = place[parent]
            A = A0 @ _quat(mj.body_quat[b])
            d = d0 + A0 @ np.array(mj.body_pos[b], dtype=float)
            label = self.body_names[b] or f"body{b}"
            label = label if label[:1].isalpha() else f"body_{label}"
            start, count = int(mj.body_jntadr[b]), int(mj.body_jntnum[b])
            for j in range(start, start + count):
                group, A, d = self.joint(m, j, group, A, d, label, rotors)
            groups[b], place[b] = group, (A, d)
            if mj.body_mass[b] > 0 or np.any(mj.body_inertia[b]):
                R = A @ _quat(mj.body_iquat[b])
                group.parts.append((float(mj.body_mass[b]),
                                    d + A @ np.array(mj.body_ipos[b], dtype=float),
                                    R @ np.diag(np.array(mj.body_inertia[b], dtype=float)) @ R.T))
        for group in dict.fromkeys(groups.values()):
            if group.name is not None:
                self.add_body(m, group)
        for name, speed, armature in rotors:
            frame = m.orient(N, self.internal(f"{name}_rotor"), sm.eye(3), (0, 0, speed))
            m.body(self.internal(f"{name}_rotor_body"), frame, 0, (0, 0, armature), m.origin)
        if gnorm > 0:
            m.gravity(g * frame_vector(N, gvec / gnorm))
        return m

    def add_body(self, m: Model, group: Group) -> None:
        made = group.combined()
        if made is None:
            return
        mass, centre, inertia = made
        point = group.point if not centre.any() else \
            m.point(self.internal(f"{group.name}_G"), group.point, frame_vector(group.frame, centre))
        m.body(self.internal(group.name), group.frame, float(mass),
               [[float(v) for v in row] for row in inertia], point)

    def joint(self, m: Model, j: int, group: Group, A, d, label: str, rotors: list):
        """One joint of a body: the new ``(group, A, d)`` of the body's frame after it."""
        mj = self.mj
        kind, base, qs, us, rs = self.joints[j]
        q = [self.symbols[n] for n in qs]
        u = [self.symbols[n] for n in us]
        r = [self.symbols[n] for n in rs]
        dof = int(mj.jnt_dofadr[j])
        damping = [float(mj.dof_damping[dof + k]) for k in range(len(u))]
        for k, s in enumerate(u):
            if mj.dof_armature[dof + k]:
                rotors.append((f"{base}{k}", s, float(mj.dof_armature[dof + k])))
        axis = A @ np.array(mj.jnt_axis[j], dtype=float)
        jpos = np.array(mj.jnt_pos[j], dtype=float)
        anchor = d + A @ jpos
        parent = group
        if kind in (HINGE, SLIDE):
            q0 = float(mj.qpos0[mj.jnt_qposadr[j]])
            angle = q[0] - q0 if q0 else q[0]
            load = r[0] - damping[0] * u[0]
            k = float(mj.jnt_stiffness[j])
            if k:
                load = load - k * (q[0] - float(mj.qpos_spring[mj.jnt_qposadr[j]]))
        if kind == SLIDE:
            point = m.point(self.internal(f"{label}_slide"), parent.point,
                            frame_vector(parent.frame, axis) * angle)
            m.force(point, load * frame_vector(parent.frame, axis), reaction=parent.point)
            return Group(label, parent.frame, point), A, d
        point = parent.point if not anchor.any() else \
            m.point(self.internal(f"{label}_J"), parent.point, frame_vector(parent.frame, anchor))
        if kind == HINGE:
            steps, k_axis, sign = axis_rotation(axis)
            frame, C = parent.frame, np.eye(3)
            for n, (ax, ang) in enumerate(steps):
                frame = m.rotate(frame, self.internal(f"{label}_axis{n}"), ax, ang)
                C = C @ simple(ax, ang)
            frame = m.rotate(frame, self.internal(f"{label}_frame"), k_axis, sign * angle)
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
            frame = m.orient(parent.frame, self.internal(f"{label}_frame"),
                             sm.Matrix(A.tolist()) * R, w, relative=True)
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


def frame_vector_sym(frame, comps):
    """``sum comps[i] * frame.axis_i`` of symbolic components (zeros dropped)."""
    terms = [c * e for c, e in zip(comps, (frame.x, frame.y, frame.z)) if c != 0]
    return sum(terms[1:], terms[0]) if terms else 0


def scene_values(mj) -> tuple[dict, dict]:
    """``(parameters, initial state)`` of a MuJoCo model: ``g`` and ``qpos0`` by name."""
    names = [n for row in joint_symbols(mj) for n in row[2]]
    return ({"g": float(np.linalg.norm(mj.opt.gravity))},
            {n: float(v) for n, v in zip(names, mj.qpos0) if v != 0})


__all__ = ["compile_mjcf", "from_mjcf", "from_mujoco", "import_mujoco", "joint_symbols", "scene_values"]
