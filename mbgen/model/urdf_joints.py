r"""What a URDF joint's ``<mimic>``, ``<dynamics>`` and ``<limit>`` become in a Model.

:func:`mbgen.model.urdf.from_urdf` passes its options through :func:`joint_options`;
:func:`mbgen.model.urdf.build_model` asks this module for each moving joint's symbols
(:func:`joint_symbols`), its generalized force (:func:`joint_load`) and its bounds
(:func:`bound_joint`).

Mimic (``mimic=``, :data:`MIMIC_MODES`)
    ``"coupled"`` (the default): a joint with ``<mimic joint="i" multiplier="m"
    offset="o">`` follows the file, :math:`q_j = m\,q_i + o`: a reduced coordinate, no
    constraint.  It has no coordinate, speed or input of its own; its angle (or slide)
    is that expression, so its inertia enters the rows of :math:`q_i`, and whatever
    acts at the joint (its damping, friction, soft limit) enters the generalized force
    of :math:`q_i` times :math:`m` (virtual power: :math:`\dot q_j = m\,u_i`).  A mimic of
    a mimic is composed down to the joint that moves on its own.  This is Pinocchio's
    ``buildModelFromUrdf(path, mimic=True)``: its ``JointModelMimic`` has ``nq = nv = 0``
    and shares the leader's ``idx_q``/``idx_v``, so ``nq`` and ``nv`` shrink by one per
    follower, ``q``, ``v`` and ``tau`` keep the other joints in order, and ``tau_i`` is
    the leader's generalized force, the follower's torque times :math:`m` included.
    ``"independent"``: ``<mimic>`` is ignored and the joint has its own coordinate, as
    Pinocchio's default reads it.
Damping (``damping=True``; off by default)
    the file's ``<dynamics damping="d">`` as :math:`-d\,u` at the joint (N m s/rad, or
    N s/m on a prismatic joint), as MuJoCo applies a joint's damping.
Friction (``friction=True`` or a velocity scale; off by default)
    the file's ``<dynamics friction="f">`` as a regularised Coulomb torque
    :math:`-f \tanh(u / v_f)`; :math:`v_f` is the constant ``friction_velocity``
    (:data:`FRICTION_VELOCITY`, 0.01 rad/s or m/s, unless given): at :math:`|u| = 3 v_f`
    the torque is 99.5 % of :math:`f`, and its slope :math:`f / v_f` at rest makes the
    equations stiff for a small :math:`v_f` (MuJoCo's ``frictionloss`` is a constraint
    instead, not the same model).
Soft limits (``soft_limits={"stiffness": k, "damping": c}``; off by default)
    the range ``[lower, upper]`` of ``<limit>`` on a revolute or prismatic joint as a
    one-sided spring-damper: :math:`-k\,(q - q_\mathrm{upper}) - c\,u` where
    :math:`q > q_\mathrm{upper}`, :math:`-k\,(q - q_\mathrm{lower}) - c\,u` where
    :math:`q < q_\mathrm{lower}`, nothing in between (a sympy ``Piecewise``: a C ternary,
    a Python conditional expression; its derivatives are the branch's, right on either
    side of the kink).  The spring force is continuous at the limit, the damper's jumps
    by :math:`c\,u` there (a Kelvin-Voigt stop).  ``k`` and ``c`` are the constants
    ``limit_stiffness`` and ``limit_damping`` (one pair for every joint; N m/rad or N/m),
    run-time parameters whose defaults are the values given.  An empty range (``lower >=
    upper``: also what a ``<limit>`` without them gives) or a continuous joint has none.
Bounds (always, as data)
    ``<limit effort velocity>`` of a joint with a coordinate of its own become
    ``Model.bound`` records, read back by ``model.bounds("inputs")`` (``tau_<joint>`` in
    ``[-effort, effort]``) and ``model.bounds("speeds")`` (``u_<joint>`` in
    ``[-velocity, velocity]``), and its range ``model.bounds("coordinates")``.  A
    missing, infinite, zero or negative effort or velocity is no bound.  The equations
    never use them: saturating an input is the caller's.

Damping and friction are off by default so that ``from_urdf(path)`` stays Pinocchio's
``aba`` one to one (its ``aba`` ignores ``model.damping`` and ``model.friction``), as it
was before they were read.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sm

from ..errors import ArgumentError, ArgumentTypeError, UrdfSyntaxError

#: How a ``<mimic>`` is read: the joint follows its leader, or moves on its own.
MIMIC_MODES = ("coupled", "independent")

#: Default velocity scale (rad/s, m/s) of the regularised Coulomb friction.
FRICTION_VELOCITY = 0.01


@dataclass(frozen=True)
class SoftLimits:
    """The one-sided spring-damper of the soft joint limits: ``stiffness`` (N m/rad or N/m)
    and ``damping`` (N m s/rad or N s/m), both >= 0."""

    stiffness: float
    damping: float = 0.0


@dataclass(frozen=True)
class JointOptions:
    """What :func:`~mbgen.model.urdf.from_urdf`'s options ask of the joints (module
    docstring); ``friction`` is the velocity scale, None when off."""

    mimic: str = "coupled"
    damping: bool = False
    friction: float | None = None
    soft_limits: SoftLimits | None = None


def joint_options(mimic="coupled", damping=False, friction=False,
                  soft_limits=None) -> JointOptions:
    """The options checked: ``mimic`` one of :data:`MIMIC_MODES`; ``damping`` a bool;
    ``friction`` a bool (True: :data:`FRICTION_VELOCITY`) or a positive velocity scale;
    ``soft_limits`` None, a :class:`SoftLimits` or a mapping of its fields by name."""
    if not isinstance(mimic, str):
        raise ArgumentTypeError(f"from_urdf: mimic must be one of {', '.join(MIMIC_MODES)}, "
                                f"not {type(mimic).__name__} {mimic!r}")
    if mimic not in MIMIC_MODES:
        raise ArgumentError(f"from_urdf: mimic={mimic!r} is not one of "
                            f"{', '.join(map(repr, MIMIC_MODES))}")
    if not isinstance(damping, bool):
        raise ArgumentTypeError(f"from_urdf: damping must be True or False, not "
                                f"{type(damping).__name__} {damping!r}")
    if isinstance(friction, bool):
        scale = FRICTION_VELOCITY if friction else None
    else:
        scale = _number(friction, "friction (a velocity scale)", positive=True)
    return JointOptions(mimic, damping, scale, _soft_limits(soft_limits))


def _soft_limits(value) -> SoftLimits | None:
    if value is None or isinstance(value, SoftLimits):
        given = {} if value is None else {"stiffness": value.stiffness,
                                          "damping": value.damping}
    elif isinstance(value, Mapping):
        unknown = set(value) - {"stiffness", "damping"}
        if unknown or "stiffness" not in value:
            raise ArgumentError(f"from_urdf: soft_limits takes 'stiffness' (required) and "
                                f"'damping' by name; got {sorted(map(str, value))}")
        given = dict(value)
    else:
        raise ArgumentTypeError(f"from_urdf: soft_limits must be None, a SoftLimits or a "
                                f"mapping such as {{'stiffness': 1e3, 'damping': 10}}, not "
                                f"{type(value).__name__}")
    if not given:
        return None
    return SoftLimits(*(_number(given.get(k, 0.0), f"soft_limits {k}")
                        for k in ("stiffness", "damping")))


def _number(value, what: str, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ArgumentTypeError(f"from_urdf: {what} must be a number, not "
                                f"{type(value).__name__} {value!r}")
    if not math.isfinite(value) or value < 0 or (positive and value == 0):
        raise ArgumentError(f"from_urdf: {what} must be a finite number "
                            f"{'> 0' if positive else '>= 0'}; got {value!r}")
    return float(value)


# ------------------------------------------------------------------------------ mimic
def followers(joints, options: JointOptions) -> dict[str, tuple[str, float, float]]:
    """``{follower: (leader, multiplier, offset)}`` of the moving ``joints``, composed down
    to a leader that moves on its own (none when ``options.mimic`` is independent)."""
    if options.mimic != "coupled":
        return {}
    by_name = {j.name: j for j in joints}
    out = {}
    for j in joints:
        if j.mimic is None:
            continue
        a, b, k = 1.0, 0.0, j
        while k.mimic is not None:   # q_j = a q_k + b, q_k = m q_l + o
            a, b, k = a * k.mimic.multiplier, a * k.mimic.offset + b, by_name[k.mimic.joint]
        out[j.name] = (k.name, a, b)
    return out


@dataclass(frozen=True)
class JointSymbols:
    """A moving joint's coordinate ``q`` and speed ``u`` (symbols, or a follower's
    expressions in its leader's) and input ``tau`` (0 for a follower)."""

    q: object
    u: object
    tau: object
    own: bool


