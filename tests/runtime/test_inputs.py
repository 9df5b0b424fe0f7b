"""Inputs that vary in time: InputTable in C, functions of (t, x) for solve_ivp; B of linearize;
tables read from CSV files, on the command line (``-r F=table.csv``)."""

import re
from functools import cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbgen
from mbgen import InputTable, Output
from mbgen.cli import EXIT_OK, EXIT_USAGE, main
from mbgen.errors import UnknownNameError, UsageError
from mbgen.runtime.named import merge_inputs, read_input_csv
from mbgen.runtime.simulate import simulate
from mbgen.scenes import n_link_cart

OUTPUTS = (Output.RHS, Output.JACOBIAN, Output.INPUT_JACOBIAN, Output.DOPRI5, Output.RK4,
           Output.ROSENBROCK)


@cache
def cart():
    scene = n_link_cart.scene(n=2)
    return scene, mbgen.compile(scene, OUTPUTS)


def push(t_end=2.0, k=41):
    """A smooth push F(t) sampled finely, so that both sides integrate one function."""
    times = np.linspace(0.0, t_end, k)
    return InputTable(times, {"F": 2.0 * np.sin(3.0 * times)})


@pytest.mark.parametrize("method", ["dopri5", "rosenbrock", "rk4"])
def test_c_input_table_agrees_with_solve_ivp_on_the_same_function(method):
    scene, model = cart()
    x0, table = scene.x0(model.layout), push()
    t = np.linspace(0.0, 2.0, 21)
    got = model.integrate(method, t, x0, r=table, rtol=1e-10, atol=1e-12, h=2e-4)
    ref = solve_ivp(model.bind(None, table), (0.0, 2.0), x0, method="DOP853", t_eval=t,
                    rtol=1e-12, atol=1e-12, first_step=1e-4, max_step=0.05)
    assert got.success and got.y.shape == ref.y.shape
    np.testing.assert_allclose(got.y, ref.y, rtol=0, atol=2e-6)
    # the push matters: held at its first value the answer is far away
    held = model.integrate(method, t, x0, r={"F": 0.0}, rtol=1e-10, atol=1e-12, h=2e-4)
    assert np.max(np.abs(held.y - ref.y)) > 1e-2


@pytest.mark.parametrize("method", ["dopri5", "rosenbrock", "rk4"])
def test_a_constant_table_reproduces_constant_inputs_bit_for_bit(method):
    scene, model = cart()
    x0, t = scene.x0(model.layout), np.linspace(0.0, 1.0, 11)
    const = model.integrate(method, t, x0, r=np.array([0.8]), h=1e-3)
    table = model.integrate(method, t, x0, r=InputTable([0.0, 0.5, 3.0], [[0.8]] * 3), h=1e-3)
    assert np.array_equal(const.x, table.x)


def test_simulate_takes_a_function_of_time_and_state():
    scene, model = cart()
    x0 = scene.x0(model.layout)

    def feedback(t, x):  # a damping push on the cart: only Python can do this
        return np.array([-3.0 * x[model.state_names.index("u0")] + np.sin(t)])

    traj = simulate(model, x0, (0.0, 1.0), r=feedback, rtol=1e-10, atol=1e-12, progress=False)
    assert traj.method == "DOP853" and "Python function" in traj.message
    ref = solve_ivp(lambda t, x: model.rhs(t, x, None, feedback(t, x)), (0.0, 1.0), x0,
                    method="DOP853", rtol=1e-10, atol=1e-12, t_eval=traj.t)
    np.testing.assert_allclose(traj.x, ref.y.T, rtol=0, atol=1e-8)
    in_c = simulate(model, x0, (0.0, 2.0), r=push(), rtol=1e-10, atol=1e-12)
    assert in_c.method == "C dopri5"  # a table stays in C


