"""Generated C integrators (DOPRI5, RK4, Rosenbrock): coefficients, orders, accuracy, errors."""

import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import sympy as sm
from scipy.integrate import solve_ivp
from scipy.integrate._ivp.rk import RK45

import mbgen
from mbgen import IntegrationError, MbgenError, Output
from mbgen.integrators import ROSENBROCK, Dopri5, Rodas3, Rodas4
from mbgen.model.scene import load_scene
from mbgen.runtime.stepper import Stepper
from mbgen.scenes import bead_wire
from models import stiff_pair

ALL = {"rhs", "dopri5", "rk4", "rosenbrock", "jacobian"}
GCC = shutil.which("gcc") or shutil.which("cc")
GXX = shutil.which("g++") or shutil.which("c++")
STRICT_C = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-Wshadow", "-Wconversion",
            "-Wno-sign-conversion"]
STRICT_CXX = ["-x", "c++", "-Wall", "-Wextra", "-Werror", "-Wshadow"]


# ------------------------------------------------------------------ models
def shaken_pendulum():
    """A pendulum whose pivot is shaken horizontally, ``a sin(w t)``: explicitly time dependent."""
    m = mbgen.Model("shaken_pendulum")
    q, = m.coordinates("q")
    m.speeds("u")
    length, g, a, w, mass = m.constants("l g a w m")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q)
    E = m.point("E", m.origin, m.prescribed("e", a * sm.sin(w * mbgen.t)) * N.x)
    m.particle("bob", m.point("P", E, -length * A.y), mass)
    m.gravity(-g * N.y)
    return mbgen.Scene("shaken_pendulum", m,
                       parameters={"l": 1.0, "g": 9.81, "a": 0.3, "w": 5.0, "m": 1.0},
                       initial_state={"q": 0.5, "u": 0.0}, t_span=(0.0, 2.0))


@pytest.fixture(scope="module")
def disc():
    scene = load_scene("disc_pendulum")
    return scene, mbgen.compile(scene, outputs=ALL)


@pytest.fixture(scope="module")
def cart():
    scene = load_scene("n_link_cart", n=3)
    return scene, mbgen.compile(scene, outputs=ALL)


@pytest.fixture(scope="module")
def shaken():
    scene = shaken_pendulum()
    return scene, mbgen.run(scene, outputs=ALL)


@pytest.fixture(scope="module")
def stiff():
    scene = stiff_pair()
    return scene, mbgen.compile(scene, outputs=ALL | {"jacobian"})


def reference(model, t, x0, p=None, r=None):
    """A tight DOP853 solution at ``t`` (rows)."""
    p = model.default_parameters if p is None else p
    r = np.zeros(model.n_r) if r is None else r
    sol = solve_ivp(model.rhs, (t[0], t[-1]), x0, method="DOP853", t_eval=t, args=(p, r),
                    rtol=1e-13, atol=1e-14)
    assert sol.success
    return sol.y.T


def orders(errors):
    errors = np.asarray(errors)
    return np.log2(errors[:-1] / errors[1:])


# ---------------------------------------------------------- coefficients
def test_dopri5_coefficients_are_scipys():
    for name in ("C", "A", "B", "E", "P"):
        np.testing.assert_array_equal(getattr(Dopri5, name), getattr(RK45, name), err_msg=name)
    assert (Dopri5.order, Dopri5.error_estimator_order, Dopri5.n_stages) == \
           (RK45.order, RK45.error_estimator_order, RK45.n_stages)


def test_coefficients_are_printed_with_full_precision(disc):
    src = disc[1].rendered.source
    for value in (Dopri5.A[4, 0], Dopri5.E[4], Dopri5.P[4, 3], ROSENBROCK.C[5, 3],
                  ROSENBROCK.A[3, 2]):
        assert repr(float(abs(value))) in src
        assert float(repr(float(value))) == value


def _hairer_wanner(T):
    """``(alpha_ij, gamma_ij incl. diagonal, b)`` from the KPP form (a, c, m)."""
    s = T.n_stages()
    Gam = np.linalg.inv(np.eye(s) / T.gamma - T.C)
    return T.A @ Gam, Gam, T.M @ Gam