def joint_symbols(m, joints, identifier, options: JointOptions) -> dict[str, JointSymbols]:
    """Declare on ``m`` the coordinate, speed and input of each of the moving ``joints``
    that moves on its own (in order, named ``q_``, ``u_``, ``tau_`` + ``identifier(name)``)
    and express each follower's in its leader's."""
    coupled = followers(joints, options)
    out: dict[str, JointSymbols] = {}
    for j in joints:
        if j.name not in coupled:
            base = identifier(j.name)
            (q,), (u,), (tau,) = (m.coordinates(f"q_{base}"), m.speeds(f"u_{base}"),
                                  m.inputs(f"tau_{base}"))
            out[j.name] = JointSymbols(q, u, tau, True)
    for name, (leader, a, b) in coupled.items():
        lead = out[leader]
        out[name] = JointSymbols(_affine(lead.q, a, b), _affine(lead.u, a, 0.0), 0, False)
    return out


def _affine(x, a: float, b: float):
    y = x if a == 1 else -x if a == -1 else a * x
    return y + b if b else y


# ------------------------------------------------------------------------------ loads
def damping_load(joint, q, u, c):
    return -joint.damping * u if joint.damping else 0


def friction_load(joint, q, u, c):
    return -joint.friction * sm.tanh(u / c["friction_velocity"]) if joint.friction else 0


