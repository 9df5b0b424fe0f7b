"""The n-link pendulum on a cart: the model of sympy's and PyDy's ``n_link_pendulum_on_cart``.

A cart of mass ``m0`` slides along ``I.x`` (coordinate ``q0``) pushed by the
input force ``F``; ``n`` point masses ``m1..mn`` hang on massless links of
lengths ``l0..l(n-1)``.  Link ``i`` makes the absolute angle ``q(i+1)`` with
``I.y`` (frames ``B0..B(n-1)`` rotate about ``I.z``); gravity ``-g I.y``.
Symbols, order and conventions match
:func:`sympy.physics.mechanics.models.n_link_pendulum_on_cart` with
``cart_force=True``, so numbers compare directly.
"""

from .. import Model, Output, Scene


def build_model(n: int = 3) -> Model:
    if n < 1:
        raise ValueError("the number of links n must be at least 1")
    m = Model("n_link_cart")
    q = m.coordinates(f"q:{n + 1}")
    m.speeds(f"u:{n + 1}")
    masses = m.constants(f"m:{n + 1}")
    lengths = m.constants(f"l:{n}")
    g, = m.constants("g")
    F, = m.inputs("F")
    I = m.newtonian("I")
    cart = m.point("P0", m.origin, q[0] * I.x)
    m.particle("Pa0", cart, masses[0])
    m.force(cart, F * I.x)
    previous = cart
    for i in range(n):
        B = m.rotate(I, f"B{i}", 3, q[i + 1])
        P = m.point(f"P{i + 1}", previous, lengths[i] * B.y)
        m.particle(f"Pa{i + 1}", P, masses[i + 1])
        previous = P
    m.gravity(-g * I.y)
    return m


def scene(n: int = 3) -> Scene:
    params = {f"m{i}": 1.0 for i in range(n + 1)}
    params.update({f"l{i}": 1.0 for i in range(n)})
    params["g"] = 9.81
    x0 = {f"q{i + 1}": 0.1 * (i + 1) for i in range(n)}
    return Scene(
        name="n_link_cart",
        model=build_model(n),
        outputs=(Output.RHS, Output.DOPRI5),
        parameters=params,
        initial_state=x0,
        t_span=(0.0, 10.0),
        description=f"{n}-link pendulum on a cart (sympy/PyDy n_link_pendulum_on_cart)",
        conserves_energy=True,
    )
