"""FMI 2.0 export, checked by a third-party importer (FMPy): its model-description
validation, and co-simulation and model-exchange trajectories against integrate."""

import dataclasses
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from ctypes import byref, c_double, c_int

import numpy as np
import pytest
import sympy as sm

import mbgen
import models
from mbgen.build.fmu import write_fmu
from mbgen.codegen.targets import Targets
from mbgen.codegen.targets.fmu import FMI2_ALLOWED, FMI2_STATES
from mbgen.export import export_fmu
from mbgen.integrators import DEFAULT_ATOL, DEFAULT_RTOL
from mbgen.model.scene import load_scene
from mbgen.runtime.stepper import Stepper

fmpy = pytest.importorskip("fmpy", reason="FMPy is in the test extra: pip install -e '.[test]'")
from fmpy import extract, read_model_description, simulate_fmu  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import (  # noqa: E402
    FMU2Model,
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Error,
)
from fmpy.logging import addLoggerProxy  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

SCENES = {"disc_pendulum": {}, "stiff_chain": {}, "n_link_cart": {"n": 2}}
CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++") or shutil.which("c++")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fmus")
    return {name: (load_scene(name, **opts), export_fmu(load_scene(name, **opts), folder))
            for name, opts in SCENES.items()}


def state_columns(result, names):
    return np.stack([result[n] for n in names], axis=1)


@pytest.mark.parametrize("name", SCENES)
def test_fmpy_validates_the_model_description(fmus, name):
    assert validate_fmu(str(fmus[name][1])) == []


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_fmpy_trajectory_matches_integrate(fmus, name, kind):
    scene, path = fmus[name]
    model = mbgen.compile(scene)
    method = "rosenbrock" if "rosenbrock" in [o.value for o in model.outputs] else "dopri5"
    t_end = min(scene.t_span[1], 5.0)
    r = [2.0] * model.n_r                                  # a constant force where there are inputs
    signal = None
    if model.n_r:
        signal = np.array([(0.0, 2.0), (t_end, 2.0)], dtype=[("time", "f8"), ("F", "f8")])
    res = simulate_fmu(str(path), fmi_type=kind, stop_time=t_end, output_interval=t_end / 100,
                       relative_tolerance=1e-9, input=signal,
                       output=list(model.state_names))
    ref = model.integrate(method, res["time"], scene.x0(model.layout), r=r or None,
                          rtol=1e-11, atol=1e-13)
    gap = np.abs(state_columns(res, model.state_names) - ref.x).max()
    scale = np.abs(ref.x).max()
    # co-simulation runs mbgen's own integrator at rtol 1e-9; model exchange FMPy's CVode
    assert gap < (1e-6 if kind == "CoSimulation" else 1e-4) * scale, gap


def test_tunable_parameters_and_baked_ones_absent(fmus, tmp_path):
    scene, path = fmus["disc_pendulum"]
    model = mbgen.compile(scene)
    res = simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=2.0, output_interval=0.1,
                       relative_tolerance=1e-9, start_values={"l": 3.0, "q2": 0.5})
    p = model.default_parameters.copy()
    p[model.parameter_names.index("l")] = 3.0
    x0 = scene.x0(model.layout)
    x0[model.state_names.index("q2")] = 0.5
    ref = model.integrate("dopri5", res["time"], x0, p, rtol=1e-11, atol=1e-13)
    assert np.abs(state_columns(res, model.state_names) - ref.x).max() < 1e-6
    # bead_wire bakes m: it is no variable of the FMU; its free parameters are tunable
    bead = export_fmu(load_scene("bead_wire"), tmp_path)
    root = ET.fromstring(zipfile.ZipFile(bead).read("modelDescription.xml"))
    variables = {v.get("name"): v for v in root.iter("ScalarVariable")}
    assert "m" not in variables and load_scene("bead_wire").fixed == {"m": 0.1}
    params = [v for v in variables.values() if v.get("causality") == "parameter"]
    assert params and all(v.get("variability") == "tunable" for v in params)


