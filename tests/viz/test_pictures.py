"""Pictures and long diagnostics: simulate --plot, animate, notebook summaries, the
work-precision plot, bench scaling -o, the stiff reference, the stress report's format and
files, and matplotlib as an optional dependency."""

import json
import math
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

import mbgen
from mbgen import Model, Scene
from mbgen.cli import main
from mbgen.errors import IntegrationError, SceneError
from mbgen.model.scene import load_scene

PNG = b"\x89PNG\r\n\x1a\n"


def cartesian_pendulum_scene():
    """A pendulum in Cartesian coordinates with its rod as a holonomic constraint."""
    m = Model("cart_pend_pic")
    x, y = m.coordinates("x y")
    m.speeds("vx vy")
    l, mass, g = m.constants("l m g")
    N = m.newtonian()
    m.particle("bob", m.point("P", m.origin, x * N.x + y * N.y), mass)
    m.gravity(-g * N.y)
    m.holonomic([x**2 + y**2 - l**2], [y])
    return Scene("cart_pend_pic", m, parameters={"l": 1.0, "m": 1.0, "g": 9.81},
                 initial_state={"x": 0.6, "y": -0.8}, t_span=(0.0, 3.0),
                 conserves_energy=True)


# ------------------------------------------------------------------ simulate --plot
def test_simulate_plot_writes_states_and_energy_drift(tmp_path, capsys):
    png, csv = tmp_path / "sp.png", tmp_path / "sp.csv"
    rc = main(["simulate", "spring_pendulum", "-O", "stiffness=1e3", "--method", "dopri5",
               "--t-end", "2", "--csv", str(csv), "--plot", str(png)])
    assert rc == 0 and png.read_bytes()[:8] == PNG and f"plot: {png}" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sp.csv", "sp.png"]  # no temporaries


def test_energy_drift_is_small_when_conserved_and_large_when_not():
    from mbgen.runtime.simulate import simulate_in_c
    from mbgen.viz.plots import diagnostics

    scene = load_scene("spring_pendulum", stiffness=1e3)
    model = mbgen.compile(scene, ("rhs", "dopri5"))
    traj = simulate_in_c(model, scene.x0(model.layout), (0, 2), rtol=1e-10, atol=1e-12)
    good = diagnostics(scene, traj.t, traj.x, traj.names)
    assert np.max(np.abs(good["energy_drift"])) < 1e-8 and "residual" not in good
    # the same scene with a damper, simulated as is but judged as if it conserved energy
    wet = load_scene("spring_pendulum", stiffness=1e3, damping=5.0)
    wet_model = mbgen.compile(wet, ("rhs", "dopri5"))
    damped = wet_model.integrate("dopri5", traj.t, traj.x[0], wet.p(wet_model.layout),
                                 rtol=1e-10, atol=1e-12)
    bad = diagnostics(scene, damped.t, damped.x, traj.names)
    assert np.max(np.abs(bad["energy_drift"])) > 1e-5     # 1000 x the conserved drift
    not_conserving = diagnostics(replace(scene, conserves_energy=False), traj.t, traj.x,
                                 traj.names)
    assert "energy_drift" not in not_conserving and "does not conserve" in \
        not_conserving["notes"][0]


def test_constraint_residual_panel_sees_projection(tmp_path):
    from mbgen.viz.plots import diagnostics, plot_simulation

    scene = cartesian_pendulum_scene()
    model = mbgen.compile(scene, ("rhs", "holonomic", "holonomic_jacobian", "dopri5"))
    x0 = model.consistent(scene.x0(model.layout))
    t = np.linspace(0, 3, 31)
    names = model.state_names
    tight = model.integrate("dopri5", t, x0, rtol=1e-10, atol=1e-12, project=False)
    loose = model.integrate("dopri5", t, x0, rtol=1e-3, atol=1e-6, project=False)
    res_tight = diagnostics(scene, tight.t, tight.x, names)["residual"]
    res_loose = diagnostics(scene, loose.t, loose.x, names)["residual"]
    assert res_tight.shape == (31,) and res_tight[0] < 1e-12 and res_tight.max() < 1e-7
    assert res_loose.max() > 100 * res_tight.max()       # drift at a loose tolerance
    off = replace(loose, x=loose.x.copy())
    off.x[:, 1] = -0.7                                  # y off the rod: |x² + y² - 1|
    res_off = diagnostics(scene, off.t, off.x, names)["residual"]
    np.testing.assert_allclose(res_off, np.abs(off.x[:, 0]**2 + 0.49 - 1.0), rtol=1e-12)
    png = plot_simulation(off, tmp_path / "res.png", scene=scene, names=names)
    assert png.read_bytes()[:8] == PNG