def soft_limit_load(joint, q, u, c):
    limit = joint.limit
    if joint.type == "continuous" or limit is None or not limit.lower < limit.upper:
        return 0
    k, d = c["limit_stiffness"], c["limit_damping"]
    pieces = [(-k * (q - end) - d * u, test(q, end))
              for end, test in ((limit.upper, sm.StrictGreaterThan),
                                (limit.lower, sm.StrictLessThan)) if math.isfinite(end)]
    return sm.Piecewise(*pieces, (0, True)) if pieces else 0


#: The joint loads the options switch on: option -> (its constants with their defaults
#: from the options, the generalized force at one joint from the file's numbers, the
#: joint's coordinate ``q`` and speed ``u`` and the constants ``c`` by name).
JOINT_LOADS = {
    "damping": ((), damping_load),
    "friction": ((("friction_velocity", lambda o: o.friction),), friction_load),
    "soft_limits": ((("limit_stiffness", lambda o: o.soft_limits.stiffness),
                     ("limit_damping", lambda o: o.soft_limits.damping)), soft_limit_load),
}


def active_loads(options: JointOptions) -> list[str]:
    """The rows of :data:`JOINT_LOADS` the options switch on."""
    return [name for name in JOINT_LOADS if getattr(options, name) not in (None, False)]


def load_constants(options: JointOptions) -> dict[str, float]:
    """``{constant: default}`` the switched-on loads declare."""
    return {name: float(value(options)) for row in active_loads(options)
            for name, value in JOINT_LOADS[row][0]}


def check_dynamics(robot, options: JointOptions) -> None:
    """The file's damping and friction are >= 0 where the options use them."""
    for key in ("damping", "friction"):
        if key not in active_loads(options):
            continue
        for j in robot.ordered_joints():
            if getattr(j, key) < 0:
                raise UrdfSyntaxError(
                    f"URDF file {robot.source!r}, joint {j.name!r}: <dynamics {key}="
                    f"\"{getattr(j, key)}\"> is negative, which would feed energy in; give "
                    f"a value >= 0, or leave {key} off")


def joint_load(joint, symbols: JointSymbols, constants: dict, options: JointOptions):
    """The generalized force at ``joint``: its input plus the switched-on loads."""
    return sm.Add(symbols.tau, *(JOINT_LOADS[row][1](joint, symbols.q, symbols.u, constants)
                                 for row in active_loads(options)))


def bound_joint(m, joint, symbols: JointSymbols) -> None:
    """Record ``joint``'s ``<limit>`` on ``m`` as bounds (module docstring), if it has a
    coordinate of its own."""
    limit = joint.limit
    if limit is None or not symbols.own:
        return
    for value, symbol in ((limit.effort, symbols.tau), (limit.velocity, symbols.u)):
        if 0 < value < math.inf:
            m.bound(symbol, -value, value)
    if joint.type != "continuous" and limit.lower < limit.upper:
        m.bound(symbols.q, limit.lower, limit.upper)
