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
from mbgen.run.stepper import Stepper


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