# ------------------------------------------------------------------ animate
def test_simulate_plot_shows_the_inputs(tmp_path, capsys, monkeypatch):
    """``simulate --plot`` drew the states only: a run driven by ``-r F=table.csv`` did not
    show what drove it (and called the work of the push an energy drift)."""
    from mbgen.viz import plots

    figures = []
    save = plots.save_png
    monkeypatch.setattr(plots, "save_png",
                        lambda fig, path: figures.append(fig) or save(fig, path))
    (tmp_path / "push.csv").write_text("t,F\n0.5,0\n1,2\n3,2\n")
    png = tmp_path / "cart.png"
    assert main(["simulate", "n_link_cart", "-O", "n=1", "-r", f"F={tmp_path / 'push.csv'}",
                 "--t-end", "4", "--csv", str(tmp_path / "c.csv"), "--plot", str(png)]) == 0
    [fig] = figures
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["coordinates", "speeds", "inputs"], labels
    [line] = fig.axes[2].get_lines()
    assert line.get_label() == "F"
    np.testing.assert_array_equal(line.get_xdata(), [0.0, 0.5, 1.0, 3.0, 4.0])
    np.testing.assert_array_equal(line.get_ydata(), [0.0, 0.0, 2.0, 2.0, 2.0])
    assert "no energy drift: the inputs do work" in fig._suptitle.get_text()
    assert png.stat().st_size > 0
    figures.clear()   # constant inputs: a flat line, and the energy drift when they are 0
    assert main(["simulate", "n_link_cart", "-O", "n=1", "--t-end", "1", "--csv",
                 str(tmp_path / "c.csv"), "--plot", str(png)]) == 0
    [fig] = figures
    assert [ax.get_ylabel() for ax in fig.axes][2] == "inputs"
    assert fig.axes[3].get_ylabel().startswith("energy drift")


def test_animate_gif_frames_and_html(tmp_path):
    from PIL import Image

    gif = tmp_path / "dp.gif"
    assert main(["animate", "disc_pendulum", "-o", str(gif), "--frames", "4",
                 "--t-end", "1"]) == 0
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == 4
    html = tmp_path / "dp.html"
    assert main(["animate", "disc_pendulum", "-o", str(html), "--frames", "3"]) == 0
    text = html.read_text()
    assert text.startswith("<!DOCTYPE html>") and "<img" in text and "disc_pendulum" in text


def test_animated_positions_follow_the_model():
    """The bob hangs l = 4 from the suspension point E on the disc, at every frame."""
    from mbgen.viz.animate import _simulate_positions

    scene = load_scene("disc_pendulum")
    t, pos, _ = _simulate_positions(scene, ["E", "P"], 5, 2.0)
    assert pos.shape == (5, 2, 3) and np.isclose(t[-1], 2.0)
    np.testing.assert_allclose(np.linalg.norm(pos[:, 1] - pos[:, 0], axis=1), 4.0, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(pos[:, 0, :2], axis=1), 1.0, rtol=1e-12)  # s = 1


def test_body_axes_are_the_frames_direction_cosines(tmp_path):
    """torque_free has no points but a body: its axes are drawn from N.dcm(B) = Rx Ry Rz."""
    from mbgen.viz.animate import _body_axes, _simulate_positions

    scene = load_scene("torque_free")
    t, pos, states = _simulate_positions(scene, [], 3, 1.0)
    (name, centre, R), = _body_axes(scene, scene.model, t, states)
    assert name == "body" and pos.shape == (3, 0, 3) and R.shape == (3, 3, 3)
    q1, q2, q3 = (states[n][0] for n in ("q1", "q2", "q3"))
    c, s_ = np.cos, np.sin
    rx = np.array([[1, 0, 0], [0, c(q1), -s_(q1)], [0, s_(q1), c(q1)]])
    ry = np.array([[c(q2), 0, s_(q2)], [0, 1, 0], [-s_(q2), 0, c(q2)]])
    rz = np.array([[c(q3), -s_(q3), 0], [s_(q3), c(q3), 0], [0, 0, 1]])
    np.testing.assert_allclose(R[0], rx @ ry @ rz, atol=1e-14)
    for m in R:
        np.testing.assert_allclose(m.T @ m, np.eye(3), atol=1e-13)
    assert main(["animate", "torque_free", "-o", str(tmp_path / "tf.gif"), "--frames", "3"]) == 0


