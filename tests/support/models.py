"""Small models shared by several test files, a scene file of the pendulum, and two helpers
of the robot-file tests (a counter of joint reads, a read that must not block on a pipe)."""

import dataclasses
import os
import threading
from pathlib import Path

import pytest
import sympy as sm

import mbgen
from mbgen.model import urdf_xml


def stiff_pair() -> mbgen.Scene:
    """Two masses joined by a stiff, overdamped spring (eigenvalues near -500 and -4000).

    A soft spring ties the first mass to the origin (period 2 pi sqrt(2)); stiff enough
    for LSODA to switch to BDF and for explicit methods to need many more steps.
    """
    m = mbgen.Model("stiff_pair")
    x1, x2 = m.coordinates("x1 x2")
    m.speeds("v1 v2")
    k, c, mass = m.constants("k c mass")
    N = m.newtonian()
    P1 = m.point("P1", m.origin, x1 * N.x)
    P2 = m.point("P2", m.origin, x2 * N.x)
    m.particle("b1", P1, mass)
    m.particle("b2", P2, mass)
    m.spring("s0", P1, m.origin, 1.0)
    m.spring("s12", P2, P1, k, natural_length=1.0, damping=c)
    return mbgen.Scene("stiff_pair", m, parameters={"k": 1e6, "c": 2e3, "mass": 1.0},
                       initial_state={"x1": 1.0, "x2": 2.0, "v2": 0.1})


def pendulum(name="pendulum") -> mbgen.Model:
    """A point mass ``m`` on a massless rod of length ``l`` under gravity ``g``: coordinate
    ``q``, speed ``u``."""
    m = mbgen.Model(name)
    q, = m.coordinates("q")
    m.speeds("u")
    l, g, mass = m.constants("l g m")
    N = m.newtonian()
    B = m.rotate(N, "B", 3, q)
    P = m.point("P", m.origin, -l * B.y)
    m.particle("bob", P, mass)
    m.gravity(-g * N.y)
    return m


def two_input_cart() -> mbgen.Scene:
    """A cart (``x``) pushed by ``F``, a pendulum on it (``th``) driven by ``T`` and a spring:
    two inputs, both reaching both speeds (``B`` is full)."""
    m = mbgen.Model("cart_pendulum")
    x, th = m.coordinates("x th")
    m.speeds("v w")
    mc, mp, l, g, k = m.constants("mc mp l g k")
    F, T = m.inputs("F T")
    N = m.newtonian()
    C = m.point("C", m.origin, x * N.x)
    B = m.rotate(N, "B", 3, th)
    m.particle("cart", C, mc)
    m.particle("bob", m.point("P", C, -l * B.y), mp)
    m.gravity(-g * N.y)
    m.spring("s", m.origin, C, k)
    m.force(C, F * N.x + T * sm.sin(th) * N.x)     # T also pushes the cart: B is full
    m.torque(B, T * N.z)
    scene = mbgen.Scene("cart_pendulum", m, parameters=dict(mc=2.0, mp=0.7, l=0.9, g=9.81,
                                                            k=3.0))
    return scene


def bounded_cart(saturate: bool = True, outputs=("rhs", "dopri5", "rk4")) -> mbgen.Scene:
    """:func:`two_input_cart` with input bounds, ``F`` in ``[-5, 5]`` and ``T <= 1``
    (unbounded below), saturated or not (``Scene(saturate=...)``)."""
    scene = two_input_cart()
    scene.model.bound("F", -5.0, 5.0)
    scene.model.bound("T", None, 1.0)
    return dataclasses.replace(scene, saturate=saturate, outputs=outputs,
                               initial_state={"x": 0.1, "th": 0.2})


def massless_link_scene() -> mbgen.Scene:
    """A link without mass (frame A, angle q1) carrying a body on a second link (B, angle q2
    relative to A): a force at the massless link's midpoint and a torque on it are loads on
    a massless part, whose generalized forces reach u1' only through ``tau``."""
    m = mbgen.Model("massless_link")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("u1 u2")
    l, mass, g, f, T = m.constants("l m g f T")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(A, "B", 3, q2)
    PA = m.point("PA", m.origin, l * A.x)
    m.body("bob", B, mass, (0, 0, mass * l**2 / 12), m.point("G", PA, l / 2 * B.x))
    m.gravity(-g * N.y)
    m.force(m.point("H", m.origin, l / 2 * A.x), f * N.x + 2 * f * N.y)
    m.torque(A, T * N.z)
    return mbgen.Scene("massless_link", m,
                       parameters=dict(l=0.8, m=1.3, g=9.81, f=7.0, T=-2.5))


