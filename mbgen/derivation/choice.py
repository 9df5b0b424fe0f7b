r"""What the default derivation looks at: the model's joint tree, before anything is derived.

Kane's method and Newton–Euler give the same ``M u' = F`` at different costs.
Kane's partial velocities of a body carry every joint between it and the
ground, so on a chain its equations grow with the square of the chain's
length (faster on a spatial chain, whose rotations multiply); Newton–Euler
passes one velocity, acceleration and wrench per body along the tree and, when
every speed belongs to exactly one joint, gives ``u'`` by the articulated-body
recursion at a cost linear in the number of bodies.  Measured as operations
after CSE (L D L^T solve included) of the right-hand side when the rule was set
(the optimiser has moved the counts a few per cent since; the ratios stand):

======================================  =========  ======  ======  ======  ======
chain (relative joint angles)           method     2       4       6       12
======================================  =========  ======  ======  ======  ======
planar, particles                       Kane           44     210     524   2,514
                                        N-E            53     230     402     918
planar, rigid bodies                    Kane           54     279     733   3,681
                                        N-E            59     241     419     953
spatial arm (``scenes.spatial_arm``)    Kane           95     973   3,635
                                        N-E            92     537   1,230
======================================  =========  ======  ======  ======  ======

The length of a chain is counted in speeds, the joints' degrees of freedom from
the ground out, which is what Kane's partial velocities carry: for joints of
one speed it is the number of bodies, and a floating base (a free joint of six
speeds at the root) makes every chain on it six longer.  A floating body alone
already costs Kane's method several times Newton–Euler's (a free-flying body
147 against 490 operations; Solo-12, a quadruped of three-joint legs on a
floating base, 4,264 against 10,760).

Kane wins short chains, models in absolute coordinates (the n-link pendulum
on a cart: 90 against 292 at 3 links, 1,923 against 5,128 at 16) and most
constrained ones (the rolling disc: 335 against 600).  From a chain of
:data:`CHAIN` bodies on, Newton–Euler is never more than a few per cent
dearer (planar particles, 6 links: 635 against 666 with energies and an
integrator) and soon several times cheaper, so it is taken without deriving
Kane's equations, whose generated code would take minutes on a 16-link arm.

:func:`structure` reads what that rule needs from the body tree that
Newton–Euler infers (:mod:`mbgen.derivation.joints`); :func:`mbgen.derivation.choose_method`
applies the rule.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import ModelError
from .articulated import speed_owners
from .prepare import Prepared
from .recursion import NewtonEuler

#: Speeds on a chain (joints from the ground out; bodies, for joints of one speed)
#: from which a tree of joints that own their speeds is derived by Newton–Euler
#: without trying Kane.
CHAIN = 6
#: Most speeds for which both derivations are tried and the cheaper kept; a
#: larger model gets the structural choice alone (twice a long derivation is
#: not worth the few per cent the comparison could find).
COMPARE_SPEEDS = 24


@dataclass(frozen=True)
class Structure:
    """The joint tree as the default derivation sees it.

    Attributes
    ----------
    speeds : int
        Number of speeds, independent and dependent (``n_u``).
    owned : bool
        Every speed belongs to exactly one joint (relative joint coordinates):
        the tree of joints on which Newton–Euler is linear.
    chain : int
        Bodies on the longest path from the ground through the joint tree.
    chain_speeds : int
        Speeds of the joints on the path from the ground with the most of them (the
        same as ``chain`` when every joint has one speed; a floating base adds six).
    unfit : str
        Why Newton–Euler cannot infer the model's bodies and joints ("" when it can).
    outward : NewtonEuler or None
        The outward pass this was read from (None where ``unfit``), for the derivation to
        fork (:attr:`mbgen.derivation.prepare.Prepared.outward`).
    """

    speeds: int
    owned: bool
    chain: int
    chain_speeds: int = 0
    unfit: str = ""
    outward: NewtonEuler | None = field(default=None, compare=False, repr=False)

    @property
    def joint_tree(self) -> str:
        """The tree in words, for the reason a choice gives."""
        more = f" and {self.chain_speeds} speeds" if self.chain_speeds != self.chain else ""
        return (f"a tree of joints that own their speeds, with a chain of "
                f"{self.chain} bod{'y' if self.chain == 1 else 'ies'}{more}")


def structure(prep: Prepared) -> Structure:
    """The model's joint tree: its speeds, whether joints own them, its longest chain.

    Costs Newton–Euler's outward pass (milliseconds: a 16-link arm 0.06 s), never a
    derivation; the pass ``prep`` carries, where it carries one.  The pass is only read,
    and returned in :attr:`Structure.outward`.
    """
    n_u = prep.layout.n_u
    try:
        ne = prep.outward if prep.outward is not None else NewtonEuler(prep)
    except ModelError as exc:
        return Structure(n_u, False, 0, 0, str(exc).splitlines()[0])
    depth: dict = {}
    speeds: dict = {}
    for body in ne.bodies:  # every parent before its children
        up = body.parent
        depth[body] = 1 + (depth[up] if up is not None else 0)
        speeds[body] = len(ne.kin[body].S) + (speeds[up] if up is not None else 0)
    return Structure(n_u, speed_owners(ne) is not None, max(depth.values(), default=0),
                     max(speeds.values(), default=0), outward=ne)


__all__ = ["CHAIN", "COMPARE_SPEEDS", "Structure", "structure"]
