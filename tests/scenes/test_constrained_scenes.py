"""The constrained built-in scenes: every back end agrees, and each reproduces its physics.

* every constrained scene: compiled C, generated Python and lambdify of the unoptimised
  equations agree on every output (``mbgen.verify.check``), at consistent states too;
* four_bar: the closed-form position analysis is what ``consistent`` finds, the default
  run keeps the loop closed and conserves energy; the dead-point variant starts with a
  nearly singular constraint block and still integrates;
* slider_crank: the power balance d(T + V)/dt = T u1 - c u1^2 with the driving torque;
* rolling_disc: sympy's published equations;
* paraboloid_normal: the normal force from the notes' equation of motion, along a run;
* bead_wire_force: the wire's force 2 m omega rho' and the closed-form motion;
* whipple: the benchmark bicycle's published eigenvalues at 5 m/s and its weave and
  capsize speeds (Meijaard et al. 2007), energy over the default run, self-stability.
"""

from functools import cache

import numpy as np
import pytest

import mbgen
from mbgen.scenes import bead_wire_force, four_bar, paraboloid_normal, whipple
from mbgen.verify.check import check

CONSTRAINED = ("four_bar", "slider_crank", "rolling_disc", "paraboloid_normal",
               "bead_wire_force", "whipple")


@cache
def result(name, **options):
    return mbgen.run(mbgen.load_scene(name, **options))


def consistent_states(c, scene, k=4, seed=0, scale=0.2):
    """Seeded states near the scene's start, completed onto the configuration constraints."""
    rng = np.random.default_rng(seed)
    x0 = c.consistent(scene.x0(c.layout))
    return [c.consistent(x0 + rng.uniform(-scale, scale, c.n_x)) for _ in range(k)]


@pytest.mark.parametrize("name", CONSTRAINED)
def test_back_ends_agree_on_every_output(name):
    res = result(name)
    report = check(None, result=res, samples=5)
    assert report.ok, report.format()
    assert {"rhs", "constraint_forces"} <= {r.output for r in report.rows}
    c, py = res.compiled, mbgen.python_model(res.rendered)
    ref = mbgen.LambdifiedModel(res.baked, c.outputs, layout=c.layout)
    scn = mbgen.load_scene(name)
    r = np.full(c.n_r, 0.7)
    for x in consistent_states(c, scn):
        for out in ("rhs", "constraint_forces"):
            want = getattr(ref, out)(0.3, x, None, r)
            np.testing.assert_allclose(getattr(c, out)(0.3, x, None, r), want, rtol=1e-10,
                                       atol=1e-10)
            np.testing.assert_allclose(getattr(py, out)(0.3, x, None, r), want, rtol=1e-10,
                                       atol=1e-10)


@pytest.mark.parametrize("name", CONSTRAINED)
def test_default_run_stays_on_the_constraints(name):
    """The scene's start is consistent and the C integrator keeps the residual at round-off."""
    res = result(name)
    c, scn = res.compiled, mbgen.load_scene(name)
    x0 = scn.x0(c.layout)
    if c.dependent_coordinates:
        assert np.max(np.abs(c.holonomic(0, x0))) < 1e-12
    t = np.linspace(*scn.t_span, 11)
    run = c.integrate("dopri5", t, x0, rtol=1e-9, atol=1e-11)
    assert np.all(np.isfinite(run.x))
    if c.dependent_coordinates:    # output rows are interpolated between projected steps
        assert max(np.max(np.abs(c.holonomic(0, x))) for x in run.x) < 1e-8
        assert run.max_residual < 1e-8
    if scn.conserves_energy:
        energy = [sum(c.energy(ti, x)) for ti, x in zip(t, run.x)]
        assert max(energy) - min(energy) < 1e-6 * max(1.0, abs(energy[0]))


# ------------------------------------------------------------------ four-bar
def test_four_bar_position_analysis_is_what_consistent_finds():
    c = result("four_bar").compiled
    for q1 in (-2.0, 0.5, 2.5):
        q2, q3 = four_bar.closed_loop(q1, four_bar.LENGTHS)
        x = c.consistent([q1, q2 + 0.05, q3 - 0.05, 0.3])
        np.testing.assert_allclose(x[1:3], [q2, q3], atol=1e-12)
        assert np.max(np.abs(c.holonomic(0, [q1, q2, q3, 0.0]))) < 1e-14


