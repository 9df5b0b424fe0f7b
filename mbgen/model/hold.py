r"""Hold a posture: a joint PD controller generated into the model, so a robot can stand.

With zero joint torques a legged robot's legs fold under it on any ground.
:func:`hold_posture` adds, for each joint input :math:`\tau_j` (the effort of coordinate
:math:`q_j` with speed :math:`u_j`), the generalized force

.. math::

    \tau^{hold}_j = -k_p\,(q_j - q^{ref}_j) - k_d\,u_j

where :math:`\tau_j` acts (the same loads, scaled), so the input still adds to it.
:math:`k_p` and :math:`k_d` are the run-time constants ``kp_hold`` (N m/rad) and
``kd_hold`` (N m s/rad) and each reference :math:`q^{ref}_j` the constant ``<q_j>_ref``
(``q_FL_HFE_ref``), defaults as given; ``mbgen simulate --hold KP,KD`` sets the
references to the initial state, so the robot holds the posture it starts in.  It is
a spring of stiffness :math:`k_p` and a damper at every joint: it stores
:math:`\tfrac12 k_p (q_j - q^{ref}_j)^2` and dissipates :math:`k_d u_j^2`, so it keeps a
dropped robot's energy falling (:mod:`mbgen.model.ground`).

The joints are found by name: every input ``tau_X`` of a coordinate ``q_X`` with speed
``u_X`` (how :func:`mbgen.from_urdf` names a joint's), or ``joints`` given as
``{input: (coordinate, speed)}``.  An input acts through the loads that hold it (a torque
about the joint axis with its reaction, a force along a slide), linearly, so the hold
is each such load's derivative with respect to the input times
:math:`\tau^{hold}_j`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sm
from sympy.physics import vector as spv

from ..errors import ModelError
from .elements import Force, Torque

#: The names of the gains.
GAINS = ("kp_hold", "kd_hold")


@dataclass(frozen=True)
class Hold:
    """What :func:`hold_posture` added: the gains and, per held joint, its input,
    coordinate, speed and reference constant (names)."""

    gains: tuple
    joints: tuple   # of (input, coordinate, speed, reference) names


def reference_name(coordinate: str) -> str:
    """The constant holding ``coordinate``'s reference: ``<coordinate>_ref``."""
    return f"{coordinate}_ref"


def hold_gains(value) -> tuple[float, float]:
    """``(kp, kd)`` from a pair of numbers or the text ``"KP,KD"`` (``--hold 50,0.5``)."""
    parts = value.split(",") if isinstance(value, str) else value
    try:
        kp, kd = (float(v) for v in parts)
    except (TypeError, ValueError):
        raise ModelError(f"hold={value!r}: give the gains as KP,KD (e.g. 50,0.5: N m/rad and "
                         f"N m s/rad)") from None
    return kp, kd


def hold_posture(model, kp: float, kd: float, reference: Mapping | None = None,
                 joints: Mapping | None = None) -> Hold:
    """Hold the posture ``reference`` (``{coordinate: value}``, others 0) with gains ``kp``,
    ``kd`` (numbers >= 0, the defaults of ``kp_hold`` and ``kd_hold``) at ``joints``
    (default: every ``tau_X`` with ``q_X`` and ``u_X``; module docstring)."""
    gains = []
    for name, value in zip(GAINS, (kp, kd)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value) or value < 0:
            raise ModelError(f"hold: {name} must be a finite number >= 0, got {value!r}")
        gains.append(float(value))
    pairs = _pairs(model, joints)
    reference = dict(reference or {})
    unknown = set(reference) - {q for _, q, _ in pairs}
    if unknown:
        raise ModelError(f"hold: reference names {sorted(unknown)}, which are not held "
                         f"coordinates ({', '.join(q for _, q, _ in pairs)})")
    kp_s, kd_s = model.constants(list(GAINS), defaults=gains)
    refs = model.constants([reference_name(q) for _, q, _ in pairs],
                           defaults=[float(reference.get(q, 0.0)) for _, q, _ in pairs])
    table = {str(s.func): s for s in model.coordinates_ + model.speeds_ + model.inputs_}
    added = []
    for (r, q, u), ref in zip(pairs, refs):
        law = -kp_s * (table[q] - ref) - kd_s * table[u]
        _act_like(model, table[r], law)
        added.append((r, q, u, str(ref)))
    return Hold(GAINS, tuple(added))


def _pairs(model, joints) -> list[tuple[str, str, str]]:
    coords = {str(s.func) for s in model.coordinates_}
    speeds = {str(s.func) for s in model.speeds_}
    inputs = [str(s.func) for s in model.inputs_]
    if joints is None:
        pairs = [(r, "q_" + r[4:], "u_" + r[4:]) for r in inputs
                 if r.startswith("tau_") and "q_" + r[4:] in coords and "u_" + r[4:] in speeds]
        if not pairs:
            raise ModelError(f"hold: model {model.name!r} has no input tau_X with coordinate "
                             f"q_X and speed u_X (a URDF robot's joints); give joints={{input: "
                             f"(coordinate, speed)}}")
        return pairs
    pairs = []
    for r, (q, u) in dict(joints).items():
        r, q, u = (str(getattr(v, "func", v)) for v in (r, q, u))
        if r not in inputs or q not in coords or u not in speeds:
            raise ModelError(f"hold: {r!r} -> ({q!r}, {u!r}) must name an input, a coordinate "
                             f"and a speed of model {model.name!r}")
        pairs.append((r, q, u))
    return pairs


def _derivative(vector, symbol) -> spv.Vector:
    return spv.Vector([(m.diff(symbol), f) for m, f in vector.args]) if vector != 0 else vector


def _act_like(model, tau, law) -> None:
    """Add ``law`` where the input ``tau`` acts: each load holding it, scaled by ``law``
    over ``tau`` (a load is linear in its inputs)."""
    found = False
    for load in list(model.loads):
        if not isinstance(load, (Force, Torque)) or load.vector == 0:
            continue
        per_unit = _derivative(load.vector, tau)
        if per_unit == 0:
            continue
        found = True
        scaled = spv.Vector([(sm.Matrix(m) * law, f) for m, f in per_unit.args])
        if isinstance(load, Force):
            model.force(load.point, scaled, reaction=load.reaction)
        else:
            model.torque(load.frame, scaled, reaction=load.reaction)
    if not found:
        raise ModelError(f"hold: input {tau.func} acts through no force or torque of model "
                         f"{model.name!r}")


__all__ = ["GAINS", "Hold", "hold_gains", "hold_posture", "reference_name"]
