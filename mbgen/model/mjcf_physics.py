r"""What a compiled MuJoCo model says beyond its bodies and joints: :func:`read_physics`.

Every option and element of an ``mjModel`` that changes the dynamics is sorted one of three
ways, so that what the file says is what runs, or the user is told at load:

Honoured
    ``opt.gravity``, and ``<flag gravity="disable"/>`` (no gravity: ``g`` is 0);
    ``<flag spring="disable"/>`` (no joint springs) and ``<flag damper="disable"/>`` (no
    joint or actuator damping); ``<flag actuation="disable"/>`` (no actuator inputs);
    joint ``armature`` and ``damping``, and an actuator's ``armature`` and ``damping`` on a
    hinge or slide joint (:math:`\mathrm{gear}^2` times each joins the joint's, as MuJoCo
    adds them; the armature becomes :meth:`Model.armature <mbgen.Model.armature>` on each
    of the joint's speeds, ball and free joints included); and the actuators of
    :class:`Actuator`: a ``motor``, ``position``, ``velocity`` or ``general`` actuator
    with a fixed or affine gain, no or an affine bias and no activation dynamics, on a
    hinge or slide joint.
Refused (:class:`~mbgen.errors.MjcfError`, every one named in one message)
    forces mbgen has no term for: gravity compensation, fluid forces (``density`` or
    ``viscosity``), tendon springs, dampers and armature, springs on ball and free joints,
    nonlinear damping (``dampingpoly``), and armature or damping of an actuator mbgen does
    not read (they act whether the actuator does or not).
Dropped, with one :class:`~mbgen.errors.ModelWarning` per load naming each
    contacts, joint and tendon limits, equality constraints, friction loss, actuators not
    read (with the reason: a tendon or site transmission, activation dynamics, a muscle
    gain, a ball or free joint, a delay, a plugin), the clamping of ``ctrl`` to
    ``ctrlrange`` and of actuator forces to ``forcerange`` (mbgen never clamps: the ranges
    stay in :attr:`Actuator.ctrlrange` and :attr:`Actuator.forcerange`, clamp ``ctrl``
    before the call for MuJoCo's behaviour), plugins and flexes.  What a disable flag
    switches off (``contact``, ``limit``, ``equality``, ``frictionloss``, ``constraint``,
    ``clampctrl``, ``actuation``) is not dropped and not named.

Not dynamics, so neither: the time step, the integrator and the solver's settings
(``eulerdamp`` among them), sensors, cameras, lights, visuals, keyframes, and ``magnetic``
and ``wind`` (which act only through sensors and fluid forces).

An actuator's generalized force, as MuJoCo's ``mj_fwdActuation`` with ``ctrl`` unclamped,
on its joint's speed: :math:`\mathrm{gear}\,(g(L, V)\,\mathrm{ctrl} + b(L, V))`, with
:math:`L = \mathrm{gear}\,q` (MuJoCo's ``qpos``, not from ``qpos0``),
:math:`V = \mathrm{gear}\,u`, :math:`g = g_0 + g_1 L + g_2 V` (``gainprm``; :math:`g_0`
alone for a fixed gain) and :math:`b = b_0 + b_1 L + b_2 V` (``biasprm``): a ``motor``
is :math:`g = 1, b = 0`, a ``position`` actuator :math:`g = k_p, b = -k_p L - k_v V`, a
``velocity`` actuator :math:`g = k_v, b = -k_v V`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import MjcfError, ModelWarning
from ..names import MAX_NAME_LENGTH
from .mjcf_xml import MAX_MAGNITUDE
from .urdf import identifier

HINGE, SLIDE = 3, 2                     # mjtJoint
_TRN_JOINT = (0, 1)                     # mjtTrn: joint, jointinparent
_GAIN_READ, _BIAS_READ = (0, 1), (0, 1)  # mjtGain fixed, affine; mjtBias none, affine
#: mjtDisableBit, by the name of its ``<flag>`` attribute.
FLAG = {"constraint": 1 << 0, "equality": 1 << 1, "frictionloss": 1 << 2, "limit": 1 << 3,
        "contact": 1 << 4, "spring": 1 << 5, "damper": 1 << 6, "gravity": 1 << 7,
        "clampctrl": 1 << 8, "filterparent": 1 << 10, "actuation": 1 << 11}
#: Names listed in a message, at most.
_SHOWN = 4


@dataclass(frozen=True)
class Actuator:
    """One actuator mbgen reads (module docstring): MuJoCo's ``ctrl[index]`` as the input
    ``input``, a generalized force on the speed of joint ``joint``.

    ``ctrlrange`` and ``forcerange`` are MuJoCo's ranges where it clamps (``ctrllimited``
    with ``clampctrl`` on; ``forcelimited``), else ``None``: data, never applied by mbgen."""

    name: str
    input: str
    index: int
    joint: int
    gear: float
    gain: tuple[float, float, float]
    bias: tuple[float, float, float]
    ctrlrange: tuple[float, float] | None
    forcerange: tuple[float, float] | None

    def force(self, q, u, ctrl):
        """:math:`\\mathrm{gear}\\,(g\\,\\mathrm{ctrl} + b)` of the joint's coordinate ``q``,
        speed ``u`` and this input ``ctrl`` (symbols or numbers); zero terms left out."""
        length, velocity = self.gear * q, self.gear * u

        def affine(c):
            return sum((k * x for k, x in zip(c, (1, length, velocity)) if k), 0)
        return self.gear * (affine(self.gain) * ctrl + affine(self.bias))


@dataclass(frozen=True)
class Physics:
    """What :func:`read_physics` makes of a compiled model, per degree of freedom where a
    tuple: the damping and armature that act (joint's and actuators' together)."""

    gravity: tuple[float, float, float]
    springs: bool
    damping: tuple[float, ...]
    armature: tuple[float, ...]
    actuators: tuple[Actuator, ...]
    dropped: tuple[str, ...]


def _on(mj, flag: str) -> bool:
    return not int(mj.opt.disableflags) & FLAG[flag]


def _listed(names) -> str:
    names = [repr(n) for n in names]
    more = f" and {len(names) - _SHOWN} more" if len(names) > _SHOWN else ""
    return ", ".join(names[:_SHOWN]) + more


def _name(mujoco, mj, kind: str, i: int, default: str) -> str:
    obj = getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}")
    return identifier(mujoco.mj_id2name(mj, obj, i) or "") or default


def _unread(mujoco, mj, a: int) -> str | None:
    """Why actuator ``a`` is not read, or ``None`` if it is."""
    trn, dyn = int(mj.actuator_trntype[a]), int(mj.actuator_dyntype[a])
    gain, bias = int(mj.actuator_gaintype[a]), int(mj.actuator_biastype[a])
    reasons = (
        (trn not in _TRN_JOINT, lambda: f"{mujoco.mjtTrn(trn).name[6:].lower()} transmission"),
        (trn in _TRN_JOINT and int(mj.jnt_type[mj.actuator_trnid[a, 0]]) not in (HINGE, SLIDE),
         lambda: "on a ball or free joint"),
        (dyn != 0, lambda: f"activation dynamics ({mujoco.mjtDyn(dyn).name[6:].lower()})"),
        (gain not in _GAIN_READ, lambda: f"{mujoco.mjtGain(gain).name[7:].lower()} gain"),
        (bias not in _BIAS_READ, lambda: f"{mujoco.mjtBias(bias).name[7:].lower()} bias"),
        (int(mj.actuator_ctrlnum[a]) != 1, lambda: f"{int(mj.actuator_ctrlnum[a])} controls"),
        (float(mj.actuator_delay[a]) > 0 or int(mj.actuator_history[a, 0]) > 0,
         lambda: "a delay"),
        (int(mj.actuator_plugin[a]) >= 0, lambda: "a plugin"))
    return next((why() for test, why in reasons if test), None)


def _check_actuator_numbers(mujoco, mj) -> None:
    if not mj.nu:
        return
    for field in ("actuator_gear", "actuator_gainprm", "actuator_biasprm",
                  "actuator_damping", "actuator_armature"):
        values = np.asarray(getattr(mj, field), dtype=float).reshape(mj.nu, -1)
        bad = (~np.isfinite(values) | (np.abs(values) > MAX_MAGNITUDE)).any(axis=1)
        if bad.any():
            a = int(np.flatnonzero(bad)[0])
            raise MjcfError(f"MuJoCo model: actuator "
                            f"{_name(mujoco, mj, 'actuator', a, f'actuator{a}')!r}: {field} "
                            f"holds {values[a].tolist()}, not finite numbers within "
                            f"{MAX_MAGNITUDE:g}; fix the file it came from")


def _actuators(mujoco, mj, taken: set[str], dropped: list[str]) -> tuple[Actuator, ...]:
    """The actuators read, their inputs named ``ctrl_<name>`` (``ctrl_actuator<k>`` when
    unnamed); those not read go to ``dropped`` with the reason."""
    out, unread = [], []
    clamp_ctrl = _on(mj, "clampctrl")
    for a in range(mj.nu):
        name = _name(mujoco, mj, "actuator", a, f"actuator{a}")
        why = _unread(mujoco, mj, a)
        if why:
            unread.append(f"{name!r} ({why})")
            continue
        symbol = f"ctrl_{name}"
        if symbol in taken or len(symbol) > MAX_NAME_LENGTH:
            raise MjcfError(f"MuJoCo model: actuator {a} ({name!r}) gives the input name "
                            f"{symbol!r}, {'taken' if symbol in taken else 'too long'}; "
                            f"rename the actuator in the file")
        taken.add(symbol)
        fixed = int(mj.actuator_gaintype[a]) == 0
        gain = tuple(float(v) for v in mj.actuator_gainprm[a, :3])
        bias = tuple(float(v) for v in mj.actuator_biasprm[a, :3]) \
            if int(mj.actuator_biastype[a]) else (0.0, 0.0, 0.0)
        out.append(Actuator(
            name, symbol, a, int(mj.actuator_trnid[a, 0]), float(mj.actuator_gear[a, 0]),
            (gain[0], 0.0, 0.0) if fixed else gain, bias,
            tuple(float(v) for v in mj.actuator_ctrlrange[a])
            if clamp_ctrl and mj.actuator_ctrllimited[a] else None,
            tuple(float(v) for v in mj.actuator_forcerange[a])
            if mj.actuator_forcelimited[a] else None))
    if unread:
        dropped.append(f"actuators mbgen does not read: {_listed(unread)}")
    return tuple(out)


def _rotor_terms(mujoco, mj, springs_on: bool, dampers_on: bool):
    """Per degree of freedom, the damping and armature that act: the joint's, plus
    :math:`\\mathrm{gear}^2` times each actuator's on a hinge or slide; refusals found."""
    damping = np.array(mj.dof_damping, dtype=float) if dampers_on else np.zeros(mj.nv)
    armature = np.array(mj.dof_armature, dtype=float)
    refused = []
    for a in range(mj.nu):
        d, arm = float(mj.actuator_damping[a]), float(mj.actuator_armature[a])
        if not (d or arm):
            continue
        j = int(mj.actuator_trnid[a, 0])
        if int(mj.actuator_trntype[a]) in _TRN_JOINT and int(mj.jnt_type[j]) in (HINGE, SLIDE):
            dof, gear2 = int(mj.jnt_dofadr[j]), float(mj.actuator_gear[a, 0]) ** 2
            damping[dof] += gear2 * d if dampers_on else 0.0
            armature[dof] += gear2 * arm
        else:
            refused.append(f"armature or damping of the actuator "
                           f"{_name(mujoco, mj, 'actuator', a, f'actuator{a}')!r} (not on a "
                           f"hinge or slide joint)")
    return tuple(damping), tuple(armature), refused


