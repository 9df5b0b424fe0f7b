"""simulate picks the right integrator, passes the Jacobian, says when it is stiff, and
keeps its bounds: a step limit on every path, finite increasing spans, positive tolerances
(from Python and from the command line); with ``saturate`` it clamps the inputs to their
bounds as the generated step API does."""

import warnings
from functools import cache

import numpy as np
import pytest

import mbgen
import models
from mbgen import Output, UsageError
from mbgen.cli import EXIT_USAGE, main
from mbgen.codegen.targets import Targets
from mbgen.errors import (
    ArgumentError,
    ArgumentTypeError,
    IntegrationError,
    StiffnessWarning,
    UnknownNameError,
)
from mbgen.model.scene import load_scene
from mbgen.runtime import simulate as sim
from mbgen.runtime.named import InputTable
from mbgen.runtime.simulate import beyond_bounds, choose_method, saturated, simulate


@cache
def stiff(outputs=(Output.RHS, Output.JACOBIAN, Output.ROSENBROCK)):
    scene = load_scene("stiff_chain", stiffness=1e8)
    return scene, mbgen.compile(scene, outputs)


def test_stiff_scene_runs_its_c_rosenbrock_by_default():
    scene, model = stiff()
    traj = simulate(model, scene.x0(model.layout), scene.t_span, rtol=1e-6, atol=1e-9)
    assert traj.method == "C rosenbrock"
    assert traj.njev > 0 and traj.nlu > 0          # the compiled Jacobian, factorised in C
    assert "generated C integrator" in traj.message
    assert traj.y.shape == (model.n_x, 201) and traj.success


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA", "radau"])
def test_implicit_solve_ivp_methods_get_the_compiled_jacobian(method, monkeypatch):
    scene, model = stiff()
    name = {m.lower(): m for m in sim.IMPLICIT}[method.lower()]
    real, seen = sim.SOLVE_IVP[name], {}

    def spy(fun, t0, y0, t_bound, **kw):
        seen.update(kw)
        return real(fun, t0, y0, t_bound, **kw)

    monkeypatch.setitem(sim.SOLVE_IVP, name, spy)
    x0 = scene.x0(model.layout)
    traj = simulate(model, x0, (0.0, 0.5), method=method, rtol=1e-6, atol=1e-9)
    assert traj.method == name
    jac = seen["jac"]
    x = x0 + 0.01
    assert np.array_equal(jac(0.1, x), model.jacobian(0.1, x))
    assert traj.njev > 0 and traj.nfev < 5000  # no finite-difference Jacobian columns


def test_explicit_method_on_a_stiff_scene_says_so_and_names_the_choice():
    scene, model = stiff()
    with pytest.warns(StiffnessWarning, match=r"DOP853 is stiffness-bound .*h\*rho=.*use the C "
                                              r"integrator 'rosenbrock'"):
        traj = simulate(model, scene.x0(model.layout), (0.0, 0.3), method="DOP853",
                        rtol=1e-6, atol=1e-9, progress=False)
    assert traj.method == "DOP853" and traj.n_steps > sim.STIFF_MIN_STEPS


def test_auto_without_c_integrator_switches_to_radau_when_stiff():
    scene, model = stiff((Output.RHS, Output.JACOBIAN))
    notes = []
    traj = simulate(model, scene.x0(model.layout), scene.t_span, rtol=1e-6, atol=1e-9,
                    say=notes.append, progress=False)
    assert traj.method == "DOP853 -> Radau" and len(notes) == 1
    assert "switching to Radau" in notes[0]
    assert traj.n_steps < 20 * sim.STIFF_MIN_STEPS  # not the millions DOP853 would take
    _, in_c = stiff()
    ref = simulate(in_c, scene.x0(model.layout), scene.t_span, method="rosenbrock", rtol=1e-9,
                   atol=1e-12)
    np.testing.assert_allclose(traj.x, ref.x, rtol=1e-4, atol=1e-5)


def test_non_stiff_scene_stays_explicit_without_notes():
    scene = load_scene("disc_pendulum")
    model = mbgen.compile(scene, [Output.RHS])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        traj = simulate(model, scene.x0(model.layout), scene.t_span, progress=False)
    assert traj.method == "DOP853" and traj.njev == 0


def test_method_names_are_checked():
    _, model = stiff()
    with pytest.raises(UsageError, match="unknown integration method 'RK99'.*DOP853"):
        choose_method(model, "RK99")
    with pytest.raises(UsageError, match="'dopri5' was not generated"):
        choose_method(model, "dopri5")
    assert choose_method(model, "dop853")[0] == "DOP853"
    with pytest.raises(UsageError, match="Python input function cannot drive"):
        choose_method(model, "rosenbrock", r=lambda t, x: np.zeros(0))


@pytest.fixture(scope="module")
def pendulum():
    scene = load_scene("disc_pendulum")
    return scene, mbgen.compile(scene, outputs=("rhs", "dopri5"))


