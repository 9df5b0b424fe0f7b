"""`mbgen check` must not pass on nothing, and its reference is the unsliced equations
(a slicing fault must not agree with itself)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mbgen
from mbgen.cli import EXIT_CHECK, EXIT_INCONCLUSIVE, EXIT_OK, EXIT_USAGE, main
from mbgen.errors import ArgumentError, CheckFailed, CheckInconclusive, MbgenError
from mbgen.model.scene import load_scene
from mbgen.verify.check import CheckReport, check


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
    from mbgen.abi import Output
    from mbgen.pipeline import run
    from mbgen.verify.check import compare

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
    from mbgen.pipeline import run
    from mbgen.runtime.python import python_model
    from mbgen.verify.check import CheckReport, compare, reference_model

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


# ------------------------------------------------------------------ scale of the reference
def tiny_disc(mass: float) -> mbgen.Scene:
    """The rolling disc (a saddle-point solve in the reference) with mass ``mass``."""
    scene = load_scene("rolling_disc")
    return replace(scene, parameters={**scene.parameters, "m": mass})


class SignFlipped:
    """A back end whose rhs has the sign of its last acceleration flipped (a real fault)."""

    def __init__(self, model):
        self.model = model

    def rhs(self, t, x, p=None, r=None):
        out = np.array(self.model.rhs(t, x, p, r))
        out[-1] = -out[-1]
        return out


@pytest.mark.parametrize("mass", [1e-20, 1e20])
def test_the_reference_does_not_lose_precision_on_the_scale_of_the_model(mass):
    """A correct model is not FAILED because of its mass's scale: at m = 1e-20 the C is
    scale-invariant (rel 6e-15) and the reference's saddle-point solve was not (rel 1.45;
    normwise pivoting mixed the 1e-20 mass block with the O(1) constraint block)."""
    report = check(tiny_disc(mass), samples=6)
    assert report.ok and report.verdict == "PASSED", report.format()
    assert all(r.max_rel < 1e-12 for r in report.rows), report.format()


@pytest.mark.parametrize("length", [1e8])
def test_the_reference_does_not_lose_precision_on_the_scale_of_lengths(length):
    """At r = 1e8 the reference's positive-definiteness test of the reduced mass matrix
    (an SVD rank with an absolute floor) called a sample singular that the C solved."""
    scene = load_scene("rolling_disc")
    report = check(replace(scene, parameters={**scene.parameters, "r": length}), samples=10)
    assert report.ok, report.format()


@pytest.mark.parametrize("mass", [1e-20, 1.0])
def test_a_real_fault_still_fails_at_every_scale(mass):
    """The scaled reference keeps every real failure: a flipped sign is FAILED."""
    from mbgen.abi import Output
    from mbgen.verify.check import compare, reference_model

    result = mbgen.run(tiny_disc(mass), ("rhs",))
    rows = compare({"flipped": SignFlipped(result.compiled)},
                   reference_model(result, (Output.RHS,)), (Output.RHS,),
                   p=result.compiled.default_parameters, samples=4)
    report = CheckReport("rolling_disc", rows, 4, 0, 1e-9, 1e-12)
    assert report.verdict == "FAILED" and rows[0].max_rel > 1e-3, report.format()
    with pytest.raises(CheckFailed):
        report.raise_if_failed()


def short_crank(crank: float) -> mbgen.Scene:
    """The four-bar with a crank of length ``crank``: ill-conditioned states for ``crank``
    << 1 (the saddle-point matrix's condition number grows like ``1 / crank**2``)."""
    scene = load_scene("four_bar")
    return replace(scene, parameters={**scene.parameters, "la": crank})


def test_an_ill_conditioned_state_is_inconclusive_not_failed():
    """Four-bar, crank 1e-6: C and reference both lose digits to the state's conditioning
    (condition number 1e13; against a 60-digit solve of the same M, F, A both are off by
    up to 6e-4), so a relative difference of 1e-3 proves nothing either way.  It was
    FAILED; it is INCONCLUSIVE, with the reason."""
    report = check(short_crank(1e-6), samples=5)
    assert report.verdict == "INCONCLUSIVE", report.format()
    rhs = [r for r in report.rows if r.output == "rhs"]
    assert all(r.unresolved > 0 and r.condition > 1e10 and not r.exceeded for r in rhs)
    assert "UNRESOLVED" in report.format() and "condition numbers up to" in report.reason
    with pytest.raises(CheckInconclusive):
        report.raise_if_failed()


def test_a_real_fault_on_an_ill_conditioned_state_still_fails():
    from mbgen.abi import Output
    from mbgen.verify.check import compare, reference_model

    result = mbgen.run(short_crank(1e-6), ("rhs",))
    rows = compare({"flipped": SignFlipped(result.compiled)},
                   reference_model(result, (Output.RHS,)), (Output.RHS,),
                   p=result.compiled.default_parameters, samples=4)
    report = CheckReport("four_bar", rows, 4, 0, 1e-9, 1e-12)
    assert report.verdict == "FAILED" and rows[0].exceeded, report.format()


def test_cli_tiny_mass_passes_and_ill_conditioning_exits_6(capsys):
    assert main(["check", "rolling_disc", "-p", "m=1e-20", "--samples", "4"]) == EXIT_OK
    assert "PASSED" in capsys.readouterr().out
    assert main(["check", "four_bar", "-p", "la=1e-6", "--samples", "4"]) == EXIT_INCONCLUSIVE
    err = capsys.readouterr().err
    assert err.startswith("mbgen: check inconclusive: four_bar: ") and "--rtol above" in err