def test_four_bar_dead_point_variant_is_nearly_singular_and_still_runs():
    res = result("four_bar", dead_point=True)
    c = res.compiled
    scn = mbgen.load_scene("four_bar", dead_point=True)
    x0 = scn.x0(c.layout)
    H = c.holonomic_jacobian(0, x0)[:, 1:3]
    assert np.linalg.cond(H) > 20           # ~1/sqrt(offset): coupler and rocker nearly in line
    lb, lc = four_bar.DEAD_POINT_LENGTHS["lb"], four_bar.DEAD_POINT_LENGTHS["lc"]
    assert abs(np.linalg.det(H)) == pytest.approx(lb * lc * abs(np.sin(x0[0] + x0[1] - x0[2])),
                                                  rel=1e-12)
    x_dead = np.array([four_bar.dead_angle(*four_bar.DEAD_POINT_LENGTHS.values()), 0, 0, 0.0])
    q2, q3 = four_bar.closed_loop(x_dead[0] - 1e-12, four_bar.DEAD_POINT_LENGTHS)
    x_dead[1:3] = q2, q3
    assert np.linalg.cond(c.holonomic_jacobian(0, x_dead)[:, 1:3]) > 1e5
    t = np.linspace(0, 1, 11)
    run = c.integrate("dopri5", t, x0, rtol=1e-9, atol=1e-11)
    assert run.max_residual < 1e-8 and run.x[-1, 0] < x0[0] - 1.0   # it swings away
    # q1 is a poor chart near the dead point (q2, q3 ~ sqrt(q1* - q1)): the energy error is
    # far larger than the regular linkage's at the same tolerance (2.5e-7 over 5 s; here 2.8e-4)
    energy = [sum(c.energy(0, x)) for x in run.x]
    assert 1e-6 < max(energy) - min(energy) < 1e-4 * energy[0]


# ------------------------------------------------------------------ slider-crank
def test_slider_crank_power_balance_with_the_driving_torque():
    c = result("slider_crank").compiled
    scn = mbgen.load_scene("slider_crank")
    p = dict(zip(c.parameter_names, scn.p(c.layout)))
    T = np.array([1.5])
    for x in consistent_states(c, scn, seed=2):
        f = c.rhs(0, x, None, T)
        h = 1e-6
        plus, minus = c.consistent(x + h * f), c.consistent(x - h * f)
        dE = (sum(c.energy(0, plus)) - sum(c.energy(0, minus))) / (2 * h)
        u1 = x[3]
        assert dE == pytest.approx(T[0] * u1 - p["c"] * u1**2, rel=1e-6, abs=1e-8)
    # the torque drives the crank round: from rest it turns the positive way
    run = c.integrate("dopri5", np.linspace(0, 0.5, 6), scn.x0(c.layout), None, T)
    assert run.x[-1, 0] > scn.initial_state["q1"] + 0.1


