"""The back ends of mbgen.runtime: one interface, one accessor per output, one result type,
one "did you mean"."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from pathlib import Path

import numpy as np
import pytest

import mbgen
from mbgen import names
from mbgen.abi import EXPRESSION_OUTPUTS, OUTPUT_INFO, Output
from mbgen.runtime import named
from mbgen.runtime.base import ACCESSORS, ModelBase, accessor_doc
from mbgen.runtime.integration import Integration, Trajectory

#: the package of the back ends
RUN = importlib.import_module("mbgen.runtime")


def _back_ends() -> list[type]:
    """Every concrete back end: a subclass of ModelBase that names its ``backend``."""
    found, todo = [], list(ModelBase.__subclasses__())
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        if cls.__module__.startswith("mbgen.runtime.") and "backend" in vars(cls):
            found.append(cls)
    return found


def test_every_back_end_is_public_and_evaluates():
    back_ends = _back_ends()
    assert {c.__name__ for c in back_ends} >= {"CompiledModel", "PythonModel", "LambdifiedModel"}
    for cls in back_ends:
        assert getattr(mbgen, cls.__name__) is cls, cls
        assert getattr(RUN, cls.__name__) is cls, cls
        assert cls._evaluate is not ModelBase._evaluate, cls
    labels = [c.backend for c in back_ends]
    assert len(set(labels)) == len(labels) and "base" not in labels, labels


def test_every_output_has_one_accessor():
    """Named in the class body (IDEs and type checkers see them), documented by the rows."""
    assert set(ACCESSORS) == set(EXPRESSION_OUTPUTS)
    for output, doc in ACCESSORS.items():
        method = vars(ModelBase)[output.value]
        assert method.__name__ == output.value and method.__doc__ == doc
        assert doc == accessor_doc(OUTPUT_INFO[output])
        assert str(inspect.signature(method)) == "(self, t, x, p=None, r=None) -> 'np.ndarray'"
    doc = inspect.getdoc(mbgen.CompiledModel.jacobian)
    assert doc.startswith("Jacobian df/dx") and doc.endswith("ndarray, shape (n_x, n_x)")


def test_one_result_type_for_integrate_and_simulate():
    assert Integration is Trajectory is mbgen.Trajectory is RUN.Trajectory
    fields = [f.name for f in dataclasses.fields(Trajectory)]
    # simulate's positional order first (mbgen.Trajectory is public), then integrate's extras
    assert fields == ["t", "x", "names", "nfev", "wall_time", "method", "njev", "nlu",
                      "n_steps", "message", "max_residual", "status", "n_rejected"]
    model = mbgen.compile(mbgen.load_scene("disc_pendulum"), outputs={"rhs", "dopri5"})
    t = np.linspace(0.0, 1.0, 5)
    out = model.integrate("dopri5", t, np.array([0.3, 0.0, 0.0, 0.0]))
    sim = mbgen.simulate(model, [0.3, 0.0, 0.0, 0.0], (0.0, 1.0), method="dopri5", t_eval=t,
                         rtol=1e-6, atol=1e-9)
    for res in (out, sim):
        assert isinstance(res, Trajectory) and res.success and res.status == 0
        assert (res.nfev, res.njev, res.nlu) == (res.n_rhs, res.n_jac, res.n_lu)
        assert res["y"] is not None and res.y.shape == (model.n_x, t.size)
        assert res.final == dict(zip(model.state_names, res.x[-1].tolist()))
        assert res.to_csv().splitlines()[0] == ",".join(("t",) + model.state_names)
        with pytest.raises(KeyError):
            res["nothing"]
    assert out.method == "dopri5" and sim.method == "C dopri5"
    assert out.message.startswith("The solver successfully") and sim.message == "as asked"
    assert np.array_equal(out.x, sim.x) and out.n_rejected == sim.n_rejected


def test_fixed_step_and_implicit_read_from_the_method_table():
    model = mbgen.compile(mbgen.load_scene("disc_pendulum"), outputs={"rhs", "jacobian", "rk4",
                                                                 "rosenbrock"})
    with pytest.raises(mbgen.MbgenError, match="the rk4 integrator takes a fixed step"):
        model.integrate("rk4", [0.0, 1.0], [0.3, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="'euler' is not an integrator; choose from 'dopri5', "
                                         "'rk4', 'rosenbrock'"):
        model.integrate("euler", [0.0, 1.0], [0.3, 0.0, 0.0, 0.0])
    assert model.c_integrators == (Output.RK4, Output.ROSENBROCK)
    assert model.integrate("rosenbrock", [0.0, 1.0], [0.3, 0.0, 0.0, 0.0]).n_lu > 0
    assert mbgen.python_model(mbgen.run(mbgen.load_scene("disc_pendulum"), build=False)
                              .rendered).c_integrators == ()


def test_integrate_result_reads_like_scipy():
    scene = mbgen.load_scene("disc_pendulum")
    model = mbgen.compile(scene)
    res = model.integrate("dopri5", np.linspace(0, 1, 6), scene.x0(model.layout))
    assert res.y.shape == (model.n_x, 6) and np.array_equal(res.y.T, res.x)
    assert res.success and res.status == 0 and "successfully" in res.message
    assert (res.nfev, res.njev, res.nlu) == (res.n_rhs, res.n_jac, res.n_lu) and res.nfev > 0
    assert res["y"] is not None and np.array_equal(res["t"], res.t)
    with pytest.raises(KeyError):
        res["nope"]


def test_c_and_python_agree_bit_for_bit_on_an_ill_conditioned_saddle_point():
    """A four-bar with a rocker of 1e-8 and a ground link of 1e-38: the constraint forces are
    ~2e8 and the saddle point is ill-conditioned, so the generated Python must do the C's sums
    in the C's order (``r2 - sum(...)`` once differed from it by 6%)."""
    scene = mbgen.load_scene("four_bar")
    model = mbgen.compile(scene, ("rhs", "jacobian", "constraint_forces", "holonomic"),
                          name="four_bar_tiny")
    py = mbgen.python_model(model.rendered)
    p = {**scene.parameters, "la": 2.0, "lb": 0.25, "lc": 1e-8, "ld": 1.17549435e-38}
    x = np.array([-1.78951665, 2.84266863, 0.5, 0.17570418])
    for output in ("rhs", "jacobian", "constraint_forces"):
        want = getattr(model, output)(0.0, x, p)
        assert np.array_equal(getattr(py, output)(0.0, x, p), want), output
    assert np.max(np.abs(model.constraint_forces(0.0, x, p))) > 1e6


def test_one_did_you_mean_for_every_unknown_name():
    """Names given by name (here), scene fields, expressions and the CLI's input tables all
    answer an unknown name by mbgen.names.did_you_mean: one rule, case-blind, up to three."""
    assert named.did_you_mean is names.did_you_mean
    assert names.did_you_mean("f", ["F", "g"]) == "; did you mean 'F'?"
    assert names.did_you_mean("q", ["q1", "q2", "q3", "q4"]).count(" or ") == 2  # three
    assert names.did_you_mean("zzz", ["g", "l0"]) == ""
    package = Path(mbgen.__file__).parent
    users = sorted(p.relative_to(package).as_posix() for p in package.rglob("*.py")
                   if "get_close_matches" in p.read_text(encoding="utf-8"))
    assert users == ["names.py"], users
