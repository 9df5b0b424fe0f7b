"""Work-precision benchmark: errors fall with the tolerance, outputs complete, failures recorded.

No timing assertions: the machine is small and shared.  A run whose points must all
succeed has no time budget (``time_budget=math.inf``), so a loaded machine cannot stop one.
"""

import csv
import io
import math
import sys

import numpy as np
import pytest

from mbgen import IntegrationError, load_scene
from mbgen.errors import MissingExtraError
from mbgen.runtime.compiled import CompiledModel
from mbgen.studies.workprecision import (
    CSV_COLUMNS,
    DEFAULT_RTOLS,
    Config,
    configurations,
    rk4_steps,
    typical_magnitude,
    work_precision,
)

RTOLS = (1e-3, 1e-6)
METHODS = ("RK45", "DOP853", "Radau", "dopri5", "rosenbrock", "rk4")
STATED_COLUMNS = ("method", "backend", "jac", "rtol", "atol", "h", "err_final", "err_max",
                  "time_s", "nfev", "njev", "nlu", "status", "message")


@pytest.fixture(scope="module")
def messages():
    return []


@pytest.fixture(scope="module")
def report(messages):
    return work_precision("disc_pendulum", rtols=RTOLS, methods=METHODS,
                          backends=("python", "c"), repeats=1, time_budget=math.inf,
                          progress=messages.append)


def test_configurations():
    configs = configurations(("RK45", "Radau", "dopri5", "rosenbrock"), ("python", "c"))
    assert configs == [Config("RK45", "python"), Config("RK45", "c"),
                       Config("Radau", "python"), Config("Radau", "python", True),
                       Config("Radau", "c"), Config("Radau", "c", True),
                       Config("dopri5", "c"), Config("rosenbrock", "c", True)]
    assert configurations(("dopri5",), ("python",)) == []  # C integrators need the C back end
    assert Config("Radau", "c", True).label == "Radau [c, jac]"


def test_rk4_steps_divide_the_output_intervals():
    t_eval = np.linspace(0.0, 20.0, 101)
    hs = rk4_steps(DEFAULT_RTOLS, 92, t_eval)
    assert len(hs) == len(DEFAULT_RTOLS) and list(hs) == sorted(hs, reverse=True)
    steps = 0.2 / np.array(hs)
    assert np.allclose(steps, np.round(steps))  # whole steps per output interval
    assert 92 <= 100 * steps[0] < 200 and steps[-1] / steps[0] > 10 ** (7 / 4) * 0.8


def test_typical_magnitude():
    x = np.array([[0.0, 1.0, -30.0], [2.0, -0.5, 0.0]])
    assert typical_magnitude(x) == 2.0  # median of (2, 1, 30)
    assert typical_magnitude(np.zeros((3, 2))) == 1.0


def test_every_point_ran(report, messages):
    configs = report.configurations()
    assert len(configs) == 2 * 4 + 3  # RK45, DOP853, Radau +-jac per back end; 3 C integrators
    assert len(report.points) == len(configs) * len(RTOLS)
    assert all(p.ok for p in report.points), [p for p in report.points if not p.ok]
    assert messages[0] == "disc_pendulum: generate and compile"
    assert "RK45 [python] rtol=1e-03" in messages and "rk4 [c] h=0.2" in messages
    for p in report.points:
        assert p.time_s > 0 and p.nfev > 0 and p.err_max >= p.err_final >= 0
        if p.config.is_c_integrator:
            assert p.overhead is None
        else:
            assert 0 < p.overhead < 1 and p.callback_s > 0
        if p.jac:
            assert p.njev > 0 and p.nlu > 0
        elif p.method == "Radau":
            assert p.njev == 0 and p.nlu > 0  # solve_ivp's finite differences
        if p.method == "rk4":
            assert p.atol is None and p.h > 0
        else:
            assert p.h is None and p.atol == pytest.approx(p.rtol * report.atol_scale)


def test_error_falls_with_tolerance(report):
    assert report.reference.source.startswith("DOP853")
    assert report.reference.check.startswith("C rosenbrock")   # the C Rodas4, not solve_ivp
    assert report.reference.disagreement < 1e-9
    for config in report.configurations():
        curve = report.curve(config)
        errors = [p.err_max for p in curve]
        assert errors[-1] < errors[0], config
        if config.method != "rk4":
            assert 100 * errors[-1] <= errors[0], (config, errors)
            assert 100 * curve[-1].err_final <= curve[0].err_final, config


def test_same_back_end_same_answer(report):
    """The generated Python and the C take the same steps; dopri5 follows RK45's step control."""
    for method, jac in (("RK45", False), ("Radau", True)):
        py, c = report.curve(Config(method, "python", jac)), report.curve(Config(method, "c", jac))
        assert [p.nfev for p in py] == [p.nfev for p in c]
        assert np.allclose([p.err_max for p in py], [p.err_max for p in c], rtol=1e-6)
    for rk45, dopri5 in zip(report.curve(Config("RK45", "c")), report.curve(Config("dopri5", "c"))):
        assert dopri5.nfev == pytest.approx(rk45.nfev, rel=0.05)
        assert dopri5.err_max == pytest.approx(rk45.err_max, rel=0.5)