def test_bad_tables_are_refused():
    scene, model = cart()
    with pytest.raises(ValueError, match="strictly increasing"):
        InputTable([0.0, 0.0, 1.0], [[1.0]] * 3)
    with pytest.raises(ValueError, match="one row per time"):
        InputTable([0.0, 1.0], [[1.0]] * 3)
    with pytest.raises(ValueError, match="finite"):
        InputTable([0.0, 1.0], [[1.0], [np.nan]])
    with pytest.raises(mbgen.UnknownNameError, match="did you mean 'F'"):
        model.integrate("dopri5", [0.0, 1.0], scene.x0(model.layout),
                        r=InputTable([0.0, 1.0], {"f": [0.0, 1.0]}))
    with pytest.raises(ValueError, match="one trajectory"):
        model.integrate("dopri5", [0.0, 1.0], np.zeros((2, model.n_x)), r=push())


def test_linearize_gives_b_for_an_unconstrained_scene_with_inputs():
    scene, model = cart()
    x = scene.x0(model.layout)
    lin = mbgen.linearize(model, x, r={"F": 0.3})
    assert lin.B.shape == (model.n_x, 1) and lin.inputs == ("F",)
    eps = 1e-6
    fd = (model.rhs(0.0, x, None, {"F": 0.3 + eps}) - model.rhs(0.0, x, None, {"F": 0.3 - eps}))
    np.testing.assert_allclose(lin.B[:, 0], fd / (2 * eps), rtol=1e-6, atol=1e-8)
    assert np.any(lin.B[model.n_x // 2:, 0] != 0)  # the push accelerates


# ------------------------------------------------------------------ tables from CSV files
def test_an_input_table_from_csv(tmp_path):
    """The format the command line reads (``-r F=table.csv``): header, time first."""
    path = tmp_path / "push.csv"
    path.write_text("\ufeff# a push, then a pull\nTime, F ,T\n0,0,1\n\n1,2.5,1\n3,-1,0\n",
                    encoding="utf-8")
    table = read_input_csv(path)
    np.testing.assert_array_equal(table.times, [0.0, 1.0, 3.0])
    assert list(table.values) == ["F", "T"]
    np.testing.assert_array_equal(table.values["F"], [0.0, 2.5, -1.0])
    scene, model = cart()
    with pytest.raises(UnknownNameError, match="'T' is not one of the inputs"):
        table.for_model(model)                                       # the cart has F only
    pushed = InputTable(table.times, {"F": table.values["F"]}).for_model(model)
    assert np.array_equal(pushed(2.0), [0.75])


@pytest.mark.parametrize("text, message", [
    ("", "is empty"),
    ("F,t\n0,1\n", "must name the time first"),
    ("t\n0\n", "must name the time first"),
    ("t,F,F\n0,1,2\n", "names ['F'] twice"),
    ("t,F\n", "has a header but no rows"),
    ("t,F\n0,1\n1\n", "push.csv:3: 1 values where the header names 2 columns"),
    ("t,F\n0,1\n1,heavy\n", "push.csv:3: 'heavy' is not a number"),
    ("t,F\n0,1\n1,inf\n", "push.csv:3: every value must be a finite number"),
    ("t,F\n0,1\n2,1\n1,1\n", "push.csv:4: the time 1.0 must be after the row before's 2.0"),
])
def test_a_bad_input_csv_names_the_line_and_the_fix(tmp_path, text, message):
    path = tmp_path / "push.csv"
    path.write_text(text)
    with pytest.raises(UsageError, match=re.escape(message)):
        read_input_csv(path)
    with pytest.raises(UsageError, match="cannot be read"):
        read_input_csv(tmp_path / "missing.csv")


def test_merged_inputs_keep_every_table_exactly():
    """Tables on different times and constants become one table on the union of the times,
    equal to each signal everywhere (piecewise linear sampled at all knots)."""
    a = (np.array([0.0, 1.0, 4.0]), np.array([0.0, 2.0, -2.0]))
    b = (np.array([0.5, 2.0]), np.array([1.0, 3.0]))
    merged = merge_inputs({"F": a, "G": b, "H": 0.25})
    np.testing.assert_array_equal(merged.times, [0.0, 0.5, 1.0, 2.0, 4.0])
    for t in np.linspace(-1.0, 5.0, 61):
        np.testing.assert_allclose([np.interp(t, merged.times, merged.values[n]) for n in "FGH"],
                                   [np.interp(t, *a), np.interp(t, *b), 0.25], rtol=0,
                                   atol=1e-15)
    assert merge_inputs({"F": 1.0}) == {"F": 1.0}


# ------------------------------------------------------------------ ... from the command line
def test_simulate_follows_an_input_table_in_c(tmp_path, capsys):
    """``-r F=table.csv``: the run is ``integrate`` with the table, bit for bit."""
    (tmp_path / "push.csv").write_text("t,F\n0,0\n0.5,3\n1.5,3\n2,-1\n")
    csv = tmp_path / "out.csv"
    assert main(["simulate", "n_link_cart", "-O", "n=2", "-r", f"F={tmp_path / 'push.csv'}",
                 "--integrator", "dopri5", "--t-end", "2", "--points", "5", "--csv",
                 str(csv)]) == EXIT_OK
    scene, model = cart()
    table = InputTable([0.0, 0.5, 1.5, 2.0], {"F": [0.0, 3.0, 3.0, -1.0]})
    ref = model.integrate("dopri5", np.linspace(0.0, 2.0, 5), scene.x0(model.layout), r=table)
    np.testing.assert_array_equal(np.loadtxt(csv, delimiter=",", skiprows=1)[:, 1:], ref.x)
    # solve_ivp calls the same table from Python
    assert main(["simulate", "n_link_cart", "-O", "n=2", "-r", f"F={tmp_path / 'push.csv'}",
                 "--integrator", "RK45", "--rtol", "1e-10", "--atol", "1e-12", "--t-end", "2",
                 "--points", "5", "--csv", str(csv)]) == EXIT_OK
    np.testing.assert_allclose(np.loadtxt(csv, delimiter=",", skiprows=1)[:, 1:], ref.x,
                               atol=1e-4)


@pytest.mark.parametrize("argv, message", [
    (["simulate", "n_link_cart", "-r", "F=missing.csv"], "'missing.csv' cannot be read"),
    (["simulate", "n_link_cart", "-r", "F=heavy"], "'heavy' is neither a number nor a CSV"),
    (["simulate", "n_link_cart", "-r", "F=two.csv"], "has the columns G, H, none named 'F'"),
    (["simulate", "n_link_cart", "-r", "F=bad.csv"], "bad.csv:3: 'x' is not a number"),
    (["linearize", "n_link_cart", "-r", "F=one.csv"], "-r takes a number here"),
    (["fmu", "n_link_cart", "-r", "F=one.csv"], "an FMU takes its inputs from the importer"),
])
def test_input_table_mistakes_on_the_command_line(argv, message, tmp_path, capsys,
                                                  monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "two.csv").write_text("t,G,H\n0,1,2\n")
    (tmp_path / "one.csv").write_text("t,Force\n0,1\n1,2\n")
    (tmp_path / "bad.csv").write_text("t,F\n0,1\n1,x\n")
    assert main(argv + ["-o" if argv[0] != "simulate" else "--csv", "out"]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert err.startswith("mbgen: error: ") and message in err, err
    assert not (tmp_path / "out").exists()


def test_a_table_with_one_input_column_drives_the_input_named(tmp_path, capsys):
    (tmp_path / "one.csv").write_text("t,Force\n0,1\n1,2\n")
    csv = tmp_path / "out.csv"
    args = ["simulate", "n_link_cart", "-O", "n=2", "--t-end", "1", "--points", "3", "--csv",
            str(csv)]
    assert main(args + ["-r", f"F={tmp_path / 'one.csv'}"]) == EXIT_OK
    by_table = csv.read_text()
    (tmp_path / "one.csv").write_text("t,F\n0,1\n1,2\n")
    assert main(args + ["-r", f"F={tmp_path / 'one.csv'}"]) == EXIT_OK
    assert csv.read_text() == by_table