# ------------------------------------------------------------------ rolling disc
def test_rolling_disc_scene_reproduces_the_published_equations():
    c = result("rolling_disc").compiled
    rng = np.random.default_rng(5)
    for _ in range(5):
        x = rng.uniform(-1, 1, c.n_x)
        q1, q2, q3, q4, q5, u1, u2, u3 = x
        want = [(6 * u2 * u3 - u3**2 * np.tan(q2) + 4 * np.sin(q2)) / 5, -2 * u1 * u3 / 3,
                u1 * (-2 * u2 + u3 * np.tan(q2))]
        np.testing.assert_allclose(c.rhs(0, x)[5:], want, rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------ paraboloid
def test_paraboloid_normal_force_is_the_closed_form_along_a_run():
    c = result("paraboloid_normal").compiled
    scn = mbgen.load_scene("paraboloid_normal")
    vals = {**scn.parameters, **scn.fixed}
    run = c.integrate("dopri5", np.linspace(0, 5, 26), scn.x0(c.layout), rtol=1e-10,
                      atol=1e-12)
    lam = np.array([c.constraint_forces(0, x)[0] for x in run.x])
    want = np.array([paraboloid_normal.normal_force(x, vals["k"], vals["g"], vals["m"])
                     for x in run.x])
    np.testing.assert_allclose(lam, want, rtol=1e-10)
    assert np.ptp(lam) > 1.0                   # it varies along the orbit
    # on the circular orbit, q2'^2 = 2 g k, the surface carries the weight: lambda = m g
    x = np.array([0.8, 0.0, vals["k"] * 0.64, 0.0, np.sqrt(2 * vals["g"] * vals["k"])])
    assert c.constraint_forces(0, x)[0] == pytest.approx(vals["m"] * vals["g"], rel=1e-12)


# ------------------------------------------------------------------ bead on the wire
def test_bead_wire_force_is_two_m_omega_rho_dot():
    c = result("bead_wire_force").compiled
    scn = mbgen.load_scene("bead_wire_force")
    p = scn.p(c.layout)
    omega, m = p
    x0 = scn.x0(c.layout)
    t = np.linspace(*scn.t_span, 16)
    run = c.integrate("dopri5", t, x0, rtol=1e-11, atol=1e-12)
    exact = bead_wire_force.closed_form(t, x0, p)
    np.testing.assert_allclose(run.x, exact, rtol=1e-8, atol=1e-9)
    lam = np.array([c.constraint_forces(ti, x)[0] for ti, x in zip(t, run.x)])
    np.testing.assert_allclose(lam, [bead_wire_force.wire_force(x, omega, m) for x in exact],
                               rtol=1e-8, atol=1e-9)
    assert lam[0] < 0 < lam[-1]                # moving in, then flying out


# ------------------------------------------------------------------ Whipple bicycle
def upright(c, speed):
    x = np.zeros(c.n_x)
    for k, v in whipple.upright_state(speed).items():
        x[c.state_names.index(k)] = v
    return c.consistent(x)


def reduced_eigenvalues(c, x, h=1e-6):
    """Eigenvalues of the linearisation on the constraint manifold, by central differences
    (dependent coordinates re-solved), without the zero ones of the ignorable coordinates.

    A state whose column is zero (to rounding: a derivation may leave a wheel angle in the
    right-hand side that cancels only numerically) in the rows of the others is ignorable:
    removing its row and column removes exactly one zero eigenvalue.  Finite differences
    would turn such a zero block into a spurious pair of size sqrt(rounding)."""
    dep = [c.state_names.index(n) for n in c.dependent_coordinates]
    keep = [i for i in range(c.n_x) if i not in dep]
    cols = []
    for i in keep:
        e = np.zeros(c.n_x)
        e[i] = h
        cols.append((c.rhs(0, c.consistent(x + e)) - c.rhs(0, c.consistent(x - e)))[keep] / (2 * h))
    J = np.column_stack(cols)
    live = list(range(len(keep)))
    while (dead := [k for k in live if np.abs(J[live, k]).max() < 1e-7]):
        live = [k for k in live if k not in dead]
    ev = np.linalg.eigvals(J[np.ix_(live, live)])
    return np.sort_complex(ev[np.abs(ev) > 1e-4])


def test_whipple_reproduces_the_benchmark_eigenvalues():
    c = result("whipple").compiled
    x = upright(c, 5.0)
    assert x[c.state_names.index("pitch")] == pytest.approx(-np.pi / 10, abs=1e-12)
    ev = reduced_eigenvalues(c, x)
    # Meijaard et al. (2007), table 2, v = 5 m/s: castering, weave pair, capsize
    published = np.sort_complex(np.array([-14.07838969, -0.77534188 - 4.46486771j,
                                          -0.77534188 + 4.46486771j, -0.32286642]))
    np.testing.assert_allclose(ev, published, atol=2e-5)


@pytest.mark.parametrize("speed, stable", [(whipple.WEAVE_SPEED - 0.01, False),
                                           (whipple.WEAVE_SPEED + 0.01, True),
                                           (whipple.CAPSIZE_SPEED - 0.01, True),
                                           (whipple.CAPSIZE_SPEED + 0.01, False)])
def test_whipple_is_self_stable_between_weave_and_capsize_speed(speed, stable):
    c = result("whipple").compiled
    ev = reduced_eigenvalues(c, upright(c, speed))
    assert (np.max(ev.real) < 0) == stable


def test_whipple_rights_itself_and_its_contact_forces_carry_it():
    c = result("whipple").compiled
    scn = mbgen.load_scene("whipple")
    t = np.linspace(0, 5, 51)
    run = c.integrate("dopri5", t, scn.x0(c.layout), rtol=1e-9, atol=1e-11)
    roll = run.x[:, c.state_names.index("roll")]
    assert np.max(np.abs(roll[:10])) > 0.02 and np.max(np.abs(roll[-10:])) < 0.2 * np.max(
        np.abs(roll[:10]))
    # rows: front height, rear x, rear y, front x, front y; upright and steady the ground
    # pushes neither wheel sideways nor along
    x = upright(c, 5.0)
    lam = c.constraint_forces(0, x)
    assert c.constraint_names == ("front_height", "rear_x", "rear_y", "front_x", "front_y")
    np.testing.assert_allclose(lam[1:], 0.0, atol=1e-9)


@pytest.mark.slow
def test_whipple_exact_linearisation_equals_the_benchmark():
    """``mbgen.linearize`` (compiled symbolic Jacobians; about a minute and a half to compile)."""
    res = mbgen.run(mbgen.load_scene("whipple"), ("rhs", "jacobian", "holonomic",
                                                   "holonomic_jacobian"), name="whipple_lin")
    c = res.compiled
    lin = mbgen.linearize(c, upright(c, 5.0))
    ev = lin.eigenvalues[np.abs(lin.eigenvalues) > 1e-6]
    np.testing.assert_allclose(np.sort_complex(ev), np.sort_complex(np.array(
        [-14.07838969, -0.77534188 - 4.46486771j, -0.77534188 + 4.46486771j, -0.32286642])),
        atol=1e-7)


# ------------------------------------------------------------------ diagnostics
def test_stress_four_bar_near_its_dead_point():
    """The 50-digit reference reduces by the constraints as the generated code does; the dead
    point is approached (cond grows like 1/delta) and hit (a named SingularConstraintError)."""
    from mbgen.verify.stress import stress

    report = stress(mbgen.load_scene("four_bar", dead_point=True), size="ci")
    assert report.ok, report.format()
    dead = [c for c in report.cases if c.name.startswith("dead point")]
    assert len(dead) == 4
    conds = [c.data["cond"] for c in dead[:3]]
    assert conds[0] < conds[1] < conds[2] and conds[2] > 1e5
    assert dead[3].reason == "numerically singular: SingularConstraintError"
    assert all(c.reason == "within bound" for c in report.cases if c.kind == "fp")


def test_stress_reference_reduces_like_the_generated_code():
    """Off the 50-digit reduction's result by a dropped acceleration bias, the fp cases fail."""
    from mbgen.verify.stress.context import make_context
    from mbgen.verify.stress.precision import evaluate_point

    ctx = make_context("rolling_disc")
    x = ctx.x0 + np.linspace(0.1, 0.5, ctx.x0.size)
    pr = evaluate_point(ctx.model, ctx.hp, 0.0, x, ctx.p0, ctx.values)
    assert pr.abs_err <= pr.allowed and pr.reference.positive_definite
    published = np.array(pr.reference.f[5:], dtype=float)
    q2, u1, u2, u3 = x[1], x[5], x[6], x[7]
    np.testing.assert_allclose(published, [(6 * u2 * u3 - u3**2 * np.tan(q2) + 4 * np.sin(q2)) / 5,
                                           -2 * u1 * u3 / 3, u1 * (-2 * u2 + u3 * np.tan(q2))],
                               rtol=1e-14)


def test_work_precision_error_includes_the_constraint_residual():
    from mbgen.studies.workprecision import work_precision

    report = work_precision("four_bar", rtols=(1e-4, 1e-7), methods=("RK45", "dopri5"),
                            backends=("c",), repeats=1, t_eval_points=11,
                            time_budget=float("inf"))     # every point must run: no clock
    assert all(p.ok for p in report.points)
    for p in report.points:
        assert np.isfinite(p.err_residual) and p.err_residual > 0
        assert p.err_max >= p.err_residual
    loose = [p for p in report.points if p.rtol == 1e-4]
    tight = [p for p in report.points if p.rtol == 1e-7]
    assert max(p.err_residual for p in tight) < min(p.err_residual for p in loose)
    assert "err_residual" in report.to_csv().splitlines()[0]
    # a solution off the constraints is wrong by its residual whatever the reference says
    from mbgen.studies.workprecision.runs import _errors

    x = np.zeros((3, 4))
    errors = _errors(x, x + 1e-9, residual=lambda rows: 1e-3)
    assert errors["err_residual"] == errors["err_max"] == 1e-3
    assert _errors(x, x + 1e-9)["err_max"] == pytest.approx(1e-9)


def test_cli_simulate_starts_consistent_and_reports_the_residual(tmp_path, capsys):
    from mbgen.cli import main

    csv = tmp_path / "fb.csv"
    assert main(["simulate", "four_bar", "--method", "dopri5", "--csv", str(csv),
                 "-O", "dead_point=true"]) == 0
    out = capsys.readouterr().out
    assert "consistent start" in out and "largest constraint residual" in out
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    c = result("four_bar", dead_point=True).compiled
    assert np.max(np.abs(c.holonomic(0, rows[0, 1:]))) < 1e-12


# ------------------------------------------------------------------ targets
def test_step_api_projects_after_every_step():
    from mbgen.codegen.targets import Targets
    from mbgen.runtime.stepper import Stepper

    scn = mbgen.load_scene("four_bar")
    c = mbgen.run(scn, None, targets=Targets(step=True), name="four_bar_step").compiled
    x0 = scn.x0(c.layout)
    one = c.integrate("dopri5", [0.0, 5.0], x0, rtol=1e-8, atol=1e-10)
    st = Stepper(c, "dopri5", 0.0, x0, rtol=1e-8, atol=1e-10)
    assert np.array_equal(st.step(5.0), one.x[-1])          # the same steps, the same bits
    assert st.max_residual == one.max_residual > 0
    rk = Stepper(c, "rk4", 0.0, x0)
    for _ in range(100):
        x = rk.step(0.01)
        assert np.max(np.abs(c.holonomic(rk.t, x))) < 1e-12
    assert 0 < rk.max_residual < 1e-6


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_fmu_of_a_constrained_scene_stays_on_the_constraints(tmp_path, kind):
    fmpy = pytest.importorskip("fmpy", reason="FMPy is in the test extra")
    from fmpy.validation import validate_fmu

    from mbgen.codegen.targets.fmu import PROJECT_TOL
    from mbgen.export import export_fmu

    scn = mbgen.load_scene("slider_crank")
    path = export_fmu(scn, tmp_path)
    assert validate_fmu(str(path)) == []
    c = result("slider_crank").compiled
    signal = np.array([(0.0, 1.5), (2.0, 1.5)], dtype=[("time", "f8"), ("T", "f8")])
    res = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=2.0, output_interval=0.02,
                            relative_tolerance=1e-9, input=signal, output=list(c.state_names))
    t = res["time"]
    after = np.append(np.diff(t) > 0, True)           # an event repeats its time: keep the last
    X = np.stack([res[n] for n in c.state_names], axis=1)[after]
    ref = c.integrate("dopri5", t[after], scn.x0(c.layout), None, [1.5], rtol=1e-11,
                      atol=1e-13)
    scale = np.abs(ref.x).max()
    assert np.abs(X - ref.x).max() < (1e-8 if kind == "CoSimulation" else 1e-6) * scale
    residual = max(np.max(np.abs(c.holonomic(0, x, None, [1.5]))) for x in X)
    if kind == "ModelExchange":     # the importer's CVode drifts; step events project back
        assert (~after).sum() > 0 and residual < 10 * PROJECT_TOL
    else:
        assert residual < 1e-10


