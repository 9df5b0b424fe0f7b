"""simulate picks the right integrator, passes the Jacobian, says when it is stiff, and
keeps its bounds: a step limit on every path, finite increasing spans, positive tolerances
(from Python and from the command line)."""

import warnings
from functools import cache

import numpy as np
import pytest

import mbgen
from mbgen import Output, UsageError
from mbgen.cli import EXIT_USAGE, main
from mbgen.errors import ArgumentError, IntegrationError, StiffnessWarning
from mbgen.model.scene import load_scene
from mbgen.runtime import simulate as sim
from mbgen.runtime.simulate import choose_method, simulate


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
