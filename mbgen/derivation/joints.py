r"""Bodies and joints, inferred from the frame and point tree (or stated by the user).

Newton–Euler works body by body, so it needs to know which masses move
together, which body each one hangs from, and where.

**Bodies.**  A mass element (particle or rigid body) sits at a point ``P``.
Walking up ``P``'s chain of parent points, the offsets stay constant in the
element's frame (or a frame rigidly attached to it: one reached by rotations
through constant angles) up to some point ``J``: the *joint point*, the highest
point of the chain fixed in the element.  Elements with the same frame (up to
rigid attachment) and the same ``J`` form one body.  A particle's frame is the
frame of the last offset that places it.

**Parents.**  A point is *fixed in* a body when it is the body's joint point or
sits at constant offsets (in the body's frame) below a point fixed in it; a
point is fixed in the ground when its offsets from the origin are constant in
``N``.  Walking up from ``J``, the first point fixed in another body (or the
ground) names the parent; when several bodies hold that point, the one whose
joint point is deepest wins, and a body sharing the child's joint point must
have a frame that is an ancestor of the child's.  Anything still ambiguous is
a :class:`~mbgen.errors.ModelError` that says to state the joint with
:meth:`mbgen.Model.joint`.

**Joint motion.**  The joint of body ``b`` with parent ``p`` is everything
between them: the rotations from ``p``'s frame to ``b``'s and the offsets
(*joint atoms*) from ``J_p`` to ``J_b``.  Nothing else is assumed: a joint may
rotate about several axes, slide, or both.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import ModelError
from ..symbolic.graph import free_symbols
from .prepare import Prepared
from .tree import Atom, FrameNode

GROUND = "ground"


@dataclass(eq=False)
class Body:
    """One body of the Newton–Euler tree.

    Attributes
    ----------
    name : str
    frame : FrameNode
        Body frame: every vector of the body is in its components.
    point : Point
        Joint point ``J``: reference point of the body's velocities and loads.
    elements : list of (MassElement, tuple of Atom)
        Mass elements and the atoms from ``J`` to each element's point.
    parent : Body or None
        None: the ground.
    joint_atoms : tuple of Atom
        Offsets from the parent's joint point (the origin for the ground) to ``J``.
    joint : str
        Joint name (rows of the ``reactions`` output).
    reaction_frame : FrameNode
        Frame of the reported reaction components.
    """

    name: str
    frame: FrameNode
    point: object
    elements: list = field(default_factory=list)
    parent: Body | None = None
    joint_atoms: tuple = ()
    joint: str = ""
    reaction_frame: FrameNode | None = None
    children: list = field(default_factory=list)
    index: int = -1

    def __repr__(self) -> str:
        return f"Body({self.name} in {self.frame.name} at {self.point.name})"


@dataclass
class BodyTree:
    """Bodies in order from the root (every parent before its children), and helpers."""

    bodies: list
    ground_frame: FrameNode
    rigid: dict            # FrameNode -> representative of its rigid class
    fixed_in: dict         # Point -> list of Body (and GROUND) the point is fixed in
    own_atoms: object      # callable Point -> atoms of the point's own offset
    atoms_between: object  # callable (upper Point, lower Point) -> atoms from upper to lower

    def body_of_point(self, point) -> Body | None | str:
        """The body a load at ``point`` acts on: the deepest body the point is fixed in.

        Returns a Body, ``GROUND`` (the point does not move: the load does no
        work) or None (the point is fixed in no body: a massless part).
        """
        holders = [b for b in self.fixed_in.get(point, ()) if b is not GROUND]
        if holders:
            return max(holders, key=lambda b: b.index)
        return GROUND if GROUND in self.fixed_in.get(point, ()) else None

    def body_of_frame(self, node: FrameNode) -> Body | None:
        """The body a torque on frame ``node`` acts on (None: a massless frame, or the ground)."""
        rep = self.rigid[node]
        holders = [b for b in self.bodies if self.rigid[b.frame] is rep]
        if not holders:
            return None
        exact = [b for b in holders if any(me.frame is node for me, _ in b.elements)]
        return (exact or holders)[0]


def _is_constant(atom: Atom, moving: set) -> bool:
    return not (free_symbols(atom.c) & moving)


def _rigid_classes(prep: Prepared, moving: set) -> dict:
    """Frame -> representative: frames joined by rotations through constant angles."""
    rep: dict = {}
    for frame, fd in prep.model.frames.items():
        node = prep.frame_nodes[frame]
        if fd.parent is None:
            rep[node] = node
            continue
        parent = prep.frame_nodes[fd.parent]
        constant = (fd.angular_velocity is None and fd.angle is not None and
                    not (free_symbols([prep.plain(fd.angle, "angle")]) & moving))
        rep[node] = rep[parent] if constant else node
    return rep


def _is_ancestor(a: FrameNode, b: FrameNode) -> bool:
    """True when ``a`` is a proper ancestor of ``b`` in the frame tree."""
    n = b.parent
    while n is not None:
        if n is a:
            return True
        n = n.parent
    return False


def _depth(point, parent_of) -> int:
    d = 0
    while parent_of.get(point) is not None:
        point = parent_of[point]
        d += 1
    return d


@dataclass(frozen=True)
class _Placement:
    """How the model's points hang from each other: each point's parent and atoms (its
    offsets from the origin), the coordinates and time that make an offset move, and each
    frame's rigid class (:func:`_rigid_classes`)."""

    parent_of: dict
    atoms_of: dict
    moving: set
    rigid: dict

    def own_atoms(self, point) -> tuple:
        """The atoms of ``point``'s own offset from its parent point."""
        up = self.parent_of.get(point)
        atoms = self.atoms_of[point]
        return atoms[len(self.atoms_of[up]):] if up is not None else atoms

    def atoms_between(self, upper, lower) -> tuple:
        """The atoms from ``upper`` down to ``lower`` (a point placed below it)."""
        return self.atoms_of[lower][len(self.atoms_of[upper]):]

    def rigid_in(self, point, rep) -> bool:
        """Whether ``point``'s own offset is constant in the rigid class ``rep``."""
        return all(_is_constant(a, self.moving) and self.rigid[a.frame] is rep
                   for a in self.own_atoms(point))


