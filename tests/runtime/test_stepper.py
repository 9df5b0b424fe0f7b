"""The step API: same steps and bits as the whole-trajectory integrators, inputs per step,
step size kept between calls, caller-owned memory (the stated stack bounds:
``tests/codegen/test_header.py``)."""

import dataclasses
import shutil
import subprocess

import numpy as np
import pytest
import sympy as sm

import mbgen
import models
from mbgen.abi import INTEGRATOR_STATUS_CODES
from mbgen.codegen.targets import Targets
from mbgen.errors import ArgumentTypeError, SceneError
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.stepper import Stepper

CC = shutil.which("gcc") or shutil.which("cc")


@pytest.fixture(scope="module")
def pendulum():
    scene = load_scene("disc_pendulum")
    return scene, mbgen.compile(scene, ("rhs", "dopri5", "rk4"), targets=Targets(step=True))


@pytest.fixture(scope="module")
def chain():
    scene = load_scene("stiff_chain")
    return scene, mbgen.compile(scene, targets=Targets(step=True))


def test_dopri5_step_takes_the_steps_of_integrate(pendulum):
    scene, model = pendulum
    x0 = scene.x0(model.layout)
    whole = model.integrate("dopri5", [0.0, 8.0], x0, rtol=1e-8, atol=1e-10)
    s = Stepper(model, "dopri5", 0.0, x0, rtol=1e-8, atol=1e-10)
    s.step(8.0)
    assert s.t == 8.0
    assert np.array_equal(s.x, whole.x[-1])                     # bit for bit
    assert s.memory.n_steps == whole.n_steps and s.memory.n_rhs == whole.n_rhs


def test_rosenbrock_step_takes_the_steps_of_integrate(chain):
    scene, model = chain
    x0 = scene.x0(model.layout)
    whole = model.integrate("rosenbrock", [0.0, 4.0], x0, rtol=1e-6, atol=1e-9)
    s = Stepper(model, "rosenbrock", 0.0, x0, rtol=1e-6, atol=1e-9)
    s.step(4.0)
    assert np.array_equal(s.x, whole.x[-1])
    assert (s.memory.n_steps, s.memory.n_jac) == (whole.n_steps, whole.n_jac)


def test_rk4_step_is_integrate_with_the_same_step(pendulum):
    scene, model = pendulum
    x0 = scene.x0(model.layout)
    h = 0.125                                                    # exact in binary
    t = h * np.arange(41)
    whole = model.integrate("rk4", t, x0, h=h)
    s = Stepper(model, "rk4", 0.0, x0)
    rows = [s.x] + [s.step(h) for _ in t[1:]]
    assert np.array_equal(np.array(rows), whole.x)


def _attempts(mem):
    return mem.n_steps + mem.n_rejected


def test_adaptive_steps_keep_their_step_size_and_follow_integrate(pendulum):
    scene, model = pendulum
    x0 = scene.x0(model.layout)
    t = np.linspace(0.0, 10.0, 201)
    ref = model.integrate("dopri5", t, x0, rtol=1e-10, atol=1e-12)
    kept = Stepper(model, "dopri5", 0.0, x0, rtol=1e-10, atol=1e-12)
    restarted = Stepper(model, "dopri5", 0.0, x0, rtol=1e-10, atol=1e-12)
    xs = [kept.x]
    for a, b in zip(t[:-1], t[1:]):
        xs.append(kept.step(b - a))
        restarted.memory.h = 0.0                 # what a restart per call would do
        restarted.memory.f_valid = 0
        restarted.step(b - a)
    assert np.abs(np.array(xs) - ref.x).max() < 1e-7
    assert np.abs(restarted.x - ref.x[-1]).max() < 1e-7
    # a restart costs the step-size search (2 RHS calls) and the steps that regrow h
    assert kept.memory.n_rhs + 2 * 200 < restarted.memory.n_rhs
    assert kept.h > 0.0


