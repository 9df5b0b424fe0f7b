"""Swing-up of the cart-pole: direct multiple shooting, solved by IPOPT through CasADi with
mbgen's dynamics and their exact Jacobians (``mbgen.casadi_function``).

The pole hangs down (``q1 = pi``; ``q1 = 0`` is upright in the n-link cart's convention) and
the cart at rest at 0; in ``T`` seconds a horizontal force ``F`` on the cart (``|F| <= 20 N``,
piecewise constant over ``N`` intervals) brings it upright at rest over ``x = 0``, the cart
staying within ``|x| <= 1.5 m``, with the least ``sum F^2 h``.  Each interval is one RK4
step of the generated right-hand side: ``casadi_function`` is an ``External`` whose Jacobian
is mbgen's analytic one, so IPOPT's constraint Jacobian is exact (the Hessian is IPOPT's
limited-memory one: the external has no second derivatives).

Run it: ``python docs/examples/cartpole_swingup.py`` (prints the force and the final state).
"""

import casadi as ca
import numpy as np

import mbgen
from mbgen.scenes import n_link_cart


def swing_up(N: int = 40, T: float = 2.5, print_level: int = 0):
    """Solve the swing-up; ``(x (n_x, N + 1), F (N,), IPOPT's stats)``."""
    scene = n_link_cart.scene(1)                           # cart-pole, parameters baked in
    scene = mbgen.Scene("cartpole", scene.model, fixed=scene.parameters)
    f = mbgen.casadi_function(scene)                       # f(t, x, p, r) -> dx/dt
    h = T / N

    x, u = ca.MX.sym("x", 4), ca.MX.sym("u", 1)
    rhs = lambda x: f(0, x, ca.DM(0, 1), u)                # noqa: E731 (p is empty)
    k1 = rhs(x)
    k2 = rhs(x + h / 2 * k1)
    k3 = rhs(x + h / 2 * k2)
    k4 = rhs(x + h * k3)
    step = ca.Function("step", [x, u], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])

    X, U = ca.MX.sym("X", 4, N + 1), ca.MX.sym("U", 1, N)
    gaps = step.map(N)(X[:, :-1], U) - X[:, 1:]            # multiple-shooting continuity
    start, goal = [0, np.pi, 0, 0], [0, 0, 0, 0]
    nlp = {"x": ca.veccat(X, U), "f": h * ca.sumsqr(U),
           "g": ca.veccat(gaps, X[:, 0] - start, X[:, -1] - goal)}
    lbx = np.concatenate([np.tile([-1.5, -np.inf, -np.inf, -np.inf], N + 1), -20 * np.ones(N)])
    guess = np.concatenate([np.linspace(start, goal, N + 1).ravel(), np.zeros(N)])
    solver = ca.nlpsol("swing_up", "ipopt", nlp, {
        "ipopt.hessian_approximation": "limited-memory", "ipopt.print_level": print_level,
        "print_time": False})
    sol = solver(x0=guess, lbx=lbx, ubx=-lbx, lbg=0, ubg=0)
    w = np.asarray(sol["x"]).ravel()
    return w[:4 * (N + 1)].reshape(N + 1, 4).T, w[4 * (N + 1):], solver.stats()


if __name__ == "__main__":
    xs, F, stats = swing_up(print_level=5)
    print(stats["return_status"], "after", stats["iter_count"], "iterations")
    print("force:", np.round(F, 2))
    print("final state:", xs[:, -1])
