r"""A URDF robot as a :class:`~mbgen.model.builder.Model`: :func:`from_urdf`.

What is read (:mod:`mbgen.model.urdf_xml` checks it all before anything is built):
links with their ``<inertial>`` (mass, ``<origin xyz rpy>``, full inertia tensor)
and joints of type revolute, continuous, prismatic and fixed, with ``<origin xyz
rpy>``, any ``<axis>`` (normalised), ``<mimic>``, ``<dynamics>`` and ``<limit>``
(:mod:`mbgen.model.urdf_joints`: what each becomes, and the options that ask for it).
Visuals, collisions, meshes and transmissions are not read.

Conventions (Pinocchio's, so its results compare one to one):

* one coordinate ``q_<joint>``, speed ``u_<joint>`` (``u = q'``) and input
  ``tau_<joint>`` (a torque about the axis, a force along it for a prismatic
  joint) per moving joint that is no mimic's follower, in the order of
  ``pinocchio.buildModelFromUrdf(path, mimic=True).names``: depth first from the root link,
  the joints below a link sorted by name.  Joint and link names are sanitised
  to identifiers (characters other than letters, digits and ``_`` become
  ``_``); two that become the same name are an error.  A continuous joint has
  one angle (Pinocchio stores its cosine and sine).
* fixed joints are merged: the child's mass, centre and inertia join its
  parent's (Pinocchio does the same), so a fixed link costs nothing.
* ``floating=True`` puts a free-flyer on the root link: coordinates
  ``root_x, root_y, root_z`` (the root frame's origin in the world) and the unit
  quaternion ``root_qx, root_qy, root_qz, root_qw``; speeds ``root_vx, root_vy,
  root_vz`` (velocity of that origin) and ``root_wx, root_wy, root_wz`` (angular
  velocity), both in root-frame components.  ``q'`` follows from ``u`` by the
  quaternion kinematics, :math:`\dot p = R v`, :math:`\dot q = \tfrac12 q \otimes
  (0, \omega)`.  The quaternion is normalised where it is read: the rotation
  matrix is the homogeneous form divided by :math:`|q|^2`, so any nonzero
  quaternion gives a proper rotation; :math:`\dot q` keeps :math:`|q|` constant
  exactly, and an integrator's drift of the norm changes nothing physical
  (renormalise between steps when you like).  In the generated code
  :math:`1/|q|^2` is one division, read by the root's rotation alone: every
  body below the root is placed relative to the root's frame, and Newton–Euler
  sees the free-flyer as one joint that owns its six speeds, with the identity
  for its motion subspace and :math:`\omega\times v` (and gravity turned into the
  root's frame) for its bias, :math:`R^T R` cancelled exactly
  (:mod:`mbgen.derivation.recursion`), so the articulated-body recursion applies.
* gravity is ``-g`` along the world's z axis, ``g`` the model's first constant, 9.81 by
  default (:data:`GRAVITY`: URDF states no gravity; ROS and Pinocchio take standard
  gravity along -z), so a model compiled as it is runs with it.  Every inertial number of
  the file is baked into the model as a number, as a robot's code is usually wanted.

Angles of ``rpy`` within 1e-12 rad of a multiple of pi/2 are taken as that
multiple (a cosine of ``1.5707963267948966`` is 6e-17, not 0), which keeps
axis-aligned frames free of such terms and changes no result by more than 1e-12.
For the same reason the components of an offset, a mass centre or an inertia
tensor below 1e-12 of its largest are zero: the rounding of the constant
rotations that bring a tilted axis onto a coordinate axis (Unitree G1's arms:
offsets of 6e-18 m, products of inertia of 1e-19) would otherwise cost
operations in every recursion through them.
"""

from __future__ import annotations

import math
import re

import numpy as np
import sympy as sm