def test_inputs_change_between_steps():
    scene = load_scene("n_link_cart", n=2)
    model = mbgen.compile(scene, targets=Targets(step=True))
    x0 = scene.x0(model.layout)
    s = Stepper(model, "dopri5", 0.0, x0, rtol=1e-10, atol=1e-12)
    s.step(0.5, r=[0.0])
    rhs, tries = s.memory.n_rhs, _attempts(s.memory)
    s.step(0.5, r=[0.0])
    # 6 RHS calls per attempted step; f(t, x) reused (first same as last across calls)
    assert s.memory.n_rhs - rhs == 6 * (_attempts(s.memory) - tries)
    x_unforced = s.x
    a = Stepper(model, "dopri5", 0.0, x0, rtol=1e-10, atol=1e-12)
    a.step(0.5, r=[0.0])
    rhs, tries = a.memory.n_rhs, _attempts(a.memory)
    a.step(0.5, r=[5.0])
    assert a.memory.n_rhs - rhs == 6 * (_attempts(a.memory) - tries) + 1  # f for the new r
    u0 = model.state_names.index("u0")
    assert abs(a.x[u0] - x_unforced[u0]) > 0.1
    # and it matches integrate with the force held from t = 0.5
    half = model.integrate("dopri5", [0.0, 0.5], x0, r=[0.0], rtol=1e-10, atol=1e-12).x[-1]
    rest = model.integrate("dopri5", [0.5, 1.0], half, r=[5.0], rtol=1e-10, atol=1e-12).x[-1]
    assert np.abs(a.x - rest).max() < 1e-8


def test_failure_keeps_the_last_state_and_reports(pendulum):
    scene, model = pendulum
    s = Stepper(model, "dopri5", 0.0, scene.x0(model.layout))
    s.memory.max_steps = 2
    with pytest.raises(mbgen.IntegrationError, match="MAX_STEPS"):
        s.step(10.0)
    assert 0.0 < s.t < 10.0 and np.all(np.isfinite(s.x))
    with pytest.raises(mbgen.IntegrationError, match="BAD_ARGUMENT"):
        s.step(-1.0)


def test_memory_holds_the_large_arrays(chain):
    _, model = chain
    n = model.n_x
    size = model.ffi.sizeof("stiff_chain_rosenbrock_memory")
    assert size >= 8 * 2 * n * n                                 # J and G live in the memory
    bounds = dict(model.rendered.stack_bounds)
    assert bounds["stiff_chain_rosenbrock_step"] < 8 * 2 * n * n + 8 * 1024


CXX = shutil.which("g++") or shutil.which("c++")


@pytest.mark.parametrize("name", ["disc_pendulum", "stiff_chain", "n_link_cart"])
def test_step_target_compiles_strictly_as_c_and_cxx(name, tmp_path):
    rendered = run(load_scene(name), build=False, targets=Targets(step=True)).rendered
    for fname, text in rendered.files.items():
        (tmp_path / fname).write_text(text)
    src = f"{rendered.prefix}.c"
    for tool, flags in ((CC, ["-std=c99"]), (CXX, ["-x", "c++", "-std=c++11"])):
        done = subprocess.run([tool, *flags, "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2",
                               "-c", src, "-o", "m.o"], cwd=tmp_path, capture_output=True,
                              text=True)
        assert done.returncode == 0 and not done.stderr, done.stderr


# ------------------------------------------------------------------ time and bad arguments
def driven_pendulum():
    """The support pendulum driven by the torque ``a sin(w t)``: its RHS depends on ``t``."""
    m = models.pendulum("driven_pendulum")
    a, w = m.constants("a w")
    m.torque(m.frame("B"), a * sm.sin(w * mbgen.t) * m.frame("N").z)
    return mbgen.Scene("driven_pendulum", m,
                       parameters={"l": 1.0, "g": 9.81, "m": 1.0, "a": 2.0, "w": 3.0},
                       initial_state={"q": 0.5, "u": 0.0}, t_span=(0.0, 2.0))


