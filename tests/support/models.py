"""Small models shared by several test files, and a scene file of the pendulum."""

from pathlib import Path

import mbgen


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
