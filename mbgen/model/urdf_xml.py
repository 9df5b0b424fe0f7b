"""Reading a URDF file safely into plain records, every check before anything is built.

:func:`read_urdf` (a path) and :func:`parse_urdf` (the text) return a
:class:`Robot`: its links (with their ``<inertial>``), its joints (type,
parent, child, ``<origin xyz rpy>``, normalised ``<axis>``) and its root link,
with the joints in Pinocchio's order (:meth:`Robot.ordered_joints`), each with its
``<mimic>`` (:class:`Mimic`), ``<dynamics damping friction>`` and ``<limit>``
(:class:`Limit`), which :mod:`mbgen.model.urdf` uses as its options ask.  Only
``<robot>``, ``<link>``, ``<inertial>`` and ``<joint>`` are read; visuals,
collisions, meshes, transmissions, ``package://`` names and Gazebo tags are never
read or resolved.

A ``<mimic>`` must name another joint of the file that moves, and mimics must not
form a cycle (:class:`~mbgen.errors.UrdfStructureError`); one on a fixed joint is
ignored, as urdfdom and Pinocchio ignore it (Talos' gripper has five).

Inertia: one that is not positive semidefinite is refused.  One that is but breaks the
triangle inequality (CAD exports round small parts so: ANYmal C's depth camera has
principal moments 8.7e-6, 6.7e-4, 1.4e-3 kg m^2) is read as it is, with one
:class:`~mbgen.errors.ModelWarning` per file naming each such link and its moments
(``strict=True`` refuses it): the mass matrix needs only a positive semidefinite
inertia (Pinocchio reads such files; MuJoCo offers ``balanceinertia``).

Safety: a path that is not a regular file (a folder, a named pipe, a device) is
refused by what it is and never read (:mod:`mbgen.model.files`); a file over
:data:`MAX_URDF_BYTES` is refused before it is read; any ``<!DOCTYPE`` (and so any
entity declaration: internal, external or a billion laughs) is refused by a first
pass of expat that stops at the declaration, so nothing is ever expanded or fetched
(the standard library parser, no new dependency).  Every refusal is a
:class:`~mbgen.errors.UrdfError` subclass that names the file, the link or joint, and
the fix.

Numbers: every one must be finite (a ``<limit>`` value may be ``inf``).  Lengths, masses
and moments of inertia are refused above :data:`MAX_MAGNITUDE` and angles above
:data:`MAX_ANGLE` (named by element and attribute): no robot comes near, and products of
such numbers in the equations stay far inside the double range, where ``1e300`` would
overflow to ``inf``.  An ``<axis>`` is a direction, of any finite scale: it is divided by
its largest component before it is normalised, so ``1e200 0 0`` is ``1 0 0`` (its square
would overflow) and ``1e-200 0 0`` too (its square would be 0).

Size: a file with more than :data:`~mbgen.model.limits.MAX_SPEEDS` moving joints or
:data:`MAX_URDF_LINKS` links is refused (:class:`~mbgen.errors.ModelSizeError`, unless
forced) as soon as it is parsed, before its elements are checked: such a model cannot be
derived in reasonable time.  Work is linear in the links: the joints below each link
are indexed once (:attr:`Robot.kids`), and the root, the order and the mass check walk
that index.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

import numpy as np

from ..errors import (
    ModelSizeError,
    ModelWarning,
    UrdfInertiaError,
    UrdfStructureError,
    UrdfSyntaxError,
    UrdfUnsupportedError,
)
from .files import read_regular_file
from .limits import MAX_BODIES, check_size, size_forced

#: Largest URDF file read (bytes); a larger one is refused before it is opened for reading.
MAX_URDF_BYTES = 100 * 1024 * 1024

#: Most links read (unless forced, :func:`~mbgen.model.limits.allow_large_models`): fixed
#: links merge into the bodies they are welded to, so ten times
#: :data:`~mbgen.model.limits.MAX_BODIES` leaves room for frames; reading takes some 0.1 ms
#: a link.
MAX_URDF_LINKS = 10 * MAX_BODIES

#: Largest length (m), mass (kg) or moment of inertia (kg m^2) read: far past any robot,
#: and a product of a few such numbers stays far inside the double range (1.8e308).
MAX_MAGNITUDE = 1e15

#: Largest ``rpy`` angle (rad) read: beyond it the angle's own rounding (its last digit,
#: 1.8e-12 rad at 1e4) passes the 1e-12 rad the frames are built to.
MAX_ANGLE = 1e4

#: What a number may be, by what it measures: (largest magnitude or None, its unit).
RANGES = {"size": (MAX_MAGNITUDE, "m, kg, kg m^2"), "angle": (MAX_ANGLE, "rad"),
          "direction": (None, ""), "bound": (None, "")}

#: Joint types mbgen models.
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")

#: Relative tolerance of the inertia checks (eigenvalues, triangle inequality): URDF files
#: print their moments rounded, so a principal moment may miss by a rounding error.
INERTIA_TOL = 1e-6


@dataclass(frozen=True)
class Inertial:
    """A link's ``<inertial>``: mass, centre ``xyz`` and orientation ``rpy`` of the inertia
    frame in the link frame, and the inertia (3x3, about the centre, in that frame)."""

    mass: float
    xyz: tuple
    rpy: tuple
    inertia: tuple  # three rows


@dataclass(frozen=True)
class Link:
    name: str
    inertial: Inertial | None


@dataclass(frozen=True)
class Mimic:
    """A ``<mimic>``: the joint's coordinate is ``multiplier * q_joint + offset``."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Limit:
    """A ``<limit>``: the coordinate's range ``[lower, upper]`` (URDF's default 0, 0), the
    largest ``effort`` (N m or N) and ``velocity`` (rad/s or m/s); ``inf`` when absent."""

    lower: float = 0.0
    upper: float = 0.0
    effort: float = math.inf
    velocity: float = math.inf