@pytest.mark.parametrize("T", [Rodas3, Rodas4])
def test_rosenbrock_order_conditions(T):
    """Hairer & Wanner II, Table IV.7.1 conditions up to the method's order; L-stable."""
    alpha, Gam, b = _hairer_wanner(T)
    g = T.gamma
    beta = np.tril(alpha + Gam, -1)
    bp = beta.sum(1)
    a = alpha.sum(1)
    conditions = [b.sum() - 1, b @ bp - (0.5 - g),
                  b @ a**2 - 1 / 3, b @ (beta @ bp) - (1 / 6 - g + g * g),
                  b @ a**3 - 1 / 4, b @ (a * (alpha @ bp)) - (1 / 8 - g / 3),
                  b @ (beta @ a**2) - (1 / 12 - g / 3),
                  b @ (beta @ (beta @ bp)) - (1 / 24 - g / 2 + 1.5 * g * g - g**3)]
    n_conditions = {3: 4, 4: 8}[T.order]
    np.testing.assert_allclose(conditions[:n_conditions], 0, atol=1e-14)
    assert np.max(np.abs(conditions[n_conditions:] or [1])) > 1e-3  # not accidentally higher
    np.testing.assert_allclose(a, T.alpha, atol=1e-14)  # stage times consistent
    np.testing.assert_allclose(Gam.sum(1), T.gamma_t, atol=1e-14)  # df/dt weights consistent
    # stability function at infinity R(inf) = 1 - b^T (alpha + Gamma)^-1 1 = 0 (L-stable)
    assert abs(1 - b @ np.linalg.solve(alpha + Gam, np.ones(len(b)))) < 1e-14


def _forced(t, y):
    return np.array([y[1], -np.sin(y[0]) - 0.2 * y[1] ** 3 + 0.5 * np.cos(2 * t)])


def _forced_jac(t, y):
    return np.array([[0.0, 1.0], [-np.cos(y[0]), -0.6 * y[1] ** 2]])


def _forced_dfdt(t, y):
    return np.array([0.0, -np.sin(2 * t)])