def test_solve_ivp_path_stops_at_its_step_limit(pendulum):
    scene, model = pendulum
    x0 = scene.x0(model.layout)
    with pytest.raises(IntegrationError, match="step limit of 5 steps"):
        simulate(model, x0, (0.0, 10.0), method="RK45", max_steps=5, progress=False)
    ok = simulate(model, x0, (0.0, 0.1), method="RK45", max_steps=10_000, progress=False)
    assert ok.x.shape[0] == 201 and np.all(np.isfinite(ok.x))


def test_c_path_stops_at_its_step_limit(pendulum):
    scene, model = pendulum
    with pytest.raises(IntegrationError):
        simulate(model, scene.x0(model.layout), (0.0, 10.0), method="dopri5", max_steps=3,
                 progress=False)


@pytest.mark.parametrize("span", [(0.0, float("inf")), (0.0, float("nan")), (1.0, 0.0)])
def test_span_must_be_finite_and_increasing(pendulum, span):
    scene, model = pendulum
    with pytest.raises(ArgumentError, match="t_span"):
        simulate(model, scene.x0(model.layout), span, method="RK45", progress=False)


@pytest.mark.parametrize("bad", [0, -3, 2.5, True])
def test_max_steps_must_be_a_positive_whole_number(pendulum, bad):
    scene, model = pendulum
    with pytest.raises(ArgumentError, match="max_steps"):
        simulate(model, scene.x0(model.layout), (0.0, 1.0), method="RK45", max_steps=bad,
                 progress=False)


@pytest.mark.parametrize("argv", [["--rtol", "-1"], ["--atol", "nan"], ["--rtol", "inf"],
                                  ["--max-steps", "0"], ["--rtol", "abc"]])
def test_cli_refuses_bad_tolerances_and_limits(argv, capsys, tmp_path):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "disc_pendulum", "--csv", str(tmp_path / "x.csv"), *argv])
    assert exc.value.code == 2
    assert "error: argument" in capsys.readouterr().err


def test_cli_step_limit_is_a_numerical_failure_named(capsys, tmp_path):
    code = main(["simulate", "disc_pendulum", "--method", "RK45", "--max-steps", "3", "--quiet",
                 "--csv", str(tmp_path / "x.csv")])
    assert code == 5
    assert "step limit of 3 steps" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()        # nothing half-written


@pytest.mark.parametrize("t_end", ["inf", "nan", "-1"])
def test_simulate_refuses_an_infinite_or_backward_span(t_end, capsys, tmp_path):
    """Issue 9.9: simulate --t-end inf ran until killed."""
    assert main(["simulate", "disc_pendulum", "--t-end", t_end, "--csv",
                 str(tmp_path / "x.csv")]) == EXIT_USAGE   # issue 19: an argument, was 3
    assert "--t-end" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()


# ------------------------------------------------------------------ input bounds (saturate)
@cache
def bounded():
    """The bounded cart (F in [-5, 5], T <= 1), not saturated, compiled with its C dopri5
    (and the step API, as tests/runtime/test_stepper.py compiles it: one build for both)."""
    scene = models.bounded_cart(False, ("rhs", "dopri5"))
    return scene, mbgen.compile(scene, targets=Targets(step=True))


X0 = [0.1, 0.2, 0.0, 0.0]


@pytest.mark.parametrize("method", ["dopri5", "RK45"])
def test_saturated_constant_inputs_run_as_the_inputs_at_the_bound(method):
    scene, model = bounded()
    bounds = scene.input_bounds()
    run = dict(method=method, progress=False)
    beyond = simulate(model, X0, (0.0, 2.0), r=[20.0, 3.0], saturate=bounds, **run)
    edge = simulate(model, X0, (0.0, 2.0), r={"F": 5.0, "T": 1.0}, **run)
    assert np.array_equal(beyond.x, edge.x)                             # bit for bit
    assert not np.array_equal(simulate(model, X0, (0.0, 2.0), r=[20.0, 3.0], **run).x, edge.x)
    inside = simulate(model, X0, (0.0, 2.0), r=[-4.0, -30.0], saturate=bounds, **run)
    assert np.array_equal(inside.x, simulate(model, X0, (0.0, 2.0), r=[-4.0, -30.0], **run).x)