#: The pendulum as a scene file ("pend"); ``DESCRIPTION`` is written above it.
SCENE_FILE = '''
from mbgen import Model, Output, Scene

def scene():
    m = Model("pend")
    q, = m.coordinates("q")
    m.speeds("u")
    l, g, mass = m.constants("l g m")
    N = m.newtonian()
    B = m.rotate(N, "B", 3, q)
    P = m.point("P", m.origin, -l * B.y)
    m.particle("bob", P, mass)
    m.gravity(-g * N.y)
    return Scene(name="pend", model=m, parameters={"l": 1.0, "g": 9.81, "m": 1.0},
                 initial_state={"q": 0.1}, t_span=(0.0, 1.0), outputs=(Output.RHS, Output.DOPRI5),
                 description=DESCRIPTION)
'''


def scene_file(folder: Path, file_name="pend.py", description="a pendulum") -> Path:
    """Write :data:`SCENE_FILE` with ``description`` to ``folder / file_name``."""
    path = folder / file_name
    path.write_text(f"DESCRIPTION = {description!r}\n" + SCENE_FILE, encoding="utf-8")
    return path


def four_bar_model(name: str) -> mbgen.Model:
    """A four-bar linkage: a loop-closing constraint (a singular Jacobian at dead points)."""
    m = mbgen.Model(name)
    q1, q2, q3 = m.coordinates("q1 q2 q3")
    m.speeds("u1 u2 u3")
    la, lb, lc, ld, g = m.constants("la lb lc ld g")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(A, "B", 3, q2)
    C = m.rotate(N, "C", 3, q3)
    PA = m.point("PA", m.origin, la * A.x)
    PB = m.point("PB", PA, lb * B.x)
    D = m.point("D", m.origin, ld * N.x)
    PC = m.point("PC", D, lc * C.x)
    m.body("crank", A, 1.0, (0, 0, 0.1), m.point("GA", m.origin, la / 2 * A.x))
    m.body("coupler", B, 1.5, (0, 0, 0.4), m.point("GB", PA, lb / 2 * B.x))
    m.body("rocker", C, 1.2, (0, 0, 0.3), m.point("GC", D, lc / 2 * C.x))
    m.gravity(-g * N.y)
    m.coincident(PB, PC, [q2, q3], axes=(1, 2))
    return m


def ambiguous_slider(name: str) -> mbgen.Model:
    """Two links on the ground at ``P`` and a slider on a rail from ``P``: which of the
    ground, ``a`` and ``b`` holds the slider is ambiguous to Newton–Euler's joint inference."""
    m = mbgen.Model(name)
    q1, q2, q3 = m.coordinates("q1 q2 q3")
    m.speeds("u1 u2 u3")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(N, "B", 3, q2)
    P = m.point("P", m.origin, N.x)
    m.body("a", A, 1, (1, 1, 1), m.point("Ga", P, A.x))
    m.body("b", B, 1, (1, 1, 1), m.point("Gb", P, B.x))
    m.particle("c", m.point("C", P, q3 * N.x), 1)
    return m


def count_joint_parent_reads(monkeypatch):
    """Make ``mbgen.model.urdf_xml`` count every read of a joint's ``parent`` (the class of
    the returned counter holds ``reads``): how linear reading is shown without a clock."""
    class Counted(urdf_xml.JointSpec):
        reads = 0

        def __getattribute__(self, name):
            if name == "parent":
                type(self).reads += 1
            return object.__getattribute__(self, name)

    monkeypatch.setattr(urdf_xml, "JointSpec", Counted)
    return Counted


def read_in_thread(read, path):
    """``read(path)``'s exception (None if it returned), read in a thread: one still blocked
    after 60 s (a hang guard, not a budget) is released by a writer that opens and closes
    the named pipe ``path``, and fails the test."""
    caught = []

    def run():
        try:
            read(path)
        except BaseException as exc:   # noqa: BLE001 - handed to the test
            caught.append(exc)
    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(60)
    if thread.is_alive():
        os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
        thread.join()
        pytest.fail(f"{read.__name__} blocked reading {path} (then: {caught})")
    return caught[0] if caught else None
