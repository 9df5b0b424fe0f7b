"""`mbgen check` must not pass on nothing, and its reference is the unsliced equations
(a slicing fault must not agree with itself)."""

from __future__ import annotations

import numpy as np
import pytest

import mbgen
from mbgen.verify.check import check
from mbgen.cli import EXIT_CHECK, EXIT_INCONCLUSIVE, EXIT_OK, EXIT_USAGE, main
from mbgen.errors import ArgumentError, CheckFailed, CheckInconclusive, MbgenError
from mbgen.model.scene import load_scene


def pendulum(mass=1.0, inertia=0.1, g=9.81, fixed_g=None, idle=False) -> mbgen.Scene:
    """A rigid pendulum (optionally a second coordinate that moves nothing)."""
    m = mbgen.Model("pend")
    names = "q z" if idle else "q"
    q, *rest = m.coordinates(names)
    m.speeds("u w" if idle else "u")
    mass_, izz, g_ = m.constants("mass izz g")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q)
    C = m.point("C", m.origin, -A.y)
    m.body("rod", A, mass_, (0, 0, izz), C)
    m.gravity(-g_ * N.y)
    params = {"mass": mass, "izz": inertia}
    fixed = {}
    if fixed_g is None:
        params["g"] = g
    else:
        fixed["g"] = fixed_g
    return mbgen.Scene("pend", m, parameters=params, fixed=fixed,
                       outputs=("rhs", "mass_matrix", "energy"))


def test_a_good_model_passes_and_counts_its_samples():
    report = check(pendulum(), samples=6)
    assert report.ok and report.verdict == "PASSED", report.format()
    assert all(r.compared == r.evaluated == 6 and r.both_failed == 0 for r in report.rows)
    assert report.evaluated() == {"c": 6, "python": 6}
    assert "compared" in report.format()


@pytest.mark.parametrize("scene", [
    pytest.param(lambda: pendulum(mass=0.0, inertia=0.0), id="zero-mass"),
    pytest.param(lambda: pendulum(inertia=-5.0), id="negative-inertia"),
    pytest.param(lambda: pendulum(idle=True), id="coordinate-appearing-nowhere"),
])
def test_every_sample_failing_everywhere_is_not_a_pass(scene):
    report = check(scene(), samples=5)
    assert not report.ok
    assert report.inconclusive and report.verdict == "INCONCLUSIVE", report.format()
    rhs = [r for r in report.rows if r.output == "rhs"]
    assert rhs and all(r.compared == r.evaluated == 0 and r.both_failed == 5 for r in rhs)
    with pytest.raises(CheckInconclusive):
        report.raise_if_failed()


def test_a_nan_parameter_is_not_a_pass():
    """g = NaN fixed: refused where it enters, or a check that compares nothing -- never PASSED."""
    try:
        report = check(pendulum(fixed_g=float("nan")), samples=4)
    except MbgenError:
        return  # refused at entry (a named error): not a pass either
    assert not report.ok and report.verdict != "PASSED", report.format()


def test_disagreeing_on_failure_fails():
    """A back end that raises where the reference returns is a FAIL, not a skip."""
    from mbgen.verify.check import compare
    from mbgen.abi import Output
    from mbgen.pipeline import run

    result = run(pendulum(), ("rhs",))

    class Broken:
        def rhs(self, t, x, p=None, r=None):
            from mbgen.errors import NonFiniteResultError
            raise NonFiniteResultError("broken")

    from mbgen.verify.check import reference_model
    rows = compare({"broken": Broken()}, reference_model(result, (Output.RHS,)), (Output.RHS,),
                   p=result.compiled.default_parameters, samples=3)
    assert rows[0].mismatched_failures == 3 and not rows[0].ok


@pytest.mark.parametrize("samples", [0, -5])
def test_no_samples_is_refused(samples):
    with pytest.raises(ArgumentError):
        check(pendulum(), samples=samples)


def test_cli_exit_codes(tmp_path, capsys):
    assert main(["check", "n_link_cart", "-O", "n=1", "--samples", "3"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "3/3" in out and "PASSED" in out
    for samples in ("0", "-5"):
        assert main(["check", "n_link_cart", "-O", "n=1", "--samples", samples]) == EXIT_USAGE
        assert "--samples must be at least 1" in capsys.readouterr().err


def test_cli_inconclusive_exit_code(tmp_path, capsys):
    scene = tmp_path / "massless.py"
    scene.write_text(
        "import mbgen\n"
        "def scene():\n"
        "    m = mbgen.Model('massless')\n"
        "    q, = m.coordinates('q')\n"
        "    m.speeds('u')\n"
        "    mass, = m.constants('mass')\n"
        "    N = m.newtonian()\n"
        "    P = m.point('P', m.origin, q * N.x)\n"
        "    m.particle('b', P, mass)\n"
        "    return mbgen.Scene('massless', m, parameters={'mass': 0.0})\n")
    assert main(["check", str(scene), "--samples", "3"]) == EXIT_INCONCLUSIVE
    captured = capsys.readouterr()
    assert "INCONCLUSIVE" in captured.out and "0/3" in captured.out
    assert "mbgen: check inconclusive" in captured.err


def test_cli_failed_exit_code_unchanged(capsys):
    assert main(["check", "n_link_cart", "-O", "n=2", "--rtol", "0", "--atol", "0",
                 "--samples", "3"]) in (EXIT_CHECK, EXIT_OK)


def test_nan_parameter_values_compare_nothing():
    """g = NaN at run time: every back end raises NonFiniteResultError at every sample."""
    from mbgen.verify.check import CheckReport, compare, reference_model
    from mbgen.pipeline import run
    from mbgen.run.python import python_model

    result = run(pendulum(), ("rhs", "energy"))
    outputs = tuple(result.compiled.outputs)
    p = np.array([1.0, 0.1, np.nan])
    rows = compare({"c": result.compiled, "python": python_model(result.rendered)},
                   reference_model(result, outputs), outputs, p=p, samples=4)
    report = CheckReport("pend", rows, 4, 0, 1e-9, 1e-12)
    assert report.verdict == "INCONCLUSIVE", report.format()
    assert all(r.compared == 0 and r.both_failed == 4 for r in rows)


SLICED = ["spring_pendulum", "bent_pipe", "paraboloid", "spherical_rod", "bead_wire"]


@pytest.mark.parametrize("name", SLICED)
def test_every_output_of_a_sliced_scene_against_the_unsliced_equations(name):
    """The reference is the derived equations before slicing: a dropped or wrongly baked
    output (a point's velocity set to zero, a fixed parameter with the wrong value) fails."""
    from mbgen.abi import Output

    scene = load_scene(name)
    assert scene.fixed, f"{name} bakes no parameter: not a sliced scene"
    wanted = {o for o in Output.parse(scene.outputs) if not o.is_integrator}
    wanted |= {Output.RHS, Output.MASS_MATRIX, Output.FORCING, Output.ENERGY,
               Output.POSITIONS, Output.VELOCITIES}
    result = mbgen.run(scene, wanted)
    assert set(result.fixed) == set(scene.fixed)
    report = check(None, result=result, samples=4)
    assert report.ok, report.format()
    assert {r.output for r in report.rows} >= {"positions", "velocities", "rhs", "energy"}
    assert "unsliced" in report.format()