def test_animate_refuses_what_it_cannot_draw(tmp_path, capsys):
    assert main(["animate", "disc_pendulum", "-o", str(tmp_path / "a.mp4")]) == 2  # issue 19: 3
    assert "mbgen: error:" in capsys.readouterr().err and not (tmp_path / "a.mp4").exists()
    from mbgen.viz.animate import animate_scene

    eq_scene = replace(load_scene("disc_pendulum"), model=mbgen.equations_of(
        load_scene("disc_pendulum")))
    with pytest.raises(SceneError, match="holds equations"):
        animate_scene(eq_scene, tmp_path / "a.html")


# ------------------------------------------------------------------ notebook summaries
def test_repr_html_is_a_summary_not_the_matrices():
    scene = load_scene("n_link_cart", n=16)
    eq = mbgen.equations_of(scene)
    compiled = mbgen.compile(load_scene("disc_pendulum"))
    for obj in (scene.model, eq, compiled):
        text = obj._repr_html_()
        assert text.startswith("<table>") and len(text) < 4000
        assert "sin(" not in text and "cos(" not in text      # no expressions
    text = eq._repr_html_()
    assert "q0, q1, q2" in text and "..." in text and "(34)" in text   # 34 states, shortened
    assert "M 17 x 17" in text and "ops" in text
    assert "29 after CSE (53 before)" in compiled._repr_html_()
    from mbgen import summary
    assert summary.names(["<b>", "a&b"]) == "&lt;b&gt;, a&amp;b"      # text is escaped
    with pytest.raises(mbgen.ModelError, match="letters, digits"):  # and names never get there
        mbgen.Model("<b>")


# ------------------------------------------------------------------ optional matplotlib
def test_missing_matplotlib_names_the_extra(tmp_path, monkeypatch, capsys):
    from mbgen.errors import MissingExtraError
    from mbgen.viz.plots import plot_simulation

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(MissingExtraError, match=r"mbgen\[plot\]"):
        plot_simulation(type("R", (), {"t": [0, 1], "x": [[0], [1]]})(), tmp_path / "x.png")
    assert main(["animate", "disc_pendulum", "-o", str(tmp_path / "a.gif")]) == 2
    assert "pip install 'mbgen[plot]'" in capsys.readouterr().err


def test_generate_check_and_simulate_do_not_import_matplotlib(tmp_path):
    code = ("import sys; from mbgen.cli import main; "
            f"assert main(['generate', 'paraboloid', '-o', {str(tmp_path / 'g')!r}]) == 0; "
            "assert main(['check', 'paraboloid', '--samples', '3']) == 0; "
            f"assert main(['simulate', 'paraboloid', '--csv', {str(tmp_path / 's.csv')!r}]) == 0;"
            " assert 'matplotlib' not in sys.modules, 'matplotlib was imported'")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path)
    assert done.returncode == 0, done.stderr


def test_py_typed_is_shipped():
    from importlib import resources

    assert resources.files("mbgen").joinpath("py.typed").is_file()


# ------------------------------------------------------------------ work-precision plot
def _report(points, disagreement=1e-9):
    from mbgen.studies.workprecision import WorkPrecisionReport
    from mbgen.studies.workprecision.reference import Reference

    t = np.linspace(0, 1, 3)
    ref = Reference(t, np.zeros((3, 1)), "LSODA", "Radau", disagreement)
    return WorkPrecisionReport("synthetic", ("x",), t, (1e-3, 1e-6), 1e-2, "atol", ref,
                               tuple(points), 1, 2.0, 1.0)


def _point(method, backend, jac, rtol, status="ok", err=math.nan, time_s=math.nan):
    from mbgen.studies.workprecision import Point

    return Point(method, backend, jac, rtol, rtol * 1e-2, None, status, "", err, err, err,
                 time_s, probe_s=0.5 if status == "failed" else None)


