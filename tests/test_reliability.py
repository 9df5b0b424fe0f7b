"""Replays each misuse class of the hardening issue: one section per class (issue 18,
"the newer surfaces lose nothing and never answer wrong"), each replaying the probes that
failed, quick enough for the default test command; the area test files hold the details."""

import math
import os
import shutil
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

import mbgen
from mbgen.abi import status_name
from mbgen.build.cache import verified
from mbgen.build.extension import build, load
from mbgen.codegen.targets import Targets
from mbgen.errors import CacheError
from mbgen.export import export_fmu
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.run.stepper import Stepper

from models import pendulum, scene_file

ROOT = Path(__file__).resolve().parent.parent


# --- 3. Many threads compiling at once
def test_threads_compiling_at_once_leave_stdout_alone(tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    errors = []

    def compile_one(name):
        try:
            mbgen.compile(pendulum(name))
        except Exception as exc:  # collected: an error in a thread must fail the test
            errors.append(repr(exc))

    threads = [threading.Thread(target=compile_one, args=(f"replay{i}",)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    os.write(1, b"fd 1 still reaches the terminal\n")
    assert "fd 1 still reaches the terminal" in capfd.readouterr().out


# --- 4. The compile cache loads only what its user built
def test_a_module_in_a_folder_others_can_write_is_not_loaded(tmp_path, monkeypatch):
    mine, shared = tmp_path / "mine", tmp_path / "shared"
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(mine))
    rendered = run(pendulum("shared"), build=False).rendered
    path = build(rendered)
    shutil.copytree(mine, shared)  # a module and its matching record
    shared.chmod(0o777)            # ... where anyone could have put them
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(shared))
    with pytest.raises(CacheError, match=f"{shared} is writable by group and others"):
        load(rendered)
    assert verified(shared / path.name) is False


FULL_DISK = textwrap.dedent("""
    import errno, os, sys
    from mbgen.build import extension
    from mbgen.cli import main

    def write_files(folder, files):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.path.join(folder, "x.c"))

    extension.write_files = write_files
    sys.exit(main(["simulate", sys.argv[1], "--csv", sys.argv[2]]))
""")


def test_a_full_disk_in_compile_is_one_error_line(tmp_path):
    env = {**os.environ, "MBGEN_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-c", FULL_DISK, str(scene_file(tmp_path)),
                           str(tmp_path / "t.csv")], capture_output=True, text=True, env=env,
                          timeout=600)
    assert proc.returncode == CacheError.exit_code == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mbgen: error: "), proc.stderr
    assert "no space left on device" in lines[0] and str(tmp_path / "cache") in lines[0]


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


# --- Injected fault: a same-size corrupted cached module
def test_a_same_size_corrupted_module_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    rendered = run(pendulum("samesize"), build=False).rendered
    path = build(rendered)
    good, stat = path.read_bytes(), path.stat()
    i = len(good) // 2
    bad = good[:i] + bytes([good[i] ^ 0x01]) + good[i + 1:]
    path.write_bytes(bad)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))  # size and time as before
    assert not verified(path)
    assert build(rendered) == path and path.read_bytes() != bad and verified(path)