@pytest.mark.parametrize("T", [Rodas3, Rodas4])
def test_rosenbrock_convergence_order_python_reference(T):
    """Fixed steps on a nonlinear non-autonomous ODE: error ratio on halving h ~ 2^p."""
    y0, span = [1.0, 0.5], (0.0, 2.0)
    exact = solve_ivp(_forced, span, y0, method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    ns = (20, 40, 80, 160)
    err = [np.abs(T.fixed_steps(_forced, _forced_jac, _forced_dfdt, span, y0, n) - exact).max()
           for n in ns]
    emb = [np.abs(T.fixed_steps(_forced, _forced_jac, _forced_dfdt, span, y0, n, embedded=True)
                  - exact).max() for n in ns]
    assert np.all(np.abs(orders(err)[1:] - T.order) < 0.15), orders(err)
    assert np.all(np.abs(orders(emb)[1:] - T.error_estimator_order) < 0.15), orders(emb)


def test_c_rosenbrock_convergence_order(shaken):
    """The C Rosenbrock with fixed steps (huge tolerances, h0 = h_max = h) on a
    non-autonomous model: 4th order, so df/dt enters correctly."""
    scene, res = shaken
    model = res.compiled
    assert Output.TIME_DERIVATIVE in model.outputs
    assert "shaken_pendulum_time_derivative(t, y" in model.rendered.source
    x0 = scene.x0(model.layout)
    t = np.array([0.0, 1.0])
    exact = reference(model, t, x0)[-1]
    errors = []
    for n in (16, 32, 64, 128):
        out = model.integrate("rosenbrock", t, x0, rtol=1e10, atol=1e10, h=1.0 / n, h_max=1.0 / n)
        assert out.n_steps == n and out.n_rejected == 0
        errors.append(np.abs(out.x[-1] - exact).max())
    assert np.all(np.abs(orders(errors)[1:] - ROSENBROCK.order) < 0.3), orders(errors)


# ------------------------------------------------------------ vs solve_ivp
@pytest.mark.parametrize("which", ["disc", "cart"])
def test_dopri5_matches_scipy_rk45(which, request):
    scene, model = request.getfixturevalue(which)
    x0 = scene.x0(model.layout)
    p = model.default_parameters
    r = np.full(model.n_r, 0.3)
    t = np.linspace(0.0, 5.0, 51)
    exact = reference(model, t, x0, p, r)
    for rtol, atol in ((1e-6, 1e-9), (1e-9, 1e-12)):
        ours = model.integrate("dopri5", t, x0, p, r if model.n_r else None, rtol=rtol, atol=atol)
        sol = solve_ivp(model.rhs, (t[0], t[-1]), x0, method="RK45", t_eval=t, args=(p, r),
                        rtol=rtol, atol=atol)
        err_ours, err_scipy = np.abs(ours.x - exact).max(), np.abs(sol.y.T - exact).max()
        assert 0.5 < err_ours / err_scipy < 2.0, (err_ours, err_scipy)
        assert abs(ours.n_rhs - sol.nfev) <= 0.1 * sol.nfev, (ours.n_rhs, sol.nfev)
        # same steps: FSAL, 6 calls per attempt, 2 calls to start (f0 and the initial step)
        assert ours.n_rhs == 2 + 6 * (ours.n_steps + ours.n_rejected)
        assert ours.n_jac == ours.n_lu == 0
        np.testing.assert_allclose(ours.x, sol.y.T, rtol=0, atol=100 * err_scipy)


@pytest.mark.parametrize("which", ["disc", "cart"])
def test_rosenbrock_vs_solve_ivp(which, request):
    """As accurate as solve_ivp's Radau / our DOPRI5 at the same tolerance, and the
    error follows the tolerance (the cart's three links amplify errors ~1e4-fold)."""
    scene, model = request.getfixturevalue(which)
    x0 = scene.x0(model.layout)
    p, r = model.default_parameters, np.full(model.n_r, -0.2)
    t = np.linspace(0.0, 5.0, 41)  # most output times fall inside steps: Hermite dense output
    exact = reference(model, t, x0, r=r)
    errors = []
    for rtol in (1e-6, 1e-9):
        kw = dict(rtol=rtol, atol=rtol * 1e-3)
        out = model.integrate("rosenbrock", t, x0, r=r if model.n_r else None, **kw)
        dop = model.integrate("dopri5", t, x0, r=r if model.n_r else None, **kw)
        radau = solve_ivp(model.rhs, (t[0], t[-1]), x0, method="Radau", jac=model.jacobian,
                          t_eval=t, args=(p, r), **kw)
        err = np.abs(out.x - exact).max()
        others = max(np.abs(dop.x - exact).max(), np.abs(radau.y.T - exact).max())
        assert err < 20 * others, (rtol, err, others)
        assert out.n_jac == out.n_steps and out.n_lu == out.n_steps + out.n_rejected
        assert out.n_rhs == 2 + out.n_steps + 5 * (out.n_steps + out.n_rejected)
        errors.append(err)
    assert errors[1] < errors[0] / 300


def test_rk4_convergence_order_and_solve_ivp(disc):
    scene, model = disc
    x0 = scene.x0(model.layout)
    t = np.linspace(0.0, 4.0, 9)
    exact = reference(model, t, x0)
    errors = []
    for h in (0.05, 0.025, 0.0125, 0.00625):
        out = model.integrate("rk4", t, x0, h=h)
        assert out.n_steps == round(4.0 / h) and out.n_rhs == 4 * out.n_steps
        errors.append(np.abs(out.x - exact).max())
    assert np.all(np.abs(orders(errors) - 4) < 0.2), orders(errors)
    # each output interval is split into ceil(dt / h) equal steps
    assert model.integrate("rk4", t, x0, h=0.3).n_steps == 8 * 2
    assert model.integrate("rk4", [0.0, 0.1, 0.25], x0, h=0.05).n_steps == 2 + 3


def test_bead_wire_closed_form():
    scene = load_scene("bead_wire")
    model = mbgen.compile(scene, outputs=ALL)
    x0, p = scene.x0(model.layout), model.default_parameters
    t = np.linspace(*scene.t_span, 31)
    exact = bead_wire.closed_form(t, x0, p)
    for method in ("dopri5", "rosenbrock"):
        out = model.integrate(method, t, x0, rtol=1e-10, atol=1e-12)
        rel = np.abs(out.x - exact).max() / np.abs(exact).max()
        assert rel < 1e-7, (method, rel)
    out = model.integrate("rk4", t, x0, h=1e-3)
    assert np.abs(out.x - exact).max() / np.abs(exact).max() < 1e-9


def test_non_autonomous_model_all_methods(shaken):
    scene, res = shaken
    model = res.compiled
    x0 = scene.x0(model.layout)
    t = np.linspace(*scene.t_span, 21)
    exact = reference(model, t, x0)
    for method, kw in (("dopri5", {}), ("rosenbrock", {}), ("rk4", {"h": 0.01})):
        out = model.integrate(method, t, x0, rtol=1e-9, atol=1e-12, **kw)
        assert np.abs(out.x - exact).max() < 1e-6, method


def test_stiff_problem_rosenbrock_takes_far_fewer_steps(stiff):
    scene, model = stiff
    x0 = scene.x0(model.layout)
    t = np.linspace(0.0, 2.0, 11)
    exact = solve_ivp(model.rhs, (0.0, 2.0), x0, method="Radau", jac=model.jacobian,
                      t_eval=t, rtol=1e-12, atol=1e-13).y.T
    ros = model.integrate("rosenbrock", t, x0, rtol=1e-6, atol=1e-9)
    dop = model.integrate("dopri5", t, x0, rtol=1e-6, atol=1e-9)
    assert np.abs(ros.x - exact).max() < 1e-4
    assert np.abs(dop.x - exact).max() < 1e-4
    assert ros.n_steps * 10 < dop.n_steps, (ros.n_steps, dop.n_steps)
    assert ros.n_rhs * 5 < dop.n_rhs


# ------------------------------------------------------------- interface
def test_result_and_statistics(disc):
    scene, model = disc
    x0 = scene.x0(model.layout)
    t = [0.0, 0.5, 1.0]
    out = model.integrate(Output.DOPRI5, t, x0)
    assert out.method == "dopri5" and out.status == 0
    assert out.t.shape == (3,) and out.x.shape == (3, model.n_x)
    np.testing.assert_array_equal(out.x[0], x0)
    assert out.wall_time > 0 and out.n_steps > 0
    again = model.integrate("DOPRI5", t, x0)
    assert not np.shares_memory(out.x, again.x)
    np.testing.assert_array_equal(out.x, again.x)  # deterministic
    with pytest.raises(AttributeError):
        out.status = 1  # frozen
    single = model.integrate("rosenbrock", [1.5], x0)
    np.testing.assert_array_equal(single.x, [x0])
    assert single.n_steps == single.n_rhs == 0


def test_reentrant_from_threads(cart):
    scene, model = cart
    x0 = scene.x0(model.layout)
    t = np.linspace(0, 3, 31)
    runs = [(m, np.full(model.n_r, f)) for m in ("dopri5", "rosenbrock") for f in (0.0, 0.5)]
    serial = [model.integrate(m, t, x0, r=r).x for m, r in runs]
    with ThreadPoolExecutor(4) as pool:
        parallel = list(pool.map(lambda a: model.integrate(a[0], t, x0, r=a[1]).x, runs * 3))
    for i, x in enumerate(parallel):
        np.testing.assert_array_equal(x, serial[i % len(runs)])


def test_bad_arguments(disc):
    scene, model = disc
    x0 = scene.x0(model.layout)
    with pytest.raises(ValueError, match="strictly increasing"):
        model.integrate("dopri5", [0.0, 1.0, 1.0], x0)
    with pytest.raises(ValueError, match="strictly increasing"):
        model.integrate("dopri5", [0.0, 2.0, 1.0], x0)
    with pytest.raises(ValueError, match="1-D"):
        model.integrate("dopri5", [[0.0, 1.0]], x0)
    with pytest.raises(ValueError, match="finite"):
        model.integrate("dopri5", [0.0, np.nan], x0)
    with pytest.raises(ValueError, match="pass h"):
        model.integrate("rk4", [0.0, 1.0], x0)
    with pytest.raises(ValueError, match="h must be > 0"):
        model.integrate("rk4", [0.0, 1.0], x0, h=0.0)
    with pytest.raises(ValueError, match="rtol"):
        model.integrate("dopri5", [0.0, 1.0], x0, rtol=-1.0)
    with pytest.raises(ValueError, match="shape"):
        model.integrate("dopri5", [0.0, 1.0], x0[:2])
    with pytest.raises(MbgenError, match="not an integrator"):
        model.integrate("rhs", [0.0, 1.0], x0)
    with pytest.raises(MbgenError, match="not an integrator"):
        model.integrate("euler", [0.0, 1.0], x0)
    plain = mbgen.compile(scene, outputs={"rhs", "rk4"})
    with pytest.raises(MbgenError, match=r"compile with outputs including Output\.DOPRI5"):
        plain.integrate("dopri5", [0.0, 1.0], x0)
    assert plain.integrate("rk4", [0.0, 1.0], x0, h=0.1).n_steps == 10


def test_c_level_bad_arguments(disc):
    scene, model = disc
    ffi, lib, pre = model.ffi, model.lib, model.rendered.prefix
    x0 = np.ascontiguousarray(scene.x0(model.layout))
    p = np.ascontiguousarray(model.default_parameters)
    x_out = np.zeros((3, 4))
    stats = ffi.new(f"{pre}_stats *")

    def call(name, t, work=True, **opt):
        o = ffi.new(f"{pre}_options *", dict(dict(rtol=1e-6, atol=1e-9), **opt))
        t = np.ascontiguousarray(t, dtype=float)
        extra = ()
        if name == "rosenbrock":  # its n_x x n_x matrices live in caller-owned work space
            extra = (ffi.new(f"{pre}_rosenbrock_work *") if work else ffi.NULL,)
        return getattr(lib, f"{pre}_{name}")(ffi.from_buffer("double[]", x0),
                                             ffi.from_buffer("double[]", p), len(t),
                                             ffi.from_buffer("double[]", t),
                                             ffi.from_buffer("double[]", x_out), o, stats,
                                             *extra)

    bad = lib.DISC_PENDULUM_BAD_ARGUMENT
    assert bad == 6 and lib.DISC_PENDULUM_MAX_STEPS == 4
    for name in ("dopri5", "rk4", "rosenbrock"):
        assert call(name, [0.0, 1.0, 0.5], h0=0.1) == bad
        assert call(name, [0.0, 0.5, 1.0], h0=0.1, rtol=-1.0) == bad
        assert call(name, [0.0, 0.5, 1.0], h0=0.1) == lib.DISC_PENDULUM_OK
        assert stats.t_reached == 1.0
    assert call("rk4", [0.0, 0.5, 1.0]) == bad  # rk4 needs h0 > 0
    assert call("rosenbrock", [0.0, 0.5, 1.0], work=False, h0=0.1) == bad  # no work space
    assert lib.disc_pendulum_dopri5(ffi.from_buffer("double[]", x0), ffi.from_buffer("double[]", p),
                                    3, ffi.from_buffer("double[]", np.array([0.0, 0.5, 1.0])),
                                    ffi.from_buffer("double[]", x_out),
                                    ffi.new(f"{pre}_options *", dict(rtol=1e-6, atol=1e-9)),
                                    ffi.NULL) == lib.DISC_PENDULUM_OK  # stats may be NULL


@pytest.mark.parametrize("method,kw", [("dopri5", {}), ("rosenbrock", {}), ("rk4", {"h": 0.01})])
def test_step_limit(disc, method, kw):
    scene, model = disc
    with pytest.raises(IntegrationError, match="MAX_STEPS") as info:
        model.integrate(method, [0.0, 20.0], scene.x0(model.layout), max_steps=25, **kw)
    assert info.value.status == 4
    assert 0.0 < info.value.t < 20.0
    assert "t_reached" in str(info.value)


def test_failing_rhs_status_is_returned():
    """A singular mass matrix (particle on the axis of the paraboloid) stops at once."""
    scene = load_scene("paraboloid")
    model = mbgen.compile(scene, outputs={"dopri5", "rosenbrock"})
    x0 = np.array([0.0, 0.0, 0.0, 1.0])
    for method in ("dopri5", "rosenbrock"):
        with pytest.raises(IntegrationError, match="NOT_POSITIVE_DEFINITE") as info:
            model.integrate(method, [0.0, 1.0], x0)
        assert info.value.status == 1 and info.value.t == 0.0


@pytest.mark.parametrize("which", ["cart", "shaken", "stiff"])
def test_generated_integrators_compile_strictly_as_c_and_cpp(which, request, tmp_path):
    scene, obj = request.getfixturevalue(which)
    rendered = obj.rendered
    assert "_rosenbrock(" in rendered.header and "_options" in rendered.cdef
    for name, text in rendered.files.items():
        (tmp_path / name).write_text(text)
    for cmd in ([GCC, *STRICT_C], [GXX, *STRICT_CXX]):
        proc = subprocess.run([*cmd, "-c", f"{rendered.prefix}.c", "-o", "out.o"], cwd=tmp_path,
                              capture_output=True, text=True)
        assert proc.returncode == 0 and not proc.stderr, proc.stderr
    # no file-scope variables (reentrant): every top-level ';' line is a prototype or typedef
    depth = 0
    for line in rendered.source.splitlines():
        if depth == 0 and line.rstrip().endswith(";") and not line.startswith((" ", "#", "/", "*")):
            raise AssertionError(f"file-scope declaration: {line}")
        depth += line.count("{") - line.count("}")


def test_singular_iteration_matrix_rejects_the_step():
    """bead_wire's Jacobian [[0, 1], [omega^2, 0]] has the eigenvalue omega = 2: with
    h gamma = 1/omega (h = 2 for Rodas4's gamma = 1/4) I/(h gamma) - J is exactly singular.
    That first attempt is rejected, and a shorter step goes on to the closed form's end."""
    scene = load_scene("bead_wire")
    model = mbgen.compile(scene, outputs=ALL)
    assert ROSENBROCK.gamma == 0.25 and model.default_parameters[0] == 2.0
    x0 = scene.x0(model.layout)
    run = model.integrate("rosenbrock", [0.0, 2.0], x0, h=2.0, h_max=2.0, rtol=1e-10,
                          atol=1e-12)
    assert run.n_rejected >= 1
    reference = model.integrate("dopri5", [0.0, 2.0], x0, rtol=1e-10, atol=1e-12)
    assert np.abs(run.x[-1] - reference.x[-1]).max() <= 1e-7 * np.abs(reference.x[-1]).max()


# ------------------------------------------------- a trial stage outside the model's domain
def _domain_model(name, pull):
    """A damped particle pulled to x = 0 by ``pull(x)``; its force also carries
    ``1e-3 sqrt(x + 0.5)``, NaN for x < -0.5, which the flow from x = 0.9 never reaches but
    a long first step's stages do (the pull's linearisation overshoots far past 0)."""
    m = mbgen.Model(name)
    x, = m.coordinates("x")
    u, = m.speeds("u")
    N = m.newtonian()
    P = m.point("P", m.origin, x * N.x)
    m.particle("p", P, 1.0)
    m.force(P, (pull(x) - 50 * u - 1e-3 * sm.sqrt(x + 0.5)) * N.x)
    return mbgen.compile(m, ("rhs", "jacobian", "dopri5", "rosenbrock"),
                         targets=mbgen.Targets(step=True))


@pytest.fixture(scope="module")
def domain():
    return _domain_model("soft_wall", lambda x: -1e3 * sm.tanh(20 * x))


@pytest.mark.parametrize("method", ["rosenbrock", "dopri5"])
def test_a_stage_outside_the_domain_is_a_rejected_step(domain, method):
    """A stage whose state gives NaN (or a mass matrix that is not positive definite, or
    a singular iteration matrix) rejects the attempt instead of ending the run: the
    whole-trajectory integrator and the step API both reach the equilibrium
    ``x = -1e-3 sqrt(0.5) / 2e4``.  Before, Rosenbrock stopped at t = 0 with NONFINITE."""
    equilibrium = -1e-3 * np.sqrt(0.5) / 2e4
    run = domain.integrate(method, [0.0, 1.0], [0.9, 0.0], h=0.5)
    assert run.n_rejected >= 1
    assert abs(run.x[-1, 0] - equilibrium) < 1e-8
    stepper = Stepper(domain, method, 0.0, [0.9, 0.0])
    stepper.memory.h = 0.5                  # the first attempt: half a second
    stepper.step(1.0)
    assert stepper.memory.n_rejected >= 1 and abs(stepper.x[0] - equilibrium) < 1e-8


def test_a_flow_into_the_undefined_region_names_the_stage_status():
    """Where the flow itself runs into the NaN (x reaches -0.5), the steps shrink to the
    resolution of t and the status is the stages' (NONFINITE), not STEP_TOO_SMALL."""
    model = _domain_model("into_the_wall", lambda x: -10.0 * x - 1e3)
    with pytest.raises(IntegrationError, match="NONFINITE") as info:
        model.integrate("rosenbrock", [0.0, 1.0], [0.0, 0.0])
    assert info.value.status == 2 and 0.0 < info.value.t < 1.0