def _refusals(mujoco, mj, joint_names: list[str]) -> list[str]:
    """What mbgen has no term for, each named (module docstring)."""
    springs, dampers = _on(mj, "spring"), _on(mj, "damper")
    tendon = mj.ntendon > 0
    rows = (
        (np.any(mj.body_gravcomp), "gravity compensation (gravcomp)"),
        (mj.opt.density or mj.opt.viscosity, "fluid forces (option density or viscosity)"),
        (tendon and ((springs and np.any(mj.tendon_stiffness))
                     or (dampers and np.any(mj.tendon_damping))),
         "tendons with stiffness or damping"),
        (tendon and np.any(mj.tendon_armature), "tendon armature"),
        (dampers and (np.any(mj.dof_dampingpoly) or np.any(mj.actuator_dampingpoly)
                      or (tendon and np.any(mj.tendon_dampingpoly))),
         "nonlinear damping (dampingpoly)"))
    problems = [what for test, what in rows if test]
    if springs:
        problems += [f"a spring on the ball or free joint {joint_names[j]!r}"
                     for j in range(mj.njnt)
                     if int(mj.jnt_type[j]) not in (HINGE, SLIDE) and mj.jnt_stiffness[j]]
    return problems


def _contact_example(mujoco, mj) -> str | None:
    """Two geoms MuJoCo may bring into contact (``contype``/``conaffinity``, not one weld
    body, not parent and child unless ``filterparent`` is off, not ``<exclude>``-d), or the
    ``<pair>`` elements; ``None`` if there are none.  Row by row: memory linear in the
    number of geoms, and the first pair found ends the search."""
    if mj.npair:
        return f"{mj.npair} <pair> element(s)"
    body = np.asarray(mj.geom_bodyid)
    weld = np.asarray(mj.body_weldid)[body]
    parent = np.asarray(mj.body_weldid)[np.asarray(mj.body_parentid)[weld]]
    ctype, caff = np.asarray(mj.geom_contype), np.asarray(mj.geom_conaffinity)
    excluded = np.asarray(mj.exclude_signature, dtype=np.int64)
    for i in range(mj.ngeom - 1):
        j = np.arange(i + 1, mj.ngeom)
        can = (((ctype[i] & caff[j]) | (ctype[j] & caff[i])) != 0) & (weld[j] != weld[i])
        if _on(mj, "filterparent") and weld[i]:
            can &= ~(((weld[i] == parent[j]) | (weld[j] == parent[i])) & (weld[j] != 0))
        if excluded.size:           # signature: the lower body id << 16, plus the higher
            lo, hi = np.minimum(body[i], body[j]), np.maximum(body[i], body[j])
            can &= ~np.isin((lo.astype(np.int64) << 16) + hi, excluded)
        if can.any():
            k = int(j[np.argmax(can)])
            a, b = (_name(mujoco, mj, "geom", g, f"geom{g}") for g in (i, k))
            return f"e.g. geoms {a!r} and {b!r}"
    return None