@dataclass(frozen=True)
class JointSpec:
    """A ``<joint>``: its frame is ``xyz``/``rpy`` in the parent link's frame; ``axis`` is a
    unit vector in the joint frame (``(1, 0, 0)`` when the file gives none); ``mimic``
    (None on a fixed joint), ``damping`` and ``friction`` (``<dynamics>``, 0 when absent)
    and ``limit`` (None when absent) as the file gives them."""

    name: str
    type: str
    parent: str
    child: str
    xyz: tuple
    rpy: tuple
    axis: tuple
    mimic: Mimic | None = None
    damping: float = 0.0
    friction: float = 0.0
    limit: Limit | None = None


@dataclass(frozen=True)
class Robot:
    name: str
    source: str
    links: dict        # name -> Link, file order
    joints: dict       # child link name -> JointSpec
    root: str
    kids: dict = field(default=None, repr=False)   # link -> its joints (children), by name

    def __post_init__(self):
        if self.kids is None:
            object.__setattr__(self, "kids", index_children(self.joints))

    def children(self, link: str) -> list[JointSpec]:
        """Joints whose parent is ``link``, sorted by joint name (as urdfdom stores them)."""
        return self.kids.get(link, [])

    def ordered_joints(self) -> list[JointSpec]:
        """Every joint, depth first from the root, children by name: Pinocchio's order."""
        out, stack = [], list(reversed(self.children(self.root)))
        while stack:
            j = stack.pop()
            out.append(j)
            stack.extend(reversed(self.children(j.child)))
        return out


def index_children(joints: dict) -> dict[str, list[JointSpec]]:
    """``{link: the joints whose parent it is, sorted by name}``, in one pass."""
    kids: dict[str, list[JointSpec]] = {}
    for j in joints.values():
        kids.setdefault(j.parent, []).append(j)
    for below in kids.values():
        below.sort(key=lambda j: j.name.encode("utf-8"))
    return kids


def read_urdf(path, *, strict: bool = False) -> Robot:
    """Read and check the URDF file at ``path`` (see the module docstring; ``strict``
    refuses an inertia that breaks the triangle inequality, else it is warned about)."""
    data = read_regular_file(path, "URDF file", UrdfSyntaxError, MAX_URDF_BYTES,
                             "; a robot's URDF is a few hundred kB (meshes stay in their "
                             "own files)")
    return parse_urdf(data, str(path), strict=strict)


