"""FMI 2.0 export, checked by a third-party importer (FMPy): its model-description
validation, and co-simulation and model-exchange trajectories against integrate."""

import dataclasses
import os
import shutil
import subprocess
import zipfile
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import mbgen
from mbgen.model.scene import load_scene
from mbgen.build.fmu import write_fmu
from mbgen.export import export_fmu

fmpy = pytest.importorskip("fmpy", reason="FMPy is in the test extra: pip install -e '.[test]'")
from fmpy import simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

SCENES = {"disc_pendulum": {}, "stiff_chain": {}, "n_link_cart": {"n": 2}}
CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++") or shutil.which("c++")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fmus")
    return {name: (load_scene(name, **opts), export_fmu(load_scene(name, **opts), folder))
            for name, opts in SCENES.items()}


def states(result, names):
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
    gap = np.abs(states(res, model.state_names) - ref.x).max()
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
    assert np.abs(states(res, model.state_names) - ref.x).max() < 1e-6
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
    x = states(res, model.state_names)
    e = np.array([model.energy(0.0, xi) for xi in x])
    assert np.abs(e - states(res, ["energy.T", "energy.V"])).max() < 1e-12


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
