r"""A chain of masses on a line, joined by stiff, strongly damped springs: a stiff test problem.

``n`` particles of masses ``m1..mn`` slide along the horizontal ``N.x``;
``x_i`` is the absolute position of particle ``P_i`` and ``v_i = x_i'`` its
speed.  A *soft* spring (stiffness ``k0``, natural length ``a``) ties the
first particle to the wall at the origin; neighbours ``P_(i-1)``, ``P_i`` are
joined by *stiff* springs of stiffness ``k`` and natural length ``a``, each
with a parallel damper ``c``.  With ``d_i = x_i - x_(i-1)`` (``x_0 = 0``)::

    T = sum_i m_i v_i^2 / 2,
    V = k0 (x_1 - a)^2 / 2 + k sum_(i>=2) (|d_i| - a)^2 / 2,
    m_i v_i' = - dV/dx_i - c sum (damper forces on P_i)

so ``M = diag(m_1..m_n)`` and the dynamics are linear while the particles
keep their order (``d_i > 0``; the line elements' direction ``d_i / |d_i|``
is undefined when two particles meet).  In equilibrium ``x_i = i a``.

Time scales (equal masses ``m``): the slow mode is the whole chain moving as
one body of mass ``n m`` on the soft spring, ``omega_0 ~ sqrt(k0 / (n m))``
(period ~ 14 s for the defaults).  The ``n - 1`` internal modes are those of
a free-free chain: undamped frequencies ``2 sqrt(k/m) sin(j pi / (2n))``,
``j = 1..n-1``.  The default damping ``c = 2 sqrt(k m)`` makes the highest
internal mode overdamped (damping ratio 2) and the lowest one damped with
ratio ``1 / (2 sin(pi/(2n)))`` -- 1.6 for ``n = 5`` -- so every fast mode
decays within a few ``sqrt(m/k)``; the fastest eigenvalue of the Jacobian is
about ``-2 (1 + cos(pi/n)) c / m`` (``-3.6 c/m ~ -7 sqrt(k/m)`` for ``n = 5``,
measured ``-6.7e4`` at ``k = 1e8``; ``-4 c/m`` for long chains).  The stiffness
ratio ``|lambda_max| / omega_0`` therefore grows like ``sqrt(k)``: about 1.5e3 at
``k = 1e4`` and 1.5e5 at ``k = 1e8``.  Explicit methods need a step below
``~3 / |lambda_max|`` over the whole run; implicit ones with the Jacobian follow
the slow mode.

Options: ``n`` (number of masses, default 5), ``stiffness`` (``k``, default
1e4; the scene is meant to work up to 1e8), ``damping`` (``c``; negative,
the default, selects ``2 sqrt(k m)`` with ``m`` the heaviest mass).

The initial state moves the whole chain 0.5 to the right of equilibrium
(exciting the slow mode) and stretches the last link by 1e-3 (a little of the
fast modes).  Dampers dissipate energy, so ``conserves_energy`` is False.
"""

import math

from .. import Model, Output, Scene


def build_model(n: int = 5) -> Model:
    """The chain; constants ``m1..mn, k0, k, c, a`` (in this order)."""
    if n < 1:
        raise ValueError("the number of masses n must be at least 1")
    m = Model("stiff_chain")
    x = m.coordinates(f"x1:{n + 1}")
    m.speeds(f"v1:{n + 1}")
    masses = m.constants(f"m1:{n + 1}")
    k0, k, c, a = m.constants("k0 k c a")
    N = m.newtonian("N")
    previous = m.origin
    for i in range(n):
        P = m.point(f"P{i + 1}", m.origin, x[i] * N.x)
        m.particle(f"mass{i + 1}", P, masses[i])
        if i == 0:
            m.spring("wall", P, previous, k0, natural_length=a)
        else:
            m.spring(f"link{i + 1}", P, previous, k, natural_length=a, damping=c)
        previous = P
    return m


def parameters(n: int = 5, stiffness: float = 1e4, damping: float = -1.0) -> dict[str, float]:
    """Parameter values of the scene for the given options (see the module docstring)."""
    masses = {f"m{i + 1}": 1.0 for i in range(n)}
    c = damping if damping >= 0 else 2.0 * math.sqrt(stiffness * max(masses.values()))
    return {**masses, "k0": 1.0, "k": float(stiffness), "c": float(c), "a": 1.0}


def initial_state(n: int = 5) -> dict[str, float]:
    """Chain shifted by 0.5 (slow mode), last link stretched by 1e-3 (fast modes)."""
    x0 = {f"x{i + 1}": (i + 1) * 1.0 + 0.5 for i in range(n)}
    x0[f"x{n}"] += 1e-3
    return x0


def scene(n: int = 5, stiffness: float = 1e4, damping: float = -1.0) -> Scene:
    """The chain of ``n`` masses with link stiffness ``stiffness`` (see the module docstring)."""
    if stiffness <= 0:
        raise ValueError("stiffness must be positive")
    return Scene(
        name="stiff_chain",
        model=build_model(n),
        outputs=(Output.RHS, Output.ROSENBROCK),
        parameters=parameters(n, stiffness, damping),
        initial_state=initial_state(n),
        t_span=(0.0, 10.0),
        description=(f"{n} masses on a line, stiff damped links (k = {stiffness:g}), "
                     "soft wall spring"),
        conserves_energy=False,
    )