def parse_urdf(data: bytes | str, source: str = "<string>", *, strict: bool = False) -> Robot:
    """Check and read URDF text (``source`` names it in messages; ``strict`` as in
    :func:`read_urdf`)."""
    if isinstance(data, str):
        data = data.encode("utf-8")
    if len(data) > MAX_URDF_BYTES:
        raise UrdfSyntaxError(f"URDF {source!r} is over the {MAX_URDF_BYTES // 2**20} MiB limit")
    _first_pass(data, source)
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise UrdfSyntaxError(f"URDF file {source!r} is not well-formed XML ({exc}); fix the "
                              f"file at that line") from None
    if root.tag != "robot":
        raise UrdfSyntaxError(f"URDF file {source!r}: the top element is <{root.tag}>, not "
                              f"<robot>; is this a URDF file (xacro files must be expanded first)?")
    reader = _Reader(source, strict)
    name = root.get("name") or Path(source).stem
    links: dict[str, Link] = {}
    for el in root.findall("link"):
        link = reader.link(el)
        if link.name in links:
            raise UrdfStructureError(f"URDF file {source!r}: two links are named "
                                     f"{link.name!r}; rename one")
        links[link.name] = link
    if not links:
        raise UrdfStructureError(f"URDF file {source!r} has no <link>; a robot needs at least one")
    joints: dict[str, JointSpec] = {}
    names: set[str] = set()
    for el in root.findall("joint"):
        joint = reader.joint(el, links)
        if joint.name in names:
            raise UrdfStructureError(f"URDF file {source!r}: two joints are named "
                                     f"{joint.name!r}; rename one")
        names.add(joint.name)
        if joint.child in joints:
            other = joints[joint.child]
            raise UrdfStructureError(
                f"URDF file {source!r}: link {joint.child!r} has two parents, through joints "
                f"{other.name!r} and {joint.name!r}; closed chains are not supported: remove "
                f"one joint (and close the loop with a constraint in a Model if you need it)")
        joints[joint.child] = joint
    _check_mimics(source, joints)
    kids = index_children(joints)
    robot = Robot(name, source, links, joints, _root(source, links, joints, kids), kids)
    _check_moving_mass(robot)
    if reader.imperfect:
        warnings.warn(ModelWarning(f"URDF file {source!r}: " + "; ".join(
            f"link {link!r} has principal moments {a:.6g} + {b:.6g} < {c:.6g}"
            for link, (a, b, c) in reader.imperfect) + ": they break the triangle inequality "
            "(rounded CAD numbers?); read as given, as a positive semidefinite inertia keeps "
            "the dynamics well defined; fix ixx, iyy, izz, or refuse it with strict=True"),
            stacklevel=4)
    return robot


def _check_mimics(source: str, joints: dict) -> None:
    """Every ``<mimic>`` names another moving joint, and no mimics form a cycle."""
    by_name = {j.name: j for j in joints.values()}
    for j in by_name.values():
        seen, k = [j.name], j
        while k.mimic is not None:
            leader = by_name.get(k.mimic.joint)
            if leader is None or leader.type == "fixed" or leader.name in seen:
                what = ("is not a <joint> of the file" if leader is None else "is fixed"
                        if leader.type == "fixed" else
                        f"closes a cycle of mimics ({' -> '.join(seen + [leader.name])})")
                raise UrdfStructureError(
                    f"URDF file {source!r}, joint {k.name!r}: it mimics joint "
                    f"{k.mimic.joint!r}, which {what}; name a moving joint that moves on "
                    f"its own in <mimic joint=...>, or delete the <mimic> element")
            seen.append(leader.name)
            k = leader


def _check_moving_mass(robot: Robot) -> None:
    """Every moving joint carries some mass or inertia (else its row of M is zero)."""
    massive: dict[str, bool] = {}
    for j in reversed(robot.ordered_joints()):
        inertial = robot.links[j.child].inertial
        own = inertial is not None and (inertial.mass > 0 or any(any(r) for r in inertial.inertia))
        massive[j.child] = own or any(massive[c.child] for c in robot.children(j.child))
        if j.type != "fixed" and not massive[j.child]:
            raise UrdfInertiaError(
                f"URDF file {robot.source!r}, joint {j.name!r}: it moves link {j.child!r}, but "
                f"neither that link nor any below it has mass or inertia, so nothing resists "
                f"the joint (a zero row of the mass matrix): give link {j.child!r} an "
                f"<inertial> with a positive mass, or make the joint fixed")


def _first_pass(data: bytes, source: str) -> None:
    """One expat pass before the tree is built: stop at any DOCTYPE (where entities are
    declared), and count the links and moving joints (children of the top element) for
    the size guard, so a huge file is refused before its tree takes memory."""
    def refuse(*_args):
        raise UrdfSyntaxError(f"URDF file {source!r} has a <!DOCTYPE> or <!ENTITY> "
                              f"declaration; mbgen refuses them (entity expansion can be "
                              f"used to attack a parser), and URDF needs none: delete it")

    depth, count = [0], {"link": 0, "joint": 0}

    def start(tag, attrs):
        if depth[0] == 1 and tag in count and attrs.get("type") != "fixed":
            count[tag] += 1
        depth[0] += 1

    def end(_tag):
        depth[0] -= 1

    parser = expat.ParserCreate()
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.StartElementHandler, parser.EndElementHandler = start, end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise UrdfSyntaxError(f"URDF file {source!r} is not well-formed XML ({exc}); fix the "
                              f"file at that line") from None
    _check_counts(source, count["link"], count["joint"])