def test_csv(report, tmp_path):
    path = report.write_csv(tmp_path / "wp.csv")
    rows = list(csv.reader(io.StringIO(path.read_text())))
    assert tuple(rows[0]) == CSV_COLUMNS and CSV_COLUMNS[:len(STATED_COLUMNS)] == STATED_COLUMNS
    assert len(rows) == 1 + len(report.points)
    first = dict(zip(rows[0], rows[1]))
    assert (first["method"], first["backend"], first["jac"], first["status"]) == \
        ("RK45", "python", "False", "ok")
    assert float(first["rtol"]) == 1e-3 and first["h"] == "" and first["message"] == ""
    assert float(first["err_max"]) == report.points[0].err_max
    assert 0 < float(first["overhead"]) < 1
    rk4 = [dict(zip(rows[0], r)) for r in rows[1:] if r[0] == "rk4"]
    assert len(rk4) == len(RTOLS) and all(r["atol"] == "" and float(r["h"]) > 0 for r in rk4)


def test_plot_is_a_png(report, tmp_path):
    path = report.plot(tmp_path / "plots" / "wp.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in path.parent.iterdir()] == ["wp.png"]  # no temporary left


def test_table_and_summary(report):
    table = report.table()
    for config in report.configurations():
        assert config.label in table
    assert "max abs error over the output times" in table and "RHS calls" in table
    summary = report.summary()
    line = next(s for s in summary.splitlines() if s.startswith("  error <= 1e-02: "))
    labels = [c.label for c in report.configurations()]
    assert any(line.startswith(f"  error <= 1e-02: {label} ") for label in labels), line
    assert report.fastest(1e-2) is not None
    assert "faster than solve_ivp at this error" in summary
    assert "dopri5 [c] vs RK45 [c]" in summary
    assert "solve_ivp's own overhead" in summary and "Radau +jac" in summary


def test_closed_form_reference_for_bead_wire():
    report = work_precision("bead_wire", rtols=(1e-4, 1e-7), methods=("RK45", "dopri5"),
                            backends=("c",), repeats=1, time_budget=math.inf)
    scene = load_scene("bead_wire")
    ref = report.reference
    assert ref.source == "closed form" and ref.check == "" and ref.disagreement == 0
    assert np.array_equal(ref.x, scene.closed_form(report.t_eval, [0.5, -0.8], [2.0, 0.1]))
    assert all(p.ok for p in report.points)
    assert "reference: closed form" in report.summary()
    assert report.curve(Config("dopri5", "c"))[-1].err_final_rel < 1e-6


def test_failures_are_recorded_not_raised(tmp_path):
    report = work_precision("bead_wire", rtols=(1e-3, 1e-4, 1e-5), methods=("RK45", "dopri5"),
                            backends=("c",), repeats=1, time_budget=1e-9)
    statuses = [[p.status for p in report.curve(c)] for c in report.configurations()]
    assert statuses == [["over budget", "skipped", "skipped"]] * 2
    assert all(np.isnan(p.err_max) and np.isnan(p.time_s) for p in report.points)
    assert "rtol=1e-03 went over the 1e-09 s budget" in report.points[1].message
    assert "No point succeeded." in report.summary()
    assert "budget" in report.table() and "skip" in report.table()
    rows = list(csv.DictReader(io.StringIO(report.to_csv())))
    assert rows[0]["status"] == "over budget" and rows[0]["err_max"] == ""
    assert report.plot(tmp_path / "empty.png").read_bytes()[:4] == b"\x89PNG"


def test_integrator_errors_are_recorded(monkeypatch):
    def failing(self, method, *args, **kwargs):
        raise IntegrationError("step size too small", status=3, t=1.5)

    monkeypatch.setattr(CompiledModel, "integrate", failing)
    report = work_precision("bead_wire", rtols=(1e-4, 1e-7), methods=("RK45", "dopri5"),
                            backends=("c",), repeats=1, time_budget=math.inf)
    dopri5 = report.curve(Config("dopri5", "c"))
    assert [p.status for p in dopri5] == ["failed", "failed"]  # a failure skips nothing
    assert dopri5[0].message == "IntegrationError: step size too small"
    assert all(p.ok for p in report.curve(Config("RK45", "c")))
    assert "dopri5 [c] rtol=1e-04: failed: IntegrationError: step size too small" in \
        report.summary()


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown integrator"):
        work_precision("bead_wire", methods=("RK23",))
    with pytest.raises(ValueError, match="backends"):
        work_precision("bead_wire", backends=("fortran",))
    with pytest.raises(ValueError, match="rtols"):
        work_precision("bead_wire", rtols=(1e-3, 2.0))
    with pytest.raises(ValueError, match="t_eval_points=1,000,000,000,000 is more than"):
        work_precision("bead_wire", t_eval_points=10**12)  # was a 7 TiB allocation


@pytest.mark.slow
def test_full_default_run_on_disc_pendulum(tmp_path):
    report = work_precision("disc_pendulum")
    assert len(report.points) == len(DEFAULT_RTOLS) * (3 * 8 + 3)
    assert sum(p.ok for p in report.points) >= 0.9 * len(report.points)
    assert report.fastest(1e-8) is not None
    report.write_csv(tmp_path / "wp.csv")
    report.plot(tmp_path / "wp.png")


def test_plot_without_matplotlib_names_the_extra(report, tmp_path, monkeypatch):
    """Was ``ModuleNotFoundError: matplotlib.transforms`` (a traceback in ``mbgen bench``)."""
    for name in [m for m in sys.modules if m.split(".")[0] == "matplotlib"] + ["matplotlib"]:
        monkeypatch.setitem(sys.modules, name, None)       # as on a core install
    with pytest.raises(MissingExtraError, match=r"pip install 'mbgen\[plot\]'"):
        report.plot(tmp_path / "wp.png")
    assert not (tmp_path / "wp.png").exists()