def test_a_saturated_table_is_the_clamped_signal():
    """Knots are added where the table crosses a bound: the C integrators' interpolation of
    the new table is clamp(r(t)); a table beyond its bounds throughout is the bound's."""
    scene, model = bounded()
    bounds = scene.input_bounds()
    table = InputTable([0.0, 1.0, 2.0], [[-20.0, 0.0], [20.0, 3.0], [0.0, -2.0]])
    clamped = saturated(model, table, bounds)
    assert set(table.times) < set(clamped.times) and clamped.times.size == 8
    t = np.linspace(-0.5, 2.5, 3001)
    want = np.clip([table(ti) for ti in t], [-5.0, -np.inf], [5.0, 1.0])
    np.testing.assert_allclose([clamped(ti) for ti in t], want, rtol=0, atol=1e-14)
    a = simulate(model, X0, (0.0, 2.0), r=table, saturate=bounds, progress=False)
    b = simulate(model, X0, (0.0, 2.0), r=clamped, progress=False)
    assert a.method == "C dopri5" and np.array_equal(a.x, b.x)
    beyond = InputTable([0.0, 2.0], [[9.0, 2.0], [30.0, 7.0]])
    edge = InputTable([0.0, 2.0], [[5.0, 1.0], [5.0, 1.0]])
    assert np.array_equal(simulate(model, X0, (0.0, 2.0), r=beyond, saturate=bounds,
                                   progress=False).x,
                          simulate(model, X0, (0.0, 2.0), r=edge, progress=False).x)


def test_a_saturated_input_function_is_clamped_at_every_call():
    scene, model = bounded()
    calls = []

    def push(t, x):
        calls.append(t)
        return [20.0 * np.sin(3.0 * t), 3.0]

    f = saturated(model, push, scene.input_bounds())
    assert np.array_equal(f(0.5, X0), [5.0, 1.0]) and calls == [0.5]
    a = simulate(model, X0, (0.0, 1.0), r=push, saturate=scene.input_bounds(), method="RK45",
                 progress=False)
    b = simulate(model, X0, (0.0, 1.0), method="RK45", progress=False,
                 r=lambda t, x: np.clip([20.0 * np.sin(3.0 * t), 3.0], -5.0, [5.0, 1.0]))
    assert np.array_equal(a.x, b.x)


@pytest.mark.parametrize("bad, error, says", [
    (True, ArgumentTypeError, "saturate must be a mapping"),
    ({"G": (0, 1)}, UnknownNameError, "'G' is not one of the inputs"),
    ({"F": (2.0, 1.0)}, ArgumentError, "lower <= upper"),
    ({"F": (float("nan"), 1.0)}, ArgumentError, "lower <= upper"),
    ({"F": 3.0}, ArgumentTypeError, "a pair"),
    ({"F": ("a", 1.0)}, ArgumentTypeError, "lower"),
])
def test_saturate_refuses_bad_bounds(bad, error, says):
    _, model = bounded()
    with pytest.raises(error, match=says):
        simulate(model, X0, (0.0, 1.0), r=[1.0, 1.0], saturate=bad, progress=False)


URDF = """<robot name="arm"><link name="base"/>
<link name="bar"><inertial><origin xyz="0 0 -0.2"/><mass value="1.0"/><inertia ixx="0.01"
 iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="hinge" type="revolute"><parent link="base"/><child link="bar"/><axis xyz="1 0 0"/>
<limit lower="-3" upper="3" effort="2" velocity="4"/></joint></robot>"""


def test_cli_saturate_clamps_a_urdf_torque_to_its_effort(tmp_path, capsys):
    """``--saturate`` (or ``-O saturate=true``): tau = 10 runs as tau = 2, its effort; the
    speed over its velocity limit is reported, not clamped; no bounds: a usage error."""
    robot = tmp_path / "arm.urdf"
    robot.write_text(URDF)
    csv = {k: tmp_path / f"{k}.csv" for k in ("beyond", "edge", "scene")}

    def sim_cli(*argv):
        assert main(["simulate", str(robot), "--quiet", "--integrator", "dopri5", *argv]) == 0
        return capsys.readouterr().out

    said = sim_cli("-r", "tau_hinge=10", "--saturate", "--csv", str(csv["beyond"]))
    assert "inputs clamped to their bounds: tau_hinge in [-2, 2]" in said
    assert "speeds beyond their bounds (reported, not clamped): u_hinge from t = " in said
    sim_cli("-r", "tau_hinge=2", "--csv", str(csv["edge"]))
    sim_cli("-r", "tau_hinge=10", "-O", "saturate=true", "--csv", str(csv["scene"]))
    assert csv["beyond"].read_text() == csv["edge"].read_text() == csv["scene"].read_text()
    assert main(["simulate", "disc_pendulum", "--saturate", "--csv",
                 str(tmp_path / "x.csv")]) == EXIT_USAGE
    assert "--saturate: no input of scene 'disc_pendulum' has bounds" in capsys.readouterr().err


def test_beyond_bounds_names_the_first_time_and_the_extreme():
    traj = sim.Trajectory(np.arange(4.0), np.array([[0.0, 1.0], [5.0, 2.0], [-8.0, 3.0],
                                                    [1.0, 4.0]]), ("u", "v"), 0, 0.0, "m")
    assert beyond_bounds(traj, {"u": (-6.0, 4.0), "v": (0.0, 9.0), "w": (0, 1)}) == {
        "u": (1.0, -8.0)}