def _check_counts(source: str, links: int, moving: int) -> None:
    """Refuse (unless forced) more moving joints or links than can be derived in time."""
    check_size(moving, f"URDF file {source!r} with {moving} moving joints")
    if links > MAX_URDF_LINKS and not size_forced():
        raise ModelSizeError(
            f"URDF file {source!r} has {links} links, more than {MAX_URDF_LINKS}: far past "
            f"any robot's, and each takes time to read and check. If you really mean it, pass "
            f"force=True to from_urdf or load_scene, or --force on the command line.")


def _root(source: str, links: dict, joints: dict, kids: dict) -> str:
    roots = [n for n in links if n not in joints]
    if len(roots) > 1:
        raise UrdfStructureError(
            f"URDF file {source!r} has {len(roots)} root links ({', '.join(roots[:6])}): links "
            f"that are no joint's child; connect every link to one tree with joints")
    reached, stack = set(roots), list(roots)
    while stack:
        for j in kids.get(stack.pop(), ()):
            if j.child not in reached:
                reached.add(j.child)
                stack.append(j.child)
    cycle = [n for n in links if n not in reached]
    if cycle:
        what = "has no root link (every link is some joint's child)" if not roots else \
            "has a cycle of joints"
        raise UrdfStructureError(
            f"URDF file {source!r} {what}: links {', '.join(cycle[:8])} form a closed chain; "
            f"closed chains are not supported: remove one joint of the loop")
    return roots[0]