def test_pareto_front_and_tolerance_labels():
    from mbgen.studies.workprecision.plot import pareto_front, tolerance_label

    pts = [_point("RK45", "c", False, 1e-3, err=1e-3, time_s=1e-3),
           _point("RK45", "c", False, 1e-6, err=1e-6, time_s=1e-2),
           _point("Radau", "c", True, 1e-3, err=1e-2, time_s=2e-3),    # dominated
           _point("dopri5", "c", False, 1e-6, err=1e-7, time_s=5e-3),
           _point("DOP853", "c", False, 1e-6, status="failed")]
    front = pareto_front(pts)
    assert [(p.method, p.rtol) for p in front] == [("RK45", 1e-3), ("dopri5", 1e-6)]
    assert tolerance_label(pts[1]) == "6" and tolerance_label(_point("rk4", "c", False,
                                                                     2.5e-6)) == "2.5e-06"


def test_work_precision_plot_with_failures_and_many_series(tmp_path):
    pts = []
    for method in ("RK45", "DOP853", "Radau", "BDF", "LSODA", "dopri5", "rosenbrock", "rk4"):
        for backend in ("lambdify", "python", "c"):
            for k, rtol in enumerate((1e-3, 1e-6)):
                pts.append(_point(method, backend, method in ("Radau", "rosenbrock"), rtol,
                                  err=rtol * (1 + k), time_s=1e-3 * (k + 1)))
    pts += [_point("DOP853", "c", False, 1e-9, status="over budget"),
            _point("BDF", "c", False, 1e-9, status="failed"),
            _point("BDF", "c", False, 1e-10, status="skipped")]
    path = _report(pts).plot(tmp_path / "wp.png")
    assert path.read_bytes()[:8] == PNG
    # a report with nothing ok still draws (and says so)
    assert _report(pts[-3:]).plot(tmp_path / "none.png").read_bytes()[:8] == PNG


# ------------------------------------------------------------------ bench: scaling -o, reference
def _rows():
    from mbgen.bench.scaling import ScalingRow

    return [ScalingRow(n, 0.1 * n, 0.01 * n, 0.02, 1.0, 1e-6 * n, 100 * n, 40 * n,
                       *((0.5 * n, 0.1 * n, 1e-4, 300 * n, 90 * n, 1e-15) if n < 8 else ()))
            for n in (2, 4, 8)]


def test_bench_scaling_writes_csv_and_plot_to_the_output_folder(tmp_path, monkeypatch, capsys):
    import mbgen.bench.scaling as bench

    monkeypatch.setattr(bench, "scaling", lambda ns, **kw: [r for r in _rows() if r.n in ns])
    assert main(["bench", "scaling", "--ns", "2,4,8", "-o", str(tmp_path / "out")]) == 0
    lines = (tmp_path / "out" / "scaling.csv").read_text().splitlines()
    assert lines[0].split(",") == list(bench.CSV_FIELDS) and len(lines) == 4
    assert lines[3].split(",")[0] == "8" and lines[3].split(",")[8] == ""   # sympy skipped
    assert (tmp_path / "out" / "scaling.png").read_bytes()[:8] == PNG
    assert "scaling.csv" in capsys.readouterr().out


def test_stiff_scene_gets_an_implicit_reference_and_a_spent_budget_is_named():
    """No wall-clock budget: the reference runs without one (``math.inf``) and the spent
    budget is ``0`` s (every solve stops at its first call), on any machine."""
    from mbgen.studies.workprecision.reference import STIFF_STEPS, make_reference, stiffness_steps
    from mbgen.studies.workprecision.solve import Backends

    stiff = load_scene("stiff_chain", stiffness=1e6)
    b = Backends.build(stiff, ("c",), ("rosenbrock",))
    x0 = stiff.x0(b.compiled.layout)
    t = np.linspace(0.0, 0.2, 11)
    assert stiffness_steps(b, np.linspace(*stiff.t_span, 3), x0) > STIFF_STEPS
    said = []
    ref = make_reference(stiff, b, t, x0, 1e-2, said.append, stiff=True, budget_s=math.inf)
    assert ref.source.startswith("C rosenbrock") and ref.check.startswith("LSODA")
    assert ref.disagreement < 1e-6 and "implicit reference solves only" in ref.notes[0]
    assert not any("DOP853" in s for s in said)
    with pytest.raises(IntegrationError, match="raise --time-budget"):
        make_reference(stiff, b, np.linspace(*stiff.t_span, 11), x0, 1e-2, said.append,
                       stiff=True, budget_s=0)
    calm = load_scene("disc_pendulum")
    bc = Backends.build(calm, ("c",), ())
    assert stiffness_steps(bc, np.linspace(*calm.t_span, 3), calm.x0(bc.compiled.layout)) < 10