@pytest.fixture(scope="module")
def driven():
    scene = driven_pendulum()
    return scene, mbgen.compile(scene, ("rhs", "dopri5", "rk4"), targets=Targets(step=True))


@pytest.fixture(scope="module")
def cart():
    scene = load_scene("n_link_cart", n=2)
    return scene, mbgen.compile(scene, targets=Targets(step=True))


def test_steps_from_t0_follow_integrate_over_t0_to_t0_plus_nh(driven):
    """The step API keeps t0: from t0 = 3.7 on a model with explicit time, n steps of h are
    integrate over [t0, t0 + n h] (t0 + k h exact in binary below 4, so bit for bit)."""
    scene, model = driven
    x0 = scene.x0(model.layout)
    t0, h, n = 3.7, 0.0625, 4
    t = t0 + h * np.arange(n + 1)
    assert np.all(np.diff(t) == h) and t[-1] < 4.0
    whole = model.integrate("rk4", t, x0, h=h)
    s = Stepper(model, "rk4", t0, x0)
    rows = [s.x] + [s.step(h) for _ in t[1:]]
    assert np.array_equal(np.array(rows), whole.x)
    assert s.t == t[-1]
    whole = model.integrate("dopri5", [t0, t[-1]], x0, rtol=1e-9, atol=1e-12)
    s = Stepper(model, "dopri5", t0, x0, rtol=1e-9, atol=1e-12)
    s.step(t[-1] - t0)
    assert s.t == t[-1] and np.array_equal(s.x, whole.x[-1])


@pytest.mark.parametrize("method", ["rk4", "dopri5", "rosenbrock"])
def test_a_step_that_cannot_advance_time_is_an_error(pendulum, chain, method):
    """t + h == t (h below the resolution of t) is STEP_TOO_SMALL, never OK with t unchanged;
    a step that is not a positive finite number is BAD_ARGUMENT.  The state stays as it was."""
    scene, model = chain if method == "rosenbrock" else pendulum
    x0 = scene.x0(model.layout)
    s = Stepper(model, method, 1e16, x0)
    assert 1e16 + 1.0 == 1e16
    with pytest.raises(mbgen.IntegrationError, match="STEP_TOO_SMALL"):
        s.step(1.0)
    assert s.t == 1e16 and np.array_equal(s.x, x0) and s.memory.n_rhs == 0
    s = Stepper(model, method, 0.0, x0)
    for h in (float("nan"), float("inf"), -1.0, 0.0, -0.0):
        with pytest.raises(mbgen.IntegrationError, match="BAD_ARGUMENT"):
            s.step(h)
    assert s.t == 0.0 and np.array_equal(s.x, x0) and s.memory.n_rhs == 0
    s = Stepper(model, method, 1e308, x0)
    with pytest.raises(mbgen.IntegrationError, match="BAD_ARGUMENT"):
        s.step(1e308)                                           # t + h overflows
    assert s.t == 1e308 and s.memory.n_rhs == 0


@pytest.mark.parametrize("method", ["rk4", "dopri5", "rosenbrock"])
def test_null_pointers_are_bad_arguments(cart, chain, method):
    """mem, x0, p and r = NULL in the C step functions return BAD_ARGUMENT (no segfault)."""
    scene, model = chain if method == "rosenbrock" else cart
    ffi, lib, prefix = model.ffi, model.lib, model.rendered.prefix
    init = getattr(lib, f"{prefix}_{method}_init")
    step = getattr(lib, f"{prefix}_{method}_step")
    bad = {name: code for name, code, _ in INTEGRATOR_STATUS_CODES}["BAD_ARGUMENT"]
    x0 = ffi.from_buffer("double[]", np.ascontiguousarray(scene.x0(model.layout)))
    args = [ffi.from_buffer("double[]", np.ascontiguousarray(v))
            for v, n in ((model.default_parameters, model.n_p), (np.zeros(model.n_r), model.n_r))
            if n]
    assert args
    mem = ffi.new(f"{prefix}_{method}_memory *")
    assert init(ffi.NULL, 0.0, x0, 1e-6, 1e-9) == bad
    assert init(mem, 0.0, ffi.NULL, 1e-6, 1e-9) == bad
    assert init(mem, 0.0, x0, 1e-6, 1e-9) == 0
    assert step(ffi.NULL, 0.1, *args) == bad
    for i in range(len(args)):
        assert step(mem, 0.1, *args[:i], ffi.NULL, *args[i + 1:]) == bad
    assert mem.t == 0.0 and mem.n_rhs == 0
    assert step(mem, 0.1, *args) == 0 and mem.t == 0.1