def _dropped(mujoco, mj, joint_names: list[str]) -> list[str]:
    """What mbgen drops, each named (module docstring)."""
    solver = _on(mj, "constraint")
    out = []
    contact = solver and _on(mj, "contact") and _contact_example(mujoco, mj)
    if contact:
        out.append(f"contacts ({contact})")
    if solver and _on(mj, "limit"):
        limited = [joint_names[j] for j in range(mj.njnt) if mj.jnt_limited[j]]
        limited += [_name(mujoco, mj, "tendon", k, f"tendon{k}") for k in range(mj.ntendon)
                    if mj.tendon_limited[k]]
        if limited:
            out.append(f"limits of {_listed(limited)}")
    if solver and _on(mj, "equality") and mj.neq:
        names = [_name(mujoco, mj, "equality", k, f"equality{k}") for k in range(mj.neq)]
        out.append(f"equality constraints ({_listed(names)})")
    if solver and _on(mj, "frictionloss"):
        rubbing = [joint_names[int(mj.dof_jntid[d])] for d in range(mj.nv)
                   if mj.dof_frictionloss[d]]
        rubbing += [_name(mujoco, mj, "tendon", k, f"tendon{k}") for k in range(mj.ntendon)
                    if mj.tendon_frictionloss[k]]
        if rubbing:
            out.append(f"friction loss of {_listed(dict.fromkeys(rubbing))}")
    if mj.nplugin:
        out.append(f"{mj.nplugin} plugin instance(s)")
    if mj.nflex:
        out.append(f"{mj.nflex} flex object(s) (deformable)")
    return out


