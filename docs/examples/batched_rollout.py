"""A batched rollout of the cart-pole in JAX and its derivative with respect to a parameter
(``mbgen.jax_function``).

1,024 initial states (pole angles and rates around upright) are integrated together with
``jax.vmap`` over ``steps`` RK4 steps of the generated right-hand side, inside ``jax.jit``;
the cost is the mean squared pole angle at the end.  Its derivative with respect to the
pole's length ``l0`` is taken through every step (and the ``L D L^T`` solve of each) in
forward mode, ``jax.jvp``: one compiled function gives the cost and its derivative, and a
central finite difference of the same cost checks it.  (``jax.grad`` gives the same number;
reverse mode through a loop costs XLA about three times the compile time here, and one
parameter is what forward mode is for.)  Float64 throughout (``jax_enable_x64``): JAX
computes in float32 by default.

Run it: ``python docs/examples/batched_rollout.py``.
"""

import jax
import jax.numpy as jnp
import numpy as np

import mbgen
from mbgen.scenes import n_link_cart

jax.config.update("jax_enable_x64", True)


def rollout_derivative(batch: int = 1024, steps: int = 100, h: float = 0.01, seed: int = 0):
    """``(cost, d cost / d l0 by jax.jvp, by central differences)`` of the rollout."""
    f = mbgen.jax_function(n_link_cart.scene(1))     # f(t, x, p, r) -> dx/dt
    p0 = jnp.array(f.default_parameters)              # [m0, m1, l0, g]
    at = f.parameter_names.index("l0")
    rng = np.random.default_rng(seed)
    x0 = jnp.array(np.column_stack([np.zeros(batch), rng.uniform(-0.3, 0.3, batch),
                                    np.zeros(batch), rng.uniform(-0.5, 0.5, batch)]))

    def step(x, p):                                   # one RK4 step of one state
        k1 = f(0.0, x, p)
        k2 = f(0.0, x + h / 2 * k1, p)
        k3 = f(0.0, x + h / 2 * k2, p)
        k4 = f(0.0, x + h * k3, p)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def cost(l0):
        p = p0.at[at].set(l0)
        final = jax.vmap(lambda x: jax.lax.fori_loop(0, steps, lambda _, x: step(x, p), x))
        return jnp.mean(final(x0)[:, 1] ** 2)         # x0: (batch, n_x)

    with_derivative = jax.jit(lambda l0: jax.jvp(cost, (l0,), (1.0,)))
    l0, eps = p0[at], 1e-6
    value, derivative = with_derivative(l0)
    fd = (with_derivative(l0 + eps)[0] - with_derivative(l0 - eps)[0]) / (2 * eps)
    return float(value), float(derivative), float(fd)


if __name__ == "__main__":
    c, d, fd = rollout_derivative()
    print(f"cost {c:.6f}; d cost/d l0: jax.jvp {d:.10f}, central difference {fd:.10f}")