from ..errors import ArgumentTypeError, UrdfInertiaError, UrdfStructureError
from ..names import C_KEYWORDS, MAX_NAME_LENGTH, did_you_mean
from . import free_base
from .builder import Model
from .limits import allow_large_models, check_size
from .urdf_joints import (
    JointOptions,
    bound_joint,
    check_dynamics,
    followers,
    joint_load,
    joint_options,
    joint_symbols,
    load_constants,
)
from .urdf_xml import Robot, read_urdf

#: Free-flyer coordinate and speed names, in Pinocchio's order.
FLOATING_Q = ("root_x", "root_y", "root_z", "root_qx", "root_qy", "root_qz", "root_qw")
FLOATING_U = ("root_vx", "root_vy", "root_vz", "root_wx", "root_wy", "root_wz")

#: Gravity (m/s^2) a URDF model's constant ``g`` defaults to: standard gravity along -z.
GRAVITY = 9.81

_SNAP = 1e-12


def from_urdf(path, *, floating: bool = False, force: bool = False, mimic: str = "coupled",
              damping: bool = False, friction=False, soft_limits=None,
              strict: bool = False, ground=None, contacts=()) -> Model:
    """The robot of the URDF file at ``path`` as a :class:`Model` (see the module docstring).

    Parameters
    ----------
    floating : bool
        A free-flyer on the root link (a bool: the string ``"false"`` is refused).
    force : bool
        Read and build past the size guard (:mod:`mbgen.model.limits`).
    mimic, damping, friction, soft_limits
        What the joints' ``<mimic>``, ``<dynamics>`` and ``<limit>`` become
        (:func:`mbgen.model.urdf_joints.joint_options`): by default a mimic joint follows
        its leader (no coordinate of its own) and no damping, friction or soft limit acts,
        so the model is Pinocchio's ``buildModelFromUrdf(path, mimic=True)`` one to one.
    strict : bool
        Refuse an inertia that breaks the triangle inequality (else read with a
        :class:`~mbgen.errors.ModelWarning`, :mod:`mbgen.model.urdf_xml`).
    ground : sequence of str, str or mapping, optional
        A compliant ground (:meth:`Model.ground <mbgen.model.builder.Model.ground>`,
        :mod:`mbgen.model.ground`) touched by the origins of these links (``("FL_FOOT",
        ...)`` or ``"FL_FOOT,FR_FOOT"``; a link merged into its parent by a fixed joint
        too), each a point named after its link (``<link>_origin`` where that name is
        the link's body's); a mapping ``{link: radius}`` makes
        each a sphere.  Its stiffness and damping follow from the robot's mass.
    contacts : sequence of str
        Links (a link merged away by a fixed joint included: a foot) whose origin is a
        rigid point contact with the ground (:meth:`mbgen.Model.contact`, named after the
        link, in the order given): Pinocchio's ``RigidConstraintModel(CONTACT_3D, ...,
        LOCAL_WORLD_ALIGNED)`` at that frame; its force is the ``constraint_forces`` output.

    Raises
    ------
    UrdfError
        Naming the file, the link or joint and the fix: a path that is no regular
        file, unsafe or malformed XML, a file over 100 MiB, a number out of range, a
        missing or negative mass, an inertia that is not positive semidefinite, a
        floating root that moves no mass some way (:mod:`mbgen.model.free_base`), an
        unknown joint type, a mimic of no moving joint or a cycle of them, a link with
        two parents, a cycle, no root, names that collide.  Nothing is built when one
        is raised.
    ModelSizeError
        More than :data:`~mbgen.model.limits.MAX_SPEEDS` speeds (unless forced).
    ArgumentError
        An option of the wrong type (:class:`~mbgen.errors.ArgumentTypeError`) or value.
    """
    for name, value in (("floating", floating), ("strict", strict)):
        if not isinstance(value, (bool, np.bool_)):
            raise ArgumentTypeError(f"from_urdf: {name} must be True or False, not "
                                    f"{type(value).__name__} {value!r}")
    options = joint_options(mimic, damping, friction, soft_limits)
    if force:
        with allow_large_models():
            return build_model(read_urdf(path, strict=bool(strict)), floating=bool(floating),
                               options=options, ground=ground,
                               contacts=contact_names(contacts, "from_urdf"))
    return build_model(read_urdf(path, strict=bool(strict)), floating=bool(floating),
                       options=options, ground=ground,
                       contacts=contact_names(contacts, "from_urdf"))


