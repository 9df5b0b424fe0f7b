"""simulate's bounds: a step limit on every path, finite spans, positive tolerances (issue 9)."""

import numpy as np
import pytest

import mbgen
from mbgen.cli import main
from mbgen.errors import ArgumentError, IntegrationError
from mbgen.model.scene import load_scene
from mbgen.run.simulate import simulate


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