def build_bodies(prep: Prepared) -> BodyTree:
    """Group the model's masses into bodies and find every body's parent and joint.

    Four passes, as the module docstring describes them: :func:`_group_bodies`,
    :func:`_fixed_in`, :func:`_set_parents` and :func:`_from_the_root`.

    Raises
    ------
    ModelError
        A joint that cannot be determined, or a stated joint that does not fit.
    """
    model, layout = prep.model, prep.layout
    moving = set(layout.coordinates) | {layout.time}
    rigid = _rigid_classes(prep, moving)
    root = prep.frame_nodes[model.N]
    at = _Placement({p: pd.parent for p, pd in model.points.items()}, prep.point_atoms, moving,
                    rigid)
    stated = {j.child: j for j in model.joints_}
    bodies = _group_bodies(prep, at, stated, root)
    fixed_in = _fixed_in(model, bodies, at, root)
    _set_parents(prep, bodies, stated, fixed_in, at)
    ordered = _from_the_root(model, bodies, at)
    return BodyTree(ordered, root, rigid, fixed_in, at.own_atoms, at.atoms_between)


def _group_bodies(prep: Prepared, at: _Placement, stated: dict, root: FrameNode) -> list:
    """**Bodies**: the mass elements grouped by (rigid frame class, joint point), in the order
    of their first element."""
    groups: dict = {}
    for me in prep.masses:
        if me.frame is not None:
            frame = me.frame
        else:
            chain = at.atoms_of[me.point]
            frame = chain[-1].frame if chain else root
        rep = at.rigid[frame]
        j = stated[me.name].point if me.name in stated and stated[me.name].point else None
        if j is None:
            j = me.point
            while at.parent_of.get(j) is not None and at.rigid_in(j, rep):
                j = at.parent_of[j]
        elif not _fixed_below(j, me.point, rep, at.parent_of, at.rigid_in):
            raise ModelError(f"the joint point {j.name} stated for {me.name!r} is not fixed in "
                             f"it: {me.name!r} must be placed from {j.name} by offsets constant "
                             f"in its own frame")
        key = (rep, j)
        if key not in groups:
            groups[key] = Body(me.name, frame, j)
        body = groups[key]
        if me.frame is not None and all(e.frame is None for e, _ in body.elements):
            body.frame = me.frame   # a rigid body's own frame names the body frame
        body.elements.append((me, at.atoms_between(j, me.point)))
    return list(groups.values())