class _Reader:
    """Element readers that name the file and the element in every message; ``imperfect``
    collects ``(link, principal moments)`` of inertias that break the triangle inequality
    (refused when ``strict``)."""

    def __init__(self, source: str, strict: bool = False):
        self.source, self.strict = source, strict
        self.imperfect: list[tuple[str, tuple]] = []

    def fail(self, where: str, message: str, cls=UrdfSyntaxError):
        raise cls(f"URDF file {self.source!r}, {where}: {message}")

    def numbers(self, el, attr: str, where: str, default: str | None, count: int = 3,
                measure: str = "size", tag: str = "") -> tuple:
        """``count`` finite numbers of ``el``'s ``attr`` (``default`` when ``el`` or the
        attribute is absent), each within the range of its ``measure`` (:data:`RANGES`);
        a ``bound`` may be infinite too (no bound), never NaN."""
        limit, unit = RANGES[measure]
        named = f"<{el.tag if el is not None else tag}> {attr}"
        text = el.get(attr, default) if el is not None else default
        if text is None:
            self.fail(where, f"<{el.tag}> has no {attr}=\"...\"; add it")
        try:
            values = tuple(float(v) for v in text.split())
        except ValueError:
            values = ()
        finite = (lambda v: not math.isnan(v)) if measure == "bound" else math.isfinite
        if len(values) != count or not all(finite(v) for v in values):
            kind = "number(s), finite or inf" if measure == "bound" else "finite number(s)"
            self.fail(where, f"{named}=\"{text}\" must be {count} {kind}")
        if limit is not None and any(abs(v) > limit for v in values):
            self.fail(where, f"{named}=\"{text}\" is out of range: a magnitude over {limit:g} "
                      f"({unit}) is no robot's, and would overflow the equations' arithmetic; "
                      f"check the number and its unit")
        return values

    def origin(self, el, where: str) -> tuple[tuple, tuple]:
        o = el.find("origin")
        return (self.numbers(o, "xyz", where, "0 0 0", tag="origin"),
                self.numbers(o, "rpy", where, "0 0 0", measure="angle", tag="origin"))

    def link(self, el) -> Link:
        name = el.get("name")
        if not name:
            self.fail("a <link>", "the link has no name=\"...\"; name it")
        inertial = el.find("inertial")
        return Link(name, None if inertial is None else self.inertial(inertial, name))

    def inertial(self, el, link: str) -> Inertial:
        where = f"link {link!r}"
        mass_el = el.find("mass")
        if mass_el is None or mass_el.get("value") is None:
            self.fail(where, "<inertial> has no <mass value=\"...\"/>; give the link's mass in kg "
                      "(or delete <inertial> for a massless link)", UrdfInertiaError)
        mass, = self.numbers(mass_el, "value", where, None, 1)
        if mass < 0:
            self.fail(where, f"the mass {mass} is negative; give the link's mass in kg",
                      UrdfInertiaError)
        xyz, rpy = self.origin(el, where)
        inertia_el = el.find("inertia")
        if inertia_el is None:
            self.fail(where, "<inertial> has no <inertia ixx=... iyy=... izz=... ixy=... ixz=... "
                      "iyz=.../>; add it", UrdfInertiaError)
        keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
        v = {k: self.numbers(inertia_el, k, where, "0" if k[1] != k[2] else None, 1)[0]
             for k in keys}
        rows = ((v["ixx"], v["ixy"], v["ixz"]), (v["ixy"], v["iyy"], v["iyz"]),
                (v["ixz"], v["iyz"], v["izz"]))
        self.check_inertia(rows, where)
        return Inertial(mass, xyz, rpy, rows)

    def check_inertia(self, rows, where: str) -> None:
        moments = np.linalg.eigvalsh(np.array(rows, dtype=float))
        scale = max(abs(moments).max(), 1e-300)
        tol = INERTIA_TOL * scale
        if moments.min() < -tol:
            self.fail(where, f"the inertia is not positive semidefinite (principal moments "
                      f"{', '.join(f'{m:.6g}' for m in moments)}); "
                      f"check the signs of ixy, ixz, iyz "
                      f"(URDF gives the products of inertia as they appear in the matrix, "
                      f"ixy = -integral of x y dm)", UrdfInertiaError)
        a, b, c = moments
        if a + b < c - tol and self.strict:
            self.fail(where, f"the principal moments {a:.6g}, {b:.6g}, {c:.6g} break the "
                      f"triangle inequality ({a:.6g} + {b:.6g} < {c:.6g}): no rigid body has "
                      f"them; check the file's ixx, iyy, izz (strict=True refuses them; "
                      f"without it they are read with a warning)", UrdfInertiaError)
        if a + b < c - tol:
            self.imperfect.append((where.split(" ", 1)[1].strip("'"), (a, b, c)))

    def joint(self, el, links: dict) -> JointSpec:
        name = el.get("name")
        if not name:
            self.fail("a <joint>", "the joint has no name=\"...\"; name it")
        where = f"joint {name!r}"
        kind = el.get("type")
        if kind not in JOINT_TYPES:
            hint = ("a floating base is from_urdf(path, floating=True) on the root link; "
                    if kind == "floating" else "")
            self.fail(where, f"joint type {kind!r} is not supported ({hint}supported: "
                      f"{', '.join(JOINT_TYPES)})", UrdfUnsupportedError)
        ends = []
        for tag in ("parent", "child"):
            e = el.find(tag)
            link = e.get("link") if e is not None else None
            if link is None:
                self.fail(where, f"no <{tag} link=\"...\"/>; add it")
            if link not in links:
                self.fail(where, f"its {tag} link {link!r} is not a <link> of the file",
                          UrdfStructureError)
            ends.append(link)
        if ends[0] == ends[1]:
            self.fail(where, f"it joins link {ends[0]!r} to itself", UrdfStructureError)
        xyz, rpy = self.origin(el, where)
        axis = unit_vector(self.numbers(el.find("axis"), "xyz", where, "1 0 0",
                                        measure="direction", tag="axis"))
        if axis is None and kind != "fixed":
            self.fail(where, "its <axis xyz> is zero; give the joint's axis")
        dynamics = el.find("dynamics")
        damping, friction = (self.numbers(dynamics, key, where, "0", 1, tag="dynamics")[0]
                             for key in ("damping", "friction"))
        return JointSpec(name, kind, ends[0], ends[1], xyz, rpy, axis or (1.0, 0.0, 0.0),
                         self.mimic(el, where) if kind != "fixed" else None, damping,
                         friction, self.limit(el.find("limit"), where))

    def mimic(self, el, where: str) -> Mimic | None:
        mimic = el.find("mimic")
        if mimic is None:
            return None
        if not mimic.get("joint"):
            self.fail(where, "<mimic> has no joint=\"...\"; name the joint it follows")
        return Mimic(mimic.get("joint"), *(self.numbers(mimic, key, where, default, 1)[0]
                                           for key, default in (("multiplier", "1"),
                                                                ("offset", "0"))))

    def limit(self, el, where: str) -> Limit | None:
        if el is None:
            return None
        return Limit(*(self.numbers(el, key, where, default, 1, measure="bound")[0]
                       for key, default in (("lower", "0"), ("upper", "0"),
                                            ("effort", "inf"), ("velocity", "inf"))))


def unit_vector(vector: tuple) -> tuple | None:
    """``vector / |vector|`` at any finite scale (None for zero): divided by its largest
    component first, its norm lies in [1, sqrt(3)] and neither overflows nor underflows."""
    largest = max(abs(v) for v in vector)
    if largest == 0:
        return None
    scaled = [v / largest for v in vector]
    norm = math.sqrt(sum(v * v for v in scaled))
    return tuple(v / norm for v in scaled)
