"""Replays each misuse class of the hardening issue: one section per class (issue 18,
"the newer surfaces lose nothing and never answer wrong"), each replaying the probes that
failed, quick enough for the default test command; the area test files hold the details."""

import math

import numpy as np
import pytest

import mbgen
from mbgen.abi import status_name
from mbgen.codegen.targets import Targets
from mbgen.export import export_fmu
from mbgen.model.scene import load_scene
from mbgen.errors import (ArgumentError, ArgumentTypeError, ConstraintError,
                          SingularMassMatrixError)
from mbgen.run.stepper import Stepper
from mbgen.scenes import four_bar


# --- 6. Singular is singular
def test_a_zero_length_crank_is_singular_in_c_python_and_the_reference():
    result = mbgen.run(four_bar.scene())
    c = result.compiled
    p = {**four_bar.scene().parameters, "la": 0.0}      # the crank moves no mass
    x = c.consistent(four_bar.scene().x0(c.layout), p=p)
    for model in (c, mbgen.python_model(result.rendered),
                  mbgen.LambdifiedModel(result.baked, c.outputs, layout=c.layout)):
        with pytest.raises(SingularMassMatrixError):    # not accelerations of 1e16
            model.rhs(0.0, x, p)


# --- 7. Constraints: consistent states, batch starts, tolerances
def test_constraints_end_on_the_loop_check_each_batch_start_and_refuse_nan_tolerances():
    scene = load_scene("four_bar", dead_point=True)
    model = mbgen.compile(scene, ("rhs", "jacobian", "holonomic", "holonomic_jacobian",
                                  "dopri5"))
    near_dead = np.array([four_bar.dead_angle(**four_bar.DEAD_POINT_LENGTHS) - 1e-6, -4.0,
                          -0.8, 0.0])
    try:
        y = model.consistent(near_dead)                 # once: q2 = -863, residual 3e-10
        assert np.max(np.abs(model.holonomic(0.0, y))) <= 5e-12
    except ConstraintError:
        pass
    x0 = scene.x0(model.layout)
    off = x0 + np.array([0.0, 0.3, 0.0, 0.0])
    with pytest.raises(ConstraintError, match="member 1 of 2"):
        model.integrate("dopri5", [0.0, 0.1], np.array([x0, off]))
    drift = model.integrate("dopri5", [0.0, 0.1], np.array([x0, off]), project=False)
    assert drift.stats["max_residual"][1] > 0.1         # as given, not projected
    for tol in (math.nan, math.inf, -1.0):
        with pytest.raises(ArgumentError, match="tol"):
            mbgen.linearize(model, x0, tol=tol)


# --- 8. Time in the step API and the FMU
def test_step_and_fmu_refuse_time_that_does_not_advance_and_calls_out_of_order(tmp_path):
    scene = load_scene("disc_pendulum")
    model = mbgen.compile(scene, ("rhs", "dopri5", "rk4"), targets=Targets(step=True))
    x0 = scene.x0(model.layout)
    for method in ("rk4", "dopri5"):
        s = Stepper(model, method, 1e16, x0)                    # 1e16 + 1 == 1e16
        with pytest.raises(mbgen.IntegrationError, match="STEP_TOO_SMALL"):
            s.step(1.0)
        mem = model.ffi.new(f"disc_pendulum_{method}_memory *")
        assert getattr(model.lib, f"disc_pendulum_{method}_init")(
            mem, 0.0, model.ffi.from_buffer("double[]", x0), 1e-6, 1e-9) == 0
        status = getattr(model.lib, f"disc_pendulum_{method}_step")(mem, 0.1, model.ffi.NULL)
        assert status_name(status) == "BAD_ARGUMENT"   # p = NULL: no segfault
    s = Stepper(model, "rk4", 3.7, x0)                          # t0 kept, not n * h
    s.step(0.25)
    s.step(0.25)
    assert s.t == 4.2

    fmi2 = pytest.importorskip("fmpy.fmi2", reason="FMPy is in the test extra")
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException

    path = export_fmu(scene, tmp_path)
    md = read_model_description(str(path))
    fmu = fmi2.FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path / "x")),
                         modelIdentifier=md.coSimulation.modelIdentifier, instanceName="replay")
    fmu.instantiate()
    for misuse in (fmu.exitInitializationMode, lambda: fmu.doStep(0.0, 0.1)):
        with pytest.raises(FMICallException):                   # out of order
            misuse()
        fmu.reset()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    with pytest.raises(FMICallException):                       # set-up in step mode
        fmu.setupExperiment(startTime=0.0)
    for point, size in ((math.nan, 0.1), (-0.1, 0.1), (0.5, 0.1), (0.0, 0.0)):
        fmu.reset()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        with pytest.raises(FMICallException):                   # NaN, backwards, jump, h = 0
            fmu.doStep(point, size)
    fmu.reset()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(0.0, 0.1)
    der = [v.valueReference for v in md.modelVariables if v.name.startswith("der(")]
    x = np.array(fmu.getReal(list(range(model.n_x))))
    assert np.array_equal(fmu.getReal(der), model.rhs(0.1, x))  # der(x) is the RHS
    fmu.terminate()
    with pytest.raises(FMICallException):                       # nothing after terminate
        fmu.doStep(0.1, 0.1)
    fmu.freeInstance()


# --- 9. The fast path never reads memory it does not own
def test_the_fast_path_reads_a_reallocated_parameter_array():
    model = mbgen.compile(load_scene("disc_pendulum"), ("rhs",))
    x, p = np.full(model.n_x, 0.3), model.default_parameters.copy()
    model.rhs(0.0, x, p)
    p.resize(1 << 16, refcheck=False)                   # moved: the old block is freed
    p[model.n_p:] = -7.0
    p.resize(model.n_p, refcheck=False)
    p[:] = model.default_parameters * 1.5
    np.testing.assert_array_equal(model.rhs(0.0, x, p), model.rhs(0.0, x, p.copy()))


# --- 10. Numbers by name are real numbers
@pytest.mark.parametrize("value", [None, 1 + 2j, "9.81", [1.0, None]])
def test_non_real_numbers_by_name_are_refused(value):
    model = mbgen.compile(load_scene("disc_pendulum"), ("rhs",))
    with pytest.raises(ArgumentTypeError, match="parameters 'g'"):   # not NaN, not 1.0
        model.rhs(0.0, np.zeros(model.n_x), {"g": value})