# ------------------------------------------------------------------ issue 28: t0 and types
@pytest.mark.parametrize("method", ["rk4", "dopri5", "rosenbrock"])
def test_init_refuses_a_start_time_that_is_not_finite(pendulum, chain, method):
    """The C init checks t0 as it checks x0: NaN or an infinite t0 is BAD_ARGUMENT (a NaN
    time would make every later step's span check pass or fail by accident)."""
    scene, model = chain if method == "rosenbrock" else pendulum
    x0 = scene.x0(model.layout)
    for t0 in (float("nan"), float("inf"), -float("inf")):
        with pytest.raises(mbgen.IntegrationError, match="init failed .*BAD_ARGUMENT"):
            Stepper(model, method, t0, x0)


@pytest.mark.parametrize("value", [None, 0.01j, "0.01", "5"])
@pytest.mark.parametrize("name", ["t0", "rtol", "atol", "h"])
def test_numbers_of_the_wrong_type_are_refused_naming_the_argument(pendulum, name, value):
    """Issue 28: None and complex numbers gave raw TypeErrors from float(); the strings '0.01'
    and '5' were parsed and silently used.  Each is an ArgumentTypeError naming the argument
    (a numpy real is still taken)."""
    scene, model = pendulum
    x0 = scene.x0(model.layout)
    kw = {"t0": 0.0, "rtol": 1e-6, "atol": 1e-9, "h": 0.01, name: value}
    with pytest.raises(ArgumentTypeError, match=f"^{name} must be a real number"):
        Stepper(model, "dopri5", kw["t0"], x0, rtol=kw["rtol"], atol=kw["atol"]).step(kw["h"])
    s = Stepper(model, "dopri5", np.float64(0.0), x0, rtol=np.float32(1e-6), atol=np.int64(1))
    assert s.step(np.float64(0.01)).shape == x0.shape and s.t == 0.01


# ------------------------------------------------------------------ input bounds (saturate)
def bounded_models(outputs=("rhs", "dopri5")):
    """The bounded cart (F in [-5, 5], T <= 1) with the step API, saturated and not."""
    return {on: mbgen.compile(models.bounded_cart(on, outputs), targets=Targets(step=True))
            for on in (True, False)}


@pytest.fixture(scope="module")
def bounded():
    return bounded_models()


def _steps(model, method, r, n=4, h=0.1):
    s = Stepper(model, method, 0.0, [0.1, 0.2, 0.0, 0.0], rtol=1e-8, atol=1e-10)
    for _ in range(n):
        s.step(h, r=r)
    return s


def _beyond_is_at_the_bound(bounded, method):
    """Saturated: F = 20, T = 3 take bit for bit the steps of F = 5, T = 1 (and F = -20 those
    of F = -5, T unbounded below passes -40); each call counts its clamped inputs; inside the
    bounds the saturated model steps as the unsaturated one."""
    model = bounded[True]
    for beyond, at, clamped in (([20.0, 3.0], [5.0, 1.0], 2), ([-20.0, -40.0], [-5.0, -40.0], 1)):
        over, edge = _steps(model, method, beyond), _steps(model, method, at)
        assert np.array_equal(over.x, edge.x) and over.t == edge.t
        assert over.memory.n_steps == edge.memory.n_steps
        assert (over.n_saturated, edge.n_saturated) == (4 * clamped, 0)
    inside = [4.5, -0.5]
    assert np.array_equal(_steps(model, method, inside).x, _steps(bounded[False], method,
                                                                   inside).x)