# ------------------------------------------------------------------ constraint benchmark
def test_four_bar_residual_table_shows_what_projection_buys():
    from mbgen.bench.constraints import four_bar_residuals

    rows = four_bar_residuals((1e-5,), repeats=1)
    on, off = rows
    assert on.project and not off.project
    assert on.final_residual < 1e-11 < 1e-4 * off.final_residual    # drift grows without it
    assert on.time_s > 0 and on.n_rhs > 0


@pytest.mark.slow
def test_sympy_kanes_method_states_the_same_bicycle():
    """The benchmark's sympy model (KanesMethod with the same constraints) and mbgen agree on
    u_s' at a state with roll, steer and their rates (about 15 s of sympy)."""
    import sympy as sm

    from mbgen.bench.constraints import operating_point, sympy_whipple

    point = operating_point()
    kane, q, u, values = sympy_whipple()
    args = [q + u, list(values)]
    M = sm.lambdify(args, kane.mass_matrix, modules="numpy", cse=True)
    F = sm.lambdify(args, kane.forcing, modules="numpy", cse=True)
    state = np.array(point["x"][:8] + point["speeds"])
    p = np.array(list(values.values()))
    acc = np.linalg.solve(M(state, p), F(state, p)).ravel()[:3]
    np.testing.assert_allclose(acc, point["accelerations"], rtol=1e-10, atol=1e-12)
