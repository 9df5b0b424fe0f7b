r"""A spatial arm of ``n`` rigid links joined by relative revolute joints (issue 8's scaling model).

Link ``i`` (frame ``L{i}``, ``i = 1..n``) turns relative to link ``i - 1`` by the
joint angle ``q{i}``: about the z axis for odd ``i`` and about the y axis for
even ``i`` (link 0 is the Newtonian frame ``N``)::

    L1 = N  turned by q1 about n3,   L2 = L1 turned by q2 about l1_2,
    L3 = L2 turned by q3 about l2_3, ...

The joint of link ``i`` sits at ``J{i} = J{i-1} + a{i-1} L{i-1}.x`` (``J1`` is
the origin ``O``): a constant offset of length ``a{i-1}`` along the x axis of
the previous link.  Link ``i`` has mass ``m{i}``, its mass centre
``G{i} = J{i} + b{i} L{i}.x`` and a full central inertia matrix in ``L{i}``
components -- principal moments *and* products::

    [[Ixx{i}, Ixy{i}, Izx{i}],
     [Ixy{i}, Iyy{i}, Iyz{i}],
     [Izx{i}, Iyz{i}, Izz{i}]]

Gravity is ``-g n3``; speeds are the joint rates, ``u{i} = q{i}'``.  There is no
friction and no input, so ``T + V`` is conserved.  The same arm is built as a
Pinocchio model (revolute joints ``RZ``/``RY`` alternating, joint placements
``(I, [a{i-1}, 0, 0])``, inertias at lever ``[b{i}, 0, 0]``) by
:mod:`mbgen.bench.arm`, which compares both RHS.

Parameters (:func:`link_parameters`): lengths ``a{i} = 0.4 + 0.1 (i mod 3)``,
mass centres at mid-link ``b{i} = a{i} / 2``, masses ``m{i} = 2 - 0.25 (i mod 4)``,
rod-like inertias with small products.  All of them are baked into the code as
``fixed`` constants (a generated model knows its own numbers); only ``g`` and
the last link's mass ``m{n}`` (a payload) stay free at run time.  The start is
a bent pose at rest, ``q{i} = 0.3 (-1)^i``, ``u = 0``.

Option: ``n`` (number of links, default 4, which keeps the tests that run
every scene with every output, Jacobians included, quick; ``mbgen bench arm``
goes to ``n = 32``).
"""

from __future__ import annotations

from .. import Method, Model, Output, Scene


def axis(i: int) -> int:
    """Joint axis of link ``i`` (1-based): 3 (z) for odd ``i``, 2 (y) for even ``i``."""
    return 3 if i % 2 else 2


def link_parameters(n: int) -> dict[str, float]:
    """Parameter values of the arm (every name of :func:`build_model`'s constants).

    Numbers are short decimals so the generated code stays readable; every
    inertia matrix is positive definite (diagonally dominant: the products of a
    row add up to at most a quarter of its moment).
    """
    values: dict[str, float] = {}
    for i in range(1, n + 1):
        a = 0.4 + 0.1 * (i % 3)
        mass = 2.0 - 0.25 * (i % 4)
        axial = 0.01 * mass                           # thin rod about its own axis
        bending = mass * a * a / 12 + 0.005 * mass    # about the transverse axes
        values.update({
            f"a{i}": round(a, 6), f"b{i}": round(a / 2, 6), f"m{i}": mass,
            f"Ixx{i}": round(axial, 6), f"Iyy{i}": round(bending, 6),
            f"Izz{i}": round(bending * 1.1, 6),
            f"Ixy{i}": round(0.1 * axial, 6), f"Iyz{i}": round(-0.05 * bending, 6),
            f"Izx{i}": round(0.15 * axial, 6),
        })
    values["g"] = 9.81
    return values


def build_model(n: int = 4) -> Model:
    """The arm of ``n`` links; constants ``a_i, b_i, m_i, I.._i`` per link (link order), then ``g``.

    The offset ``a{n}`` of the last link leads to no further joint and is not
    used, so it is not declared.
    """
    if n < 1:
        raise ValueError(f"the number of links n must be at least 1, got {n}")
    m = Model("spatial_arm")
    q = m.coordinates(f"q1:{n + 1}")
    m.speeds(f"u1:{n + 1}")
    N = m.newtonian("N")
    parent, joint, previous_length = N, m.origin, None
    for i in range(1, n + 1):
        names = f"b{i} m{i} Ixx{i} Iyy{i} Izz{i} Ixy{i} Iyz{i} Izx{i}"
        b, mass, ixx, iyy, izz, ixy, iyz, izx = m.constants(names)
        link = m.rotate(parent, f"L{i}", axis(i), q[i - 1])
        if previous_length is not None:
            joint = m.point(f"J{i}", joint, previous_length * parent.x)
        center = m.point(f"G{i}", joint, b * link.x)
        m.body(f"link{i}", link, mass, (ixx, iyy, izz, ixy, iyz, izx), center)
        if i < n:
            previous_length, = m.constants(f"a{i}")
        parent = link
    m.gravity(-m.constants("g")[0] * N.z)
    return m


def scene(n: int = 4) -> Scene:
    """The ``n``-link arm, released at rest from a bent pose (see the module docstring)."""
    values = link_parameters(n)
    values.pop(f"a{n}")
    free = ("g", f"m{n}")
    return Scene(
        name="spatial_arm",
        model=build_model(n),
        outputs=(Output.RHS, Output.REACTIONS, Output.DOPRI5),
        method=Method.NEWTON_EULER,
        parameters={k: values[k] for k in free},
        fixed={k: v for k, v in values.items() if k not in free},
        initial_state={f"q{i}": 0.3 * (-1) ** i for i in range(1, n + 1)},
        t_span=(0.0, 5.0),
        description=f"{n}-link spatial arm, revolute joints about z and y alternating, "
                    f"full link inertias, gravity",
        conserves_energy=True,
    )