def read_physics(mj, joint_names: list[str], taken: set[str]) -> Physics:
    """Sort what ``mj`` says (module docstring): :class:`MjcfError` naming every refusal;
    the actuators read, their input names added to ``taken`` (the model's names so far);
    what is dropped, for :func:`warn_dropped`.  ``joint_names``: one per joint, sanitised."""
    import mujoco
    _check_actuator_numbers(mujoco, mj)
    springs, dampers = _on(mj, "spring"), _on(mj, "damper")
    damping, armature, refused = _rotor_terms(mujoco, mj, springs, dampers)
    refused = _refusals(mujoco, mj, joint_names) + refused
    if refused:
        raise MjcfError("MuJoCo model: mbgen does not model " + "; ".join(refused)
                        + "; remove them from the file")
    dropped = _dropped(mujoco, mj, joint_names)
    actuators = _actuators(mujoco, mj, taken, dropped) if _on(mj, "actuation") else ()
    clamped = [a.name for a in actuators if a.ctrlrange]
    if clamped:
        dropped.append(f"the clamping of ctrl to ctrlrange ({_listed(clamped)})")
    forced = [a.name for a in actuators if a.forcerange]
    forced += [joint_names[j] for j in range(mj.njnt) if mj.jnt_actfrclimited[j]
               and any(a.joint == j for a in actuators)]
    if forced:
        dropped.append(f"the clamping of actuator forces to forcerange or "
                       f"actuatorfrcrange ({_listed(forced)})")
    gravity = np.array(mj.opt.gravity, dtype=float) if _on(mj, "gravity") else np.zeros(3)
    return Physics(tuple(float(v) for v in gravity), springs, damping, armature, actuators,
                   tuple(dropped))


def warn_dropped(name: str, dropped) -> None:
    """One :class:`ModelWarning` naming everything dropped, if anything is."""
    if dropped:
        warnings.warn(f"MuJoCo model {name!r}: mbgen drops what it does not model: "
                      + "; ".join(dropped) + " (mj_forward agrees with mbgen with these "
                      "off: opt.disableflags)", ModelWarning, stacklevel=4)


__all__ = ["FLAG", "Actuator", "Physics", "read_physics", "warn_dropped"]