def test_outputs_and_user_text_in_the_xml(tmp_path):
    scene = dataclasses.replace(load_scene("disc_pendulum"),
                                outputs=("rhs", "dopri5", "energy"),
                                description='a <"pendulum"> & its \'disc\'')
    path = export_fmu(scene, tmp_path)
    assert validate_fmu(str(path)) == []
    root = ET.fromstring(zipfile.ZipFile(path).read("modelDescription.xml"))
    assert root.get("description") == scene.description          # escaped, read back intact
    res = simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=1.0, output_interval=0.5,
                       output=["q1", "q2", "u1", "u2", "energy.T", "energy.V"])
    model = mbgen.compile(scene)
    x = state_columns(res, model.state_names)
    e = np.array([model.energy(0.0, xi) for xi in x])
    assert np.abs(e - state_columns(res, ["energy.T", "energy.V"])).max() < 1e-12


@pytest.mark.parametrize("outputs", [None, ("rhs", "dopri5", "energy", "positions")])
def test_glue_compiles_strictly_as_c_and_cxx(outputs, tmp_path):
    scene = load_scene("n_link_cart", n=2)
    if outputs:
        scene = dataclasses.replace(scene, outputs=outputs)
    path = export_fmu(scene, tmp_path)
    with zipfile.ZipFile(path) as zf:
        names = [n for n in zf.namelist() if n.startswith("sources/")]
        zf.extractall(tmp_path, names)
        assert any(n.startswith("binaries/") for n in zf.namelist())
    src = tmp_path / "sources"
    for tool, flags in ((CC, ["-std=c99"]), (CXX, ["-x", "c++", "-std=c++11"])):
        done = subprocess.run([tool, *flags, "-pedantic", "-Wall", "-Wextra", "-Werror", "-c",
                               "n_link_cart_fmu.c", "-o", "glue.o"], cwd=src,
                              capture_output=True, text=True)
        assert done.returncode == 0 and not done.stderr, done.stderr


def test_fmu_command(tmp_path, capsys):
    from mbgen.cli import main

    assert main(["fmu", "paraboloid", "-o", str(tmp_path)]) == 0
    assert "paraboloid.fmu" in capsys.readouterr().out
    assert validate_fmu(str(tmp_path / "paraboloid.fmu")) == []
    assert main(["fmu", "no_such_scene", "-o", str(tmp_path)]) == 3
    assert os.listdir(tmp_path) == ["paraboloid.fmu"]           # the FMU alone, no manifest


def test_fmu_command_is_generate_target_fmu(tmp_path, capsys):
    """``mbgen fmu`` is an alias of ``mbgen generate --target fmu``: one row of the registry
    writes the same archive, and beside other targets it joins their generation."""
    from mbgen.cli import main

    assert main(["fmu", "paraboloid", "-o", str(tmp_path / "alias")]) == 0
    assert main(["generate", "paraboloid", "--target", "fmu", "-o",
                 str(tmp_path / "target")]) == 0
    assert os.listdir(tmp_path / "target") == ["paraboloid.fmu"]
    assert "paraboloid.fmu  (FMI 2.0, model exchange and co-simulation)" in \
        capsys.readouterr().out

    def texts(path):
        with zipfile.ZipFile(path) as zf:
            return {n: zf.read(n) for n in zf.namelist() if not n.startswith("binaries/")}

    assert texts(tmp_path / "alias" / "paraboloid.fmu") == \
        texts(tmp_path / "target" / "paraboloid.fmu")
    done = mbgen.generate(load_scene("paraboloid"), "c,fmu", tmp_path / "both")
    assert [p.name for p in done.files] == ["paraboloid.c", "paraboloid.h"]
    assert [p.name for p, _ in done.archives] == ["paraboloid.fmu"]
    assert "paraboloid_dopri5_step(" in (tmp_path / "both" / "paraboloid.h").read_text()


# ------------------------------------------------------------------ the FMI calls one by one
LOG = []                                 # (status, message) from every probe instance
CALLBACKS = fmi2CallbackFunctions()
CALLBACKS.logger = fmi2CallbackLoggerTYPE(
    lambda env, name, status, category, message: LOG.append((status, message.decode())))
CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)
addLoggerProxy(byref(CALLBACKS))         # formats the FMU's printf-style messages


@pytest.fixture(scope="module")
def unpacked(fmus, tmp_path_factory):
    """disc_pendulum's FMU unpacked: (scene, compiled model, model description, folder)."""
    scene, path = fmus["disc_pendulum"]
    folder = extract(str(path), str(tmp_path_factory.mktemp("unpacked")))
    return scene, mbgen.compile(scene), read_model_description(str(path)), folder