# ------------------------------------------------------------------ stress report
def _stress_report():
    from mbgen.verify.stress.report import Case, StressReport

    long_bound = "err <= C eps (cond(M)|f| + s) + 30 e_formula, and more words to wrap here"
    cases = (Case("fp", "nominal", "rel err 6.2e-17 <= 1e-12, cond(M) 1", long_bound, True,
                  "within bound", {"rel_err": 6.2e-17}),
             Case("extreme", "m x0 C dopri5",
                  "status 1 SPRING_PENDULUM_NOT_POSITIVE_DEFINITE at t=0",
                  "stops with status NOT_POSITIVE_DEFINITE", True, "C status"),
             Case("stiff", "k=1e6 Radau +jac", "2052 steps, 16962 RHS calls, 5.01 s",
                  "succeeds", False, "budget: 400000 evaluations reached at t=1.92", {},
                  stopped="Radau: 400000 evaluations", cause="budget"),
             Case("stiff", "k=1e6 RK45", "1987 steps", "succeeds", False,
                  "budget: no Radau reference (Radau stopped at its 400000 evaluations "
                  "budget)", stopped="Radau: 400000 evaluations", cause="budget"),
             Case("long_run", "energy", "drift 1.234567e-3", "<= 1e-6", False,
                  "1.234567e-3 exceeds 1e-06", {"drift": float("nan")}),
             Case("fp", "x", "crashed", "no exception", False, "ZeroDivisionError: boom",
                  cause="harness"))
    return StressReport("spring_pendulum", "ci", cases, ("a note",), 1.0)


def test_stress_report_fits_120_columns_and_keeps_every_number():
    report = _stress_report()
    text = report.format()
    assert max(len(line) for line in text.splitlines()) <= 120
    words = set(text.split())
    for c in report.cases:                        # every word of every cell is there, whole
        for cell in (c.figure, c.bound, c.reason):
            assert set(cell.split()) <= words, cell
    assert "~" not in text and "SPRING_PENDULUM_NOT_POSITIVE_DEFINITE" in words
    assert [c.failure for c in report.cases] == [None, None, "budget", "budget", "model",
                                                 "harness"]
    last = " ".join(text.split("FAILED:")[1].split())
    assert last.startswith("1 model failure(s): long_run: energy; 2 harness budget")
    assert "1 harness crash(es): fp: x" in last


def test_stress_report_files(tmp_path):
    report = _stress_report()
    doc = json.loads(report.write(tmp_path / "r.json").read_text())
    assert doc["scene"] == "spring_pendulum" and len(doc["cases"]) == 6 and not doc["ok"]
    assert doc["cases"][4]["data"]["drift"] == "nan" and doc["cases"][2]["failure"] == "budget"
    rows = (report.write(tmp_path / "r.csv").read_text()).splitlines()
    assert rows[0].startswith("kind,name,figure,bound,ok,failure,reason,seconds")
    assert len(rows) == 7 and "rel_err" in rows[0]
    with pytest.raises(mbgen.MbgenError, match=r"\.csv or \.json"):
        report.write(tmp_path / "r.txt")


def test_c_status_names_are_the_headers():
    from mbgen.verify.stress.runs import c_run, status_name

    scene = load_scene("spring_pendulum")
    model = mbgen.compile(scene, ("rhs", "dopri5"))
    assert status_name(model, 4) == "SPRING_PENDULUM_MAX_STEPS"
    assert "#define SPRING_PENDULUM_MAX_STEPS" in model.rendered.header
    p = scene.p(model.layout)
    p[list(model.parameter_names).index("m")] = -1.0            # not positive definite
    run = c_run(model, "dopri5", [0.0, 1.0], scene.x0(model.layout), p, rtol=1e-6, atol=1e-9,
                max_steps=100)
    assert run.status == "failed" and "SPRING_PENDULUM_NOT_POSITIVE_DEFINITE" in run.message