@pytest.mark.parametrize("method", ["rk4", "dopri5"])
def test_an_input_beyond_its_bound_steps_as_the_input_at_the_bound(bounded, method):
    _beyond_is_at_the_bound(bounded, method)


@pytest.mark.slow
def test_rosenbrock_steps_saturate_too(tmp_path):
    """The implicit step (and its Jacobian's inputs) reads the clamped inputs; strict C/C++."""
    rosenbrock = bounded_models(("rhs", "jacobian", "rosenbrock"))
    _beyond_is_at_the_bound(rosenbrock, "rosenbrock")
    _compiles_strictly(rosenbrock[True].rendered, tmp_path)


def test_without_saturation_the_inputs_pass_as_given(bounded):
    """saturate off (the default): no clamp, no bounds in the header, no counter."""
    model = bounded[False]
    assert not np.array_equal(_steps(model, "dopri5", [20.0, 3.0]).x,
                              _steps(model, "dopri5", [5.0, 1.0]).x)
    assert "saturate" not in model.rendered.header + model.rendered.source
    assert _steps(model, "rk4", [20.0, 3.0]).n_saturated == 0


def test_the_header_states_the_bounds_by_input(bounded):
    model = bounded[True]
    header = model.rendered.header
    assert " *   r[0] F: [-5.0, 5.0]\n *   r[1] T: [-HUGE_VAL, 1.0]\n" in header
    assert "extern const double cart_pendulum_input_upper[2];" in header
    assert "long n_saturated;" in header
    lib = model.lib
    assert list(lib.cart_pendulum_input_lower) == [-5.0, -np.inf]
    assert list(lib.cart_pendulum_input_upper) == [5.0, 1.0]
    r = model.ffi.new("double[2]", [7.0, float("nan")])
    assert lib.cart_pendulum_saturate_inputs(r, r) == 1           # NaN passes, unclamped
    assert r[0] == 5.0 and np.isnan(r[1])


def _compiles_strictly(rendered, folder):
    for fname, text in rendered.files.items():
        (folder / fname).write_text(text)
    for tool, flags in ((CC, ["-std=c99"]), (CXX, ["-x", "c++", "-std=c++11"])):
        done = subprocess.run([tool, *flags, "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2",
                               "-c", f"{rendered.prefix}.c", "-o", "m.o"], cwd=folder,
                              capture_output=True, text=True)
        assert done.returncode == 0 and not done.stderr, done.stderr


def test_saturated_step_target_compiles_strictly_as_c_and_cxx(bounded, tmp_path):
    _compiles_strictly(bounded[True].rendered, tmp_path)


def test_saturate_needs_a_bounded_input():
    with pytest.raises(SceneError, match="no input it keeps has bounds"):
        dataclasses.replace(models.two_input_cart(), saturate=True)
    scene = models.two_input_cart()
    scene.model.bound("F", -5.0, 5.0)
    with pytest.raises(SceneError, match="no input it keeps has bounds"):
        dataclasses.replace(scene, inputs=("T",), saturate=True)    # F is sliced away
    with pytest.raises(SceneError, match="saturate must be True or False"):
        dataclasses.replace(models.bounded_cart(False), saturate="yes")
    assert models.bounded_cart().input_bounds() == {"F": (-5.0, 5.0), "T": (-np.inf, 1.0)}
    only_t = dataclasses.replace(models.bounded_cart(), inputs=("T",))
    assert only_t.input_bounds() == {"T": (-np.inf, 1.0)}