def instances(unpacked, name: str):
    """``(make, made)``: ``make(kind)`` a fresh instance (FMPy's FMU2Slave or FMU2Model) of
    the unpacked FMU, instantiated; ``made`` to free afterwards."""
    made = []

    def make(kind="CoSimulation"):
        _, _, md, folder = unpacked
        cls = FMU2Slave if kind == "CoSimulation" else FMU2Model
        fmu = cls(guid=md.guid, unzipDirectory=folder,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        fmu.instantiate(callbacks=CALLBACKS)
        made.append(fmu)
        LOG.clear()
        return fmu
    return make, made


@pytest.fixture
def probe(unpacked):
    """``probe(kind)``: a fresh instance of disc_pendulum's FMU, freed afterwards."""
    make, made = instances(unpacked, "probe")
    yield make
    for fmu in made:
        fmu.freeInstance()


def refused(call, *args, says):
    """``call(*args)`` returns fmi2Error and logs an error message containing ``says``."""
    LOG.clear()
    with pytest.raises(FMICallException) as info:
        call(*args)
    assert info.value.status == fmi2Error
    assert any(s == fmi2Error and says in m for s, m in LOG), (says, LOG)


def initialized(fmu, t0=0.0, x=None):
    fmu.setupExperiment(startTime=t0)
    fmu.enterInitializationMode()
    if x is not None:
        fmu.setReal(list(range(len(x))), list(x))
    fmu.exitInitializationMode()
    return fmu


def test_derivative_value_references_give_the_rhs(unpacked, probe):
    """fmi2GetReal on der(x)'s value references (read from the model description) is the
    RHS at the instance's time and state, in co-simulation and model exchange alike."""
    scene, model, md, _ = unpacked
    vr = {v.name: v.valueReference for v in md.modelVariables}
    states = [vr[n] for n in model.state_names]
    derivatives = [vr[f"der({n})"] for n in model.state_names]
    x = np.array([0.3, 1.1, 0.7, -0.4])
    p = model.default_parameters
    cs = initialized(probe("CoSimulation"), 0.25, x)
    assert np.array_equal(cs.getReal(derivatives), model.rhs(0.25, x, p))
    cs.doStep(0.25, 0.5)
    x1 = np.array(cs.getReal(states))
    assert not np.allclose(x1, x)
    assert np.array_equal(cs.getReal(derivatives), model.rhs(0.75, x1, p))
    me = initialized(probe("ModelExchange"))
    me.newDiscreteStates()
    me.enterContinuousTimeMode()
    me.setTime(0.5)
    buf = (c_double * 4)(*x)
    me.setContinuousStates(buf, 4)
    assert np.array_equal(me.getReal(derivatives), model.rhs(0.5, x, p))
    me.getDerivatives(buf, 4)
    assert np.array_equal(np.array(buf), model.rhs(0.5, x, p))


@pytest.mark.parametrize("point, size, says", [
    (float("nan"), 0.1, "currentCommunicationPoint"),
    (0.1, 0.1, "currentCommunicationPoint"),              # backwards from t = 0.2
    (0.3, 0.1, "currentCommunicationPoint"),              # a jump ahead
    (0.2, 0.0, "communicationStepSize"),
    (0.2, -0.1, "communicationStepSize"),
    (0.2, float("nan"), "communicationStepSize"),
    (0.2, float("inf"), "communicationStepSize"),
])
def test_do_step_checks_the_communication_point(unpacked, probe, point, size, says):
    """fmi2DoStep refuses (fmi2Error, a logged message) a communication point that is NaN, or
    not the FMU's time within a relative 1e-5 (the Reference-FMUs' check), and a step that is
    not a positive finite number; the state stays at the last step, and the instance is in
    the error state (only Reset, FreeInstance and the getters are allowed)."""
    _, model, _, _ = unpacked
    fmu = initialized(probe())
    fmu.doStep(0.0, 0.2)
    x = fmu.getReal(list(range(model.n_x)))
    refused(fmu.doStep, point, size, says=says)
    assert fmu.getReal(list(range(model.n_x))) == x
    refused(fmu.doStep, 0.2, 0.1, says="fmi2DoStep")
    fmu.reset()                                            # back to a fresh start
    initialized(fmu).doStep(0.0, 0.2)
    fmu.doStep(0.2 * (1 + 1e-12), 0.1)                     # the master's rounding: accepted


def test_fmi2_state_machine_refuses_calls_out_of_order(probe):
    """Calls the FMI 2.0 state machine does not allow in the instance's state are refused with
    fmi2Error and an 'illegal call sequence' message naming the function."""
    fmu = probe()
    refused(fmu.exitInitializationMode, says="fmi2ExitInitializationMode")
    fmu = probe()
    refused(fmu.doStep, 0.0, 0.1, says="fmi2DoStep")
    fmu = probe()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    refused(fmu.doStep, 0.0, 0.1, says="fmi2DoStep")
    fmu = initialized(probe())
    refused(fmu.setupExperiment, None, 0.0, says="fmi2SetupExperiment")
    fmu = initialized(probe())
    refused(fmu.enterInitializationMode, says="fmi2EnterInitializationMode")
    for call, args in (("doStep", (0.1, 0.1)), ("setReal", ([0], [1.0])),
                       ("setupExperiment", (None, 0.0)), ("enterInitializationMode", ()),
                       ("exitInitializationMode", ()), ("terminate", ())):
        fmu = initialized(probe())
        fmu.doStep(0.0, 0.1)
        fmu.terminate()
        refused(getattr(fmu, call), *args, says=f"fmi2{call[0].upper()}{call[1:]}: illegal")
    fmu = initialized(probe())
    fmu.doStep(0.0, 0.1)
    fmu.terminate()
    assert len(fmu.getReal([0, 1])) == 2                   # the getters stay allowed
    fmu.reset()
    initialized(fmu).doStep(0.0, 0.1)                      # and a reset starts afresh
    me = probe("ModelExchange")
    refused(me.setTime, 0.0, says="fmi2SetTime")
    me = initialized(probe("ModelExchange"))               # event mode
    refused(me.completedIntegratorStep, says="fmi2CompletedIntegratorStep")
    me = initialized(probe("ModelExchange"))
    me.newDiscreteStates()
    me.enterContinuousTimeMode()
    refused(me.newDiscreteStates, says="fmi2NewDiscreteStates")


def test_times_must_be_finite(probe):
    refused(probe().setupExperiment, None, float("nan"), says="startTime")
    me = initialized(probe("ModelExchange"))
    refused(me.setTime, float("inf"), says="fmi2SetTime: time")


def _enter(fmu, state):
    """Bring a fresh instance ``fmu`` into the FMI 2.0 ``state``."""
    if state == "error":
        refused(fmu.exitInitializationMode, says="illegal call sequence")
    elif state != "instantiated":
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        if state != "initialization_mode":
            fmu.exitInitializationMode()
        if state == "continuous_time_mode":
            fmu.newDiscreteStates()
            fmu.enterContinuousTimeMode()
        if state == "terminated":
            fmu.terminate()


def test_every_fmi2_function_is_refused_in_the_states_the_standard_excludes(unpacked):
    """The table FMI2_ALLOWED, call by call: each FMI function called (with zero arguments) in
    each reachable state it does not allow returns fmi2Error, logs 'illegal call sequence'
    with its name and leaves the instance in the error state."""
    _, _, md, folder = unpacked
    reachable = {"ModelExchange": ("instantiated", "initialization_mode", "event_mode",
                                   "continuous_time_mode", "terminated", "error"),
                 "CoSimulation": ("instantiated", "initialization_mode", "step_complete",
                                  "terminated", "error")}
    assert set(FMI2_STATES) == set(reachable["ModelExchange"] + reachable["CoSimulation"])
    fmus = {kind: cls(guid=md.guid, unzipDirectory=folder, instanceName="table",
                      modelIdentifier=md.coSimulation.modelIdentifier)
            for kind, cls in (("ModelExchange", FMU2Model), ("CoSimulation", FMU2Slave))}
    argtypes = {name: f.argtypes for fmu in fmus.values() for name, f in fmu._functions.items()}
    assert set(FMI2_ALLOWED) <= set(argtypes)
    checked = 0
    for kind, fmu in fmus.items():
        for state in reachable[kind]:
            for name, states in FMI2_ALLOWED.items():
                if state in states:
                    continue
                fmu.instantiate(callbacks=CALLBACKS)
                _enter(fmu, state)
                function = getattr(fmu.dll, name)
                function.argtypes, function.restype = argtypes[name], c_int
                LOG.clear()
                assert function(fmu.component, *(t() for t in argtypes[name][1:])) == fmi2Error
                assert LOG == [(fmi2Error, f"{name}: illegal call sequence (the instance is in "
                                           f"state '{state.replace('_', ' ')}')")], LOG
                refused(fmu.exitInitializationMode, says="state 'error'")
                fmu.fmi2FreeInstance(fmu.component)
                checked += 1
    assert checked >= 200
    for fmu in fmus.values():
        fmu.freeLibrary()


def test_the_fmu_follows_the_umask_like_every_other_output(fmus, tmp_path):
    """Issue 18: the .fmu was written through mkstemp and stayed 0600 whatever the umask."""
    old = os.umask(0o022)
    try:
        path = export_fmu(fmus["disc_pendulum"][0], tmp_path)
        assert os.stat(path).st_mode & 0o777 == 0o644
        os.umask(0o027)
        path = write_fmu(tmp_path / "other", "disc_pendulum", {"modelDescription.xml": "<x/>"},
                         b"\x7fELF")
        assert os.stat(path).st_mode & 0o777 == 0o640
        os.chmod(path, 0o600)                                   # a replaced FMU keeps its mode
        write_fmu(tmp_path / "other", "disc_pendulum", {"modelDescription.xml": "<y/>"}, b"")
        assert os.stat(path).st_mode & 0o777 == 0o600
    finally:
        os.umask(old)
    assert sorted(p.name for p in (tmp_path / "other").iterdir()) == ["disc_pendulum.fmu"]


# ------------------------------------------------------------------ issue 28: behaviour
@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_terminate_before_the_simulation_has_started_is_refused(probe, kind):
    """The standard (FMI 2.0, 3.2.3 and 4.2.4, as typed here, not read from FMI2_ALLOWED):
    fmi2Terminate follows a running simulation (event or continuous-time mode, a completed
    step); right after instantiation, or in initialization mode, it is an illegal call."""
    refused(probe(kind).terminate, says="fmi2Terminate: illegal call sequence (the instance "
                                        "is in state 'instantiated')")
    fmu = probe(kind)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    refused(fmu.terminate, says="fmi2Terminate: illegal call sequence (the instance is in "
                                "state 'initialization mode')")


@pytest.fixture(scope="module")
def driven(tmp_path_factory):
    """A pendulum driven by ``a sin(w t)`` (its RHS depends on t): (scene, model with the
    step API, model description, unpacked FMU folder)."""
    m = models.pendulum("driven_pendulum")
    a, w = m.constants("a w")
    m.torque(m.frame("B"), a * sm.sin(w * mbgen.t) * m.frame("N").z)
    scene = mbgen.Scene("driven_pendulum", m, parameters={"l": 1.0, "g": 9.81, "m": 1.0,
                                                         "a": 2.0, "w": 3.0},
                        initial_state={"q": 0.5, "u": 0.0}, t_span=(0.0, 2.0))
    path = export_fmu(scene, tmp_path_factory.mktemp("driven"))
    folder = extract(str(path), str(tmp_path_factory.mktemp("driven_unpacked")))
    model = mbgen.compile(scene, ("rhs", "dopri5"), targets=Targets(step=True))
    return scene, model, read_model_description(str(path)), folder


@pytest.fixture
def driven_probe(driven):
    """``driven_probe(kind)``: a fresh instance of the driven pendulum's FMU, freed after."""
    make, made = instances(driven, "driven")
    yield make
    for fmu in made:
        fmu.freeInstance()


def test_set_time_alone_gives_the_derivatives_at_the_new_time(driven, driven_probe):
    """fmi2SetTime with the states unchanged: der(x) (fmi2GetDerivatives and fmi2GetReal)
    is the RHS at the new time, not the one cached at the old time."""
    _, model, md, _ = driven
    vr = {v.name: v.valueReference for v in md.modelVariables}
    derivatives = [vr[f"der({n})"] for n in model.state_names]
    x, p = np.array([0.3, -0.2]), model.default_parameters
    me = initialized(driven_probe("ModelExchange"))
    me.newDiscreteStates()
    me.enterContinuousTimeMode()
    me.setTime(0.1)
    buf = (c_double * 2)(*x)
    me.setContinuousStates(buf, 2)
    assert np.array_equal(me.getReal(derivatives), model.rhs(0.1, x, p))
    me.setTime(0.6)
    assert not np.array_equal(model.rhs(0.6, x, p), model.rhs(0.1, x, p))
    assert np.array_equal(me.getReal(derivatives), model.rhs(0.6, x, p))
    me.setTime(0.9)
    me.getDerivatives(buf, 2)
    assert np.array_equal(np.array(buf), model.rhs(0.9, x, p))


def test_do_step_from_states_set_by_the_master_starts_afresh(driven, driven_probe):
    """Between steps the master sets new states: the next step's first stage is the RHS at
    them, not the FSAL derivative kept from the old ones.  Bit for bit the step API told
    the same (its memory's states replaced and its derivative invalidated)."""
    scene, model, md, _ = driven
    vr = {v.name: v.valueReference for v in md.modelVariables}
    states = [vr[n] for n in model.state_names]
    cs = initialized(driven_probe())
    stepper = Stepper(model, "dopri5", 0.0, scene.x0(model.layout), rtol=DEFAULT_RTOL,
                      atol=DEFAULT_ATOL)
    cs.doStep(0.0, 0.25)
    assert np.array_equal(cs.getReal(states), stepper.step(0.25))
    x = [1.2, -3.0]
    cs.setReal(states, x)
    cs.doStep(0.25, 0.25)
    stepper.memory.x[0:2], stepper.memory.f_valid = x, 0
    assert np.array_equal(cs.getReal(states), stepper.step(0.25))


# ------------------------------------------------------------------ input bounds (saturate)
@pytest.fixture(scope="module")
def bounded(tmp_path_factory):
    """The bounded cart (F in [-5, 5], T <= 1) saturated: (scene, model with the step API,
    model description, unpacked folder, FMU path)."""
    scene = models.bounded_cart(True, ("rhs", "dopri5"))
    path = export_fmu(scene, tmp_path_factory.mktemp("bounded"))
    folder = extract(str(path), str(tmp_path_factory.mktemp("bounded_unpacked")))
    model = mbgen.compile(scene, targets=Targets(step=True))
    return scene, model, read_model_description(str(path)), folder, path


def test_a_saturating_fmu_states_its_bounds_and_validates(bounded):
    *_, md, _, path = bounded
    assert validate_fmu(str(path)) == []
    said = {v.name: v.description for v in md.modelVariables if v.causality == "input"}
    assert said["F"].endswith(", saturated to [-5.0, 5.0]")
    assert said["T"].endswith(", saturated to [-inf, 1.0]")


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_fmpy_input_beyond_its_bound_runs_as_the_input_at_the_bound(bounded, kind):
    """Through FMPy, F = 20, T = 3 give bit for bit the trajectory of F = 5, T = 1."""
    *_, path = bounded

    def run_with(F, T):
        signal = np.array([(0.0, F, T), (2.0, F, T)], dtype=[("time", "f8"), ("F", "f8"),
                                                             ("T", "f8")])
        res = simulate_fmu(str(path), fmi_type=kind, stop_time=2.0, output_interval=0.1,
                           input=signal, output=["x", "th", "v", "w"])
        return state_columns(res, ["x", "th", "v", "w"])

    beyond, edge = run_with(20.0, 3.0), run_with(5.0, 1.0)
    assert np.array_equal(beyond, edge)
    assert not np.array_equal(beyond, run_with(4.0, 1.0))


def test_set_real_stores_the_clamped_input_and_logs_it(bounded):
    """fmi2SetReal keeps an input clamped (fmi2GetReal reads the bound back; logged with
    debug logging on); a co-simulation step is the saturating step API's, bit for bit."""
    scene, model, md, folder, _ = bounded
    make, made = instances((scene, model, md, folder), "bounded")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    try:
        cs = initialized(make())
        cs.setDebugLogging(True, [])
        LOG.clear()
        cs.setReal([vr["F"], vr["T"]], [20.0, -40.0])
        assert cs.getReal([vr["F"], vr["T"]]) == [5.0, -40.0]
        assert [m for _, m in LOG] == ["fmi2SetReal: input F = 20 clamped to its bound 5"]
        stepper = Stepper(model, "dopri5", 0.0, scene.x0(model.layout), rtol=DEFAULT_RTOL,
                          atol=DEFAULT_ATOL)
        cs.doStep(0.0, 0.5)
        states = [vr[n] for n in model.state_names]
        assert np.array_equal(cs.getReal(states), stepper.step(0.5, r=[20.0, -40.0]))
        assert stepper.n_saturated == 1
    finally:
        for fmu in made:
            fmu.freeInstance()