def contact_names(contacts, where: str) -> tuple[str, ...]:
    """``contacts`` (a name or a sequence of names) as a tuple of distinct strings."""
    names = (contacts,) if isinstance(contacts, str) else contacts
    try:
        names = tuple(names)
    except TypeError:
        names = (None,)
    if not all(isinstance(n, str) for n in names):
        raise ArgumentTypeError(f"{where}: contacts must be link or frame names (strings), "
                                f"got {contacts!r}")
    if len(set(names)) != len(names):
        raise ArgumentTypeError(f"{where}: contacts names a frame twice: {list(names)}")
    return names


# ------------------------------------------------------------------------------ rotations
def _cos_sin(angle: float) -> tuple[float, float]:
    quarter = round(angle / (math.pi / 2))
    if abs(angle - quarter * math.pi / 2) < _SNAP:
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[quarter % 4]
    return math.cos(angle), math.sin(angle)


def simple(axis: int, angle: float) -> np.ndarray:
    """Rotation matrix about axis 1, 2 or 3 (columns: the new basis in the old)."""
    c, s = _cos_sin(angle)
    i, j = {1: (1, 2), 2: (2, 0), 3: (0, 1)}[axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def rpy_matrix(rpy) -> np.ndarray:
    """URDF's ``rpy``: roll about x, then pitch about y, then yaw about z (fixed axes)."""
    r, p, y = rpy
    return simple(3, y) @ simple(2, p) @ simple(1, r)


def axis_rotation(a: np.ndarray) -> tuple[list, int, int]:
    """``(steps, k, s)``: constant simple rotations ``C`` (``[(axis, angle)]``) with
    ``C e_k = s a``, as few as the axis allows (none for a coordinate axis)."""
    small = [abs(x) < _SNAP for x in a]
    if sum(small) == 2:
        k = small.index(False)
        return [], k + 1, 1 if a[k] > 0 else -1
    if small[0]:
        return [(1, math.atan2(a[2], a[1]))], 2, 1
    if small[1]:
        return [(2, math.atan2(a[0], a[2]))], 3, 1
    if small[2]:
        return [(3, math.atan2(a[1], a[0]))], 1, 1
    return [(3, math.atan2(a[1], a[0])), (2, math.atan2(math.hypot(a[0], a[1]), a[2]))], 3, 1


def turned_frame(m, parent, internal, label: str, a: np.ndarray, q):
    """``(frame, C, k, s)``: a frame turned from ``parent`` about the unit axis ``a`` (in
    ``parent``) by ``q``, as ``m.rotate`` steps: the constant rotations ``C`` of
    :func:`axis_rotation` (frames ``<label>_axis<n>``), then ``s q`` about axis ``k``
    (frame ``<label>_frame``); ``internal`` makes a frame's name.  The joint's torque
    acts about ``(frame.x, frame.y, frame.z)[k - 1]`` times ``s``."""
    steps, k, s = axis_rotation(a)
    frame, C = parent, np.eye(3)
    for n, (axis, angle) in enumerate(steps):
        frame = m.rotate(frame, internal(f"{label}_axis{n}"), axis, angle)
        C = C @ simple(axis, angle)
    return m.rotate(frame, internal(f"{label}_frame"), k, s * q), C, k, s


def quaternion_matrix(x, y, z, w):
    """Rotation of the unit quaternion ``w + x i + y j + z k``, normalised where read."""
    n = x * x + y * y + z * z + w * w
    return sm.Matrix([
        [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]]) / n


# ------------------------------------------------------------------------------ names
def identifier(name: str) -> str:
    """A URDF name as an identifier: other characters than ``[A-Za-z0-9_]`` become ``_``."""
    return re.sub(r"[^A-Za-z0-9_]", "_", name.encode("ascii", "replace").decode())


class _Names:
    """Every name the model will hold, chosen before anything is built."""

    def __init__(self, robot: Robot):
        self.robot = robot
        self.taken: dict[str, str] = {}

    def visible(self, name: str, what: str) -> str:
        if len(name) > MAX_NAME_LENGTH:
            raise UrdfStructureError(
                f"URDF file {self.robot.source!r}: {what} gives the name {name[:40]!r}... of "
                f"{len(name)} characters, over mbgen's {MAX_NAME_LENGTH}; shorten it")
        if name in self.taken:
            raise UrdfStructureError(
                f"URDF file {self.robot.source!r}: {what} and {self.taken[name]} both become "
                f"the name {name!r} (names are sanitised to letters, digits and '_'); rename "
                f"one of them in the file")
        self.taken[name] = what
        return name

    def internal(self, base: str) -> str:
        name, k = base[:MAX_NAME_LENGTH - 4], 2
        while name in self.taken:
            name, k = f"{base[:MAX_NAME_LENGTH - 4]}_{k}", k + 1
        self.taken[name] = "internal"
        return name


def model_name(robot: Robot) -> str:
    name = identifier(robot.name)[:48] or "robot"
    if not name[0].isalpha():
        name = "robot_" + name
    return name + "_robot" if name in C_KEYWORDS or name.startswith("__") else name


# ------------------------------------------------------------------------------ building
class Group:
    """A rigid body: a moving link and the links fixed to it, in frame ``frame`` from ``point``."""

    def __init__(self, name, frame, point):
        self.name, self.frame, self.point = name, frame, point
        self.parts: list[tuple[float, np.ndarray, np.ndarray]] = []  # mass, centre, inertia

    def add(self, inertial, A: np.ndarray, d: np.ndarray) -> None:
        if inertial is None:
            return
        R = A @ rpy_matrix(inertial.rpy)
        self.parts.append((inertial.mass, d + A @ np.array(inertial.xyz),
                           R @ np.array(inertial.inertia) @ R.T))

    def combined(self):
        """``(mass, centre, inertia about the centre)`` of the parts, or None if massless."""
        mass = sum(m for m, _, _ in self.parts)
        if mass == 0 and not any(np.any(I) for _, _, I in self.parts):
            return None
        centre = sum((m * c for m, c, _ in self.parts), np.zeros(3)) / mass if mass else \
            np.zeros(3)
        inertia = np.zeros((3, 3))
        for m, c, I in self.parts:
            r = c - centre
            inertia += I + m * (r @ r * np.eye(3) - np.outer(r, r))
        inertia = (inertia + inertia.T) / 2
        diagonal = np.diag(inertia).copy()   # kept as it is: a pivot, however small
        inertia = snap(inertia)
        np.fill_diagonal(inertia, diagonal)
        return mass, snap(centre), inertia


def snap(values: np.ndarray) -> np.ndarray:
    """``values`` with the entries below 1e-12 of the largest set to zero (rounding)."""
    values = np.array(values, dtype=float)
    values[np.abs(values) <= _SNAP * np.abs(values).max(initial=0.0)] = 0.0
    return values


def frame_vector(frame, comps) -> object:
    comps = snap(comps)
    terms = [float(c) * e for c, e in zip(comps, (frame.x, frame.y, frame.z)) if c != 0]
    return sum(terms[1:], terms[0]) if terms else 0


#: The joint options :func:`build_model` applies when given none (the defaults of each).
_DEFAULT_JOINT_OPTIONS = JointOptions()


def build_model(robot: Robot, *, floating: bool = False,
                options: JointOptions = _DEFAULT_JOINT_OPTIONS, ground=None,
                contacts=()) -> Model:
    """The :class:`Model` of a checked :class:`~mbgen.model.urdf_xml.Robot`, its joints as
    ``options`` say (:mod:`mbgen.model.urdf_joints`): its size, (``floating``) its root
    and the numbers the options use are checked before anything is made."""
    joints = [j for j in robot.ordered_joints() if j.type != "fixed"]
    coupled = followers(joints, options)
    own = len(joints) - len(coupled)
    check_size(own + 6 * floating,
               f"URDF file {robot.source!r} with {own} moving joints"
               f"{' on a floating base' if floating else ''}")
    if floating:
        check_floating_root(robot)
    check_dynamics(robot, options)
    constants = {"g": GRAVITY, **load_constants(options)}
    names, body_names = _visible_names(robot, joints, coupled, constants, floating)
    m = Model(model_name(robot))
    N = m.newtonian(names.internal("N"), names.internal("O"))
    c = dict(zip(constants, m.constants(" ".join(constants), defaults=list(constants.values()))))
    if floating:
        root = _floating_root(m, names, body_names[robot.root])
    else:
        root = Group(None, N, m.origin)
    symbols = joint_symbols(m, joints, identifier, options)
    groups = {robot.root: root}
    place = {robot.root: (np.eye(3), np.zeros(3))}   # link -> (A, d) in its group
    for j in robot.ordered_joints():
        parent = groups[j.parent]
        A, d = place[j.parent]
        J = A @ rpy_matrix(j.rpy)
        offset = d + A @ np.array(j.xyz)
        if j.type == "fixed":
            groups[j.child], place[j.child] = parent, (J, offset)
            continue
        q, load = symbols[j.name].q, joint_load(j, symbols[j.name], c, options)
        bound_joint(m, j, symbols[j.name])
        a = J @ np.array(j.axis)
        link = body_names[j.child]
        if j.type == "prismatic":
            groups[j.child], place[j.child] = _slide(m, names, link, parent, J, offset, a, q,
                                                     load)
        else:
            groups[j.child], place[j.child] = _turn(m, names, link, parent, J, offset, a, q,
                                                    load)
    for link, (A, d) in place.items():
        groups[link].add(robot.links[link].inertial, A, d)
    for group in dict.fromkeys(groups.values()):
        if group.name is not None:
            _add_body(m, names, group)
    m.gravity(-c["g"] * N.z)
    if ground:
        _ground(m, robot, names, groups, place, ground)
    _contacts(m, robot, names, groups, place, contacts)
    return m


def _contacts(m: Model, robot: Robot, names: _Names, groups, place, contacts) -> None:
    """``m.contact`` at the origin of each link of ``contacts`` (:func:`from_urdf`), in the
    body it belongs to (a link merged by a fixed joint included), named after the link."""
    for link in contacts:
        if link not in robot.links:
            raise UrdfStructureError(f"URDF file {robot.source!r} has no link {link!r} for a "
                                     f"contact{did_you_mean(link, list(robot.links))}")
    for link in contacts:
        group, d = groups[link], place[link][1]
        name = identifier(link) if identifier(link)[:1].isalpha() else "link_" + identifier(link)
        point = group.point if not snap(d).any() else \
            m.point(names.internal(f"{name}_contact"), group.point, frame_vector(group.frame, d))
        m.contact(point, name=name)


def _ground(m: Model, robot: Robot, names: _Names, groups, place, ground) -> None:
    """``m.ground`` at a point on each link of ``ground`` (:func:`from_urdf`), at the link's
    origin in the body it belongs to (a link merged by a fixed joint included)."""
    links, radii = ground_links(ground)
    for link in links:
        if link not in robot.links:
            raise UrdfStructureError(f"URDF file {robot.source!r} has no link {link!r} for the "
                                     f"ground{did_you_mean(link, list(robot.links))}")
    points = []
    for link in links:
        base = identifier(link) if identifier(link)[:1].isalpha() else "link_" + identifier(link)
        name = names.internal(base + "_origin" if base in names.taken else base)
        points.append(m.point(name, groups[link].point,
                              frame_vector(groups[link].frame, place[link][1])))
    m.ground(points, radius=radii)


def ground_links(ground) -> tuple[list[str], list[float]]:
    """``(links, radii)`` of :func:`from_urdf`'s ``ground``: names (a sequence, or one string
    of comma-separated names), or a mapping of names to sphere radii."""
    if isinstance(ground, str):
        ground = [n.strip() for n in ground.split(",") if n.strip()]
    if isinstance(ground, dict):
        links, radii = list(ground), list(ground.values())
    elif isinstance(ground, (list, tuple)):
        links, radii = list(ground), [0.0] * len(ground)
    else:
        links, radii = [None], [0.0]
    if not all(isinstance(n, str) for n in links) or not all(
            isinstance(r, (int, float)) and not isinstance(r, bool) for r in radii):
        raise ArgumentTypeError(f"from_urdf: ground must be link names (a sequence or "
                                f"'A,B,C') or a mapping link -> radius, not {ground!r:.60}")
    return links, [float(r) for r in radii]


def _visible_names(robot: Robot, joints, coupled, constants, floating: bool):
    """``(names, body_names)``: the model's visible names reserved (the constants, each
    uncoupled joint's coordinate, speed and input, the floating base's), and the name of
    each moving link's body by link."""
    names = _Names(robot)
    for name in constants:
        names.visible(name, "the gravity constant" if name == "g" else "a joint-load constant")
    for j in joints:
        base = identifier(j.name)
        for prefix in ("q", "u", "tau"):  # its coordinate, speed and input
            if j.name not in coupled:
                names.visible(f"{prefix}_{base}", f"joint {j.name!r}")
    if floating:
        for n in FLOATING_Q + FLOATING_U:
            names.visible(n, "the floating base")
    moving = [robot.root] if floating else []
    moving += [j.child for j in joints]
    body_names = {link: names.visible(identifier(link) if identifier(link)[:1].isalpha()
                                      else "link_" + identifier(link), f"link {link!r}")
                  for link in moving}
    return names, body_names


def _slide(m: Model, names: _Names, link: str, parent: Group, J, offset, a, q, load):
    """A prismatic joint's child group (``link``, sliding along ``a`` by ``q`` from the
    anchor at ``offset`` in ``parent``) and the link's place in it; ``load`` acts along
    the axis."""
    anchor = parent.point if not offset.any() else \
        m.point(names.internal(f"{link}_anchor"), parent.point,
                frame_vector(parent.frame, offset))
    point = m.point(names.internal(f"{link}_J"), anchor,
                    frame_vector(parent.frame, a) * q)
    child = Group(link, parent.frame, point)
    if load != 0:
        m.force(point, load * frame_vector(parent.frame, a), reaction=anchor)
    return child, (J, np.zeros(3))


def _turn(m: Model, names: _Names, link: str, parent: Group, J, offset, a, q, load):
    """A revolute or continuous joint's child group (``link``, its frame turned about
    ``a`` by ``q`` at ``offset`` in ``parent``) and the link's place in it; ``load`` acts
    about the axis."""
    point = parent.point if not offset.any() else \
        m.point(names.internal(f"{link}_J"), parent.point,
                frame_vector(parent.frame, offset))
    frame, C, k, s = turned_frame(m, parent.frame, names.internal, link, a, q)
    child = Group(link, frame, point)
    if load != 0:
        m.torque(frame, s * load * (frame.x, frame.y, frame.z)[k - 1],
                 reaction=parent.frame)
    return child, (C.T @ J, np.zeros(3))


def _add_body(m: Model, names: _Names, group: Group) -> None:
    made = group.combined()
    if made is None:
        return
    mass, centre, inertia = made
    point = group.point if not centre.any() else \
        m.point(names.internal(f"{group.name}_G"), group.point, frame_vector(group.frame, centre))
    m.body(group.name, group.frame, float(mass), [[float(v) for v in row] for row in inertia],
           point)


# ------------------------------------------------------------------------------ floating root
def check_floating_root(robot: Robot, samples: int = 2) -> None:
    """Refuse a floating root that some motion moves without moving mass
    (:mod:`mbgen.model.free_base`): a singular mass matrix at every state.  Tried at
    ``samples`` pseudo-random joint angles; refused only where every one lacks."""
    rng = np.random.default_rng(0)
    found = [free_base.lack(robot_parts(robot, rng.uniform(-np.pi, np.pi, len(robot.joints))))
             for _ in range(samples)]
    if all(found):
        raise UrdfInertiaError(
            f"URDF file {robot.source!r}: the floating root link {robot.root!r} with all it "
            f"carries has {found[0]} (some motion of the root the joints below undo, so that "
            f"nothing with mass moves): the mass matrix is singular at every state; give "
            f"link {robot.root!r} an <inertial> with a positive mass and inertia, or fix "
            f"the base (floating=False)")


def robot_parts(robot: Robot, angles) -> list:
    """The links as :class:`~mbgen.model.free_base.Part` rows, the joints (in order) at
    ``angles``, the root at the world's origin."""
    pose = {robot.root: (np.eye(3), np.zeros(3))}
    index = {robot.root: 0}
    parts = [_part(robot, robot.root, -1, free_base.NO_MOTION, *pose[robot.root])]
    for j, q in zip(robot.ordered_joints(), angles):
        R, p = pose[j.parent]
        R, p = R @ rpy_matrix(j.rpy), p + R @ np.array(j.xyz)
        a = R @ np.array(j.axis)
        if j.type == "fixed":
            motion = free_base.NO_MOTION
        elif j.type == "prismatic":
            motion, p = free_base.prismatic_motion(a), p + q * a
        else:
            motion = free_base.revolute_motion(a, p)
            turn = free_base.skew(a)
            R = (np.eye(3) + math.sin(q) * turn + (1 - math.cos(q)) * turn @ turn) @ R
        pose[j.child], index[j.child] = (R, p), len(parts)
        parts.append(_part(robot, j.child, index[j.parent], motion, R, p))
    return parts


def _part(robot: Robot, link: str, parent: int, motion, R, p):
    inertial = robot.links[link].inertial
    if inertial is None:
        return free_base.Part(parent, motion, np.zeros((6, 6)), 0.0, p)
    Ri = R @ rpy_matrix(inertial.rpy)
    centre = p + R @ np.array(inertial.xyz)
    inertia = free_base.body_inertia(inertial.mass, centre,
                                     Ri @ np.array(inertial.inertia) @ Ri.T)
    return free_base.Part(parent, motion, inertia, inertial.mass, centre)


def _floating_root(m: Model, names: _Names, link: str) -> Group:
    """The free-flyer: the root link's frame at the quaternion, its origin at ``(x, y, z)``."""
    x, y, z, qx, qy, qz, qw = m.coordinates(" ".join(FLOATING_Q))
    vx, vy, vz, wx, wy, wz = m.speeds(" ".join(FLOATING_U))
    N = m.N
    R = quaternion_matrix(qx, qy, qz, qw)
    frame = m.orient(N, names.internal(f"{link}_frame"), R, (wx, wy, wz))
    point = m.point(names.internal(f"{link}_origin"), m.origin, x * N.x + y * N.y + z * N.z)
    rate = R * sm.Matrix([vx, vy, vz])
    half = sm.Rational(1, 2)
    m.kinematics({x: rate[0], y: rate[1], z: rate[2],
                  qx: half * (qw * wx + qy * wz - qz * wy),
                  qy: half * (qw * wy + qz * wx - qx * wz),
                  qz: half * (qw * wz + qx * wy - qy * wx),
                  qw: -half * (qx * wx + qy * wy + qz * wz)})
    return Group(link, frame, point)