def _fixed_in(model, bodies: list, at: _Placement, root: FrameNode) -> dict:
    """Point -> the bodies (and ``GROUND``) it is fixed in, from the origin down."""
    fixed_in: dict = {}
    for point in model.points:
        up = at.parent_of[point]
        holders = [b for b in bodies if b.point is point]
        if up is None:
            holders.append(GROUND)
        else:
            for h in fixed_in[up]:
                rep = at.rigid[root] if h is GROUND else at.rigid[h.frame]
                if h not in holders and at.rigid_in(point, rep):
                    holders.append(h)
        fixed_in[point] = holders
    return fixed_in


def _set_parents(prep: Prepared, bodies: list, stated: dict, fixed_in: dict,
                 at: _Placement) -> None:
    """**Parents**: each body's parent (stated, or found by :func:`_find_parent`), its joint's
    name and the frame its reaction is reported in."""
    model = prep.model
    by_name = {me.name: b for b in bodies for me, _ in b.elements}
    for b in bodies:
        names = [me.name for me, _ in b.elements]
        stated_j = next((stated[n] for n in names if n in stated), None)
        if stated_j is not None and stated_j.parent is not None:
            b.parent = None if stated_j.parent is model.N else by_name[stated_j.parent]
            anchor = b.parent.point if b.parent is not None else model.origin
            if b.parent is b:
                raise ModelError(f"joint of {b.name!r}: {stated_j.parent!r} is part of the same "
                                 f"body")
            if not _is_point_ancestor(anchor, b.point, at.parent_of):
                raise ModelError(f"joint of {b.name!r}: its joint point {b.point.name} is not "
                                 f"placed below {anchor.name}, the joint point of its stated "
                                 f"parent; place the point from the parent's points")
        else:
            b.parent = _find_parent(b, fixed_in, at.parent_of, at.rigid)
        b.joint = stated_j.name if stated_j is not None else b.name
        rf = stated_j.frame if stated_j is not None else None
        b.reaction_frame = prep.frame_nodes[rf] if rf is not None else b.frame


def _from_the_root(model, bodies: list, at: _Placement) -> list:
    """The bodies ordered from the root, children in model order, each with its index and
    **joint motion** (the atoms from its parent's joint point)."""
    for b in bodies:
        if b.parent is not None:
            b.parent.children.append(b)
    ordered: list = []
    stack = [b for b in reversed(bodies) if b.parent is None]
    while stack:
        b = stack.pop()
        ordered.append(b)
        stack.extend(reversed(b.children))
    if len(ordered) != len(bodies):   # pragma: no cover - parents are acyclic by construction
        raise ModelError("the joints of the model form a loop; state them with model.joint()")
    for i, b in enumerate(ordered):
        b.index = i
        anchor = b.parent.point if b.parent is not None else model.origin
        b.joint_atoms = at.atoms_between(anchor, b.point)
    return ordered


def _fixed_below(upper, lower, rep, parent_of, rigid_in) -> bool:
    p = lower
    while p is not upper:
        if p is None or not rigid_in(p, rep):
            return False
        p = parent_of.get(p)
    return True


def _is_point_ancestor(upper, lower, parent_of) -> bool:
    p = lower
    while p is not None:
        if p is upper:
            return True
        p = parent_of.get(p)
    return False


def _find_parent(b: Body, fixed_in, parent_of, rigid) -> Body | None:
    q = b.point
    while q is not None:
        holders = fixed_in.get(q, [])
        cands = [h for h in holders if h is not GROUND and h is not b and
                 (h.point is not b.point or _is_ancestor(h.frame, b.frame))]
        if cands:
            def key(h):
                return _depth(h.point, parent_of), h.frame.depth

            best = max(cands, key=key)
            tied = [h for h in cands if h is not best and key(h) == key(best)]
            if tied:
                raise ModelError(
                    f"cannot tell which body {b.name!r} hangs from: {best.name!r} and "
                    f"{tied[0].name!r} both hold its point {q.name}; state it with "
                    f"model.joint({b.name!r}, parent=...)")
            return best
        if GROUND in holders:
            return None
        q = parent_of.get(q)
    return None
