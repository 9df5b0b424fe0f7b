"""Replays each misuse class of the hardening issue: one quick test (or a few) per class,
each failing on the code before its fix; the thorough tests sit in the area's own test files.

Sections follow the issue's numbering: files (1, 2, 5), building and the cache (3, 4),
numbers (6, 7, 9, 10), time in the step API and the FMU (8), ensembles and the check
(11, 12), the clear errors and the injected faults the suite must catch.
"""

import math
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import threading
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import mbgen
from mbgen.abi import Output, status_name
from mbgen.build.cache import verified
from mbgen.build.extension import build, load
from mbgen.build.fmu import write_fmu
from mbgen.cli import EXIT_OK, EXIT_USAGE, main
from mbgen.codegen.optimize import Form
from mbgen.codegen.targets import Targets
from mbgen.errors import (ArgumentError, ArgumentTypeError, CacheError, ConstraintError,
                          SingularMassMatrixError)
from mbgen.export import export_fmu
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.run.stepper import Stepper
from mbgen.scenes import four_bar
from mbgen.studies import cluster
from mbgen.verify.check import CheckReport, check, compare, reference_model
from models import massless_link_scene, pendulum, scene_file, two_input_cart

ROOT = Path(__file__).resolve().parent.parent


# --- 1. A regeneration never deletes or overwrites what the user changed or put there
def test_regeneration_keeps_the_users_edits(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    (out / "example.c").write_text("/* my example */\n")
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs"]) == EXIT_OK
    assert (out / "example.c").read_text() == "/* my example */\n"        # not deleted
    (out / "disc_pendulum.c").write_text("/* my tuning */\n")
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_USAGE  # issue 19: was 3
    assert (out / "disc_pendulum.c").read_text() == "/* my tuning */\n"   # not overwritten
    assert "--overwrite" in capsys.readouterr().err


# --- 2. A generation is whole or absent
KILLED_GENERATE = textwrap.dedent("""
    import io, os, signal, sys
    from mbgen.cli import main

    real_open, opened = io.open, []

    def open_(file, mode="r", *args, **kwargs):
        if "w" in mode and "disc_pendulum" in os.path.basename(os.fspath(file)):
            opened.append(file)
            if len(opened) == 2:                       # the first file is written
                os.kill(os.getpid(), signal.SIGKILL)
        return real_open(file, mode, *args, **kwargs)

    io.open = open_
    main(["generate", "disc_pendulum", "-o", sys.argv[1], "--outputs", "rhs,jacobian"])
""")


def test_a_generation_killed_between_files_leaves_the_old_one_whole(tmp_path):
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs"]) == EXIT_OK
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = subprocess.run([sys.executable, "-c", KILLED_GENERATE, str(out)], cwd=tmp_path,
                          capture_output=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == -signal.SIGKILL
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before      # the old set, whole


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


# --- 5. Scene files are Python and run when loaded
def test_the_docs_say_scene_files_run_as_code():
    readme = (ROOT / "README.md").read_text()
    safety = readme.split("## Safety")[1].split("\n## ")[0]
    assert "Scene files are Python" in safety and "trust" in safety
    for text in (readme.split("## Scenes")[1].split("\n## ")[0],
                 (ROOT / "docs" / "modelling.md").read_text()):
        assert "runs when it is loaded" in text


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


# --- 11. Ensembles: chunk <= 0 refused; a chunk that kills its worker costs that chunk only
@pytest.mark.parametrize("chunk", [0, -1, 1.5])
def test_ensemble_chunk_below_one_is_refused(chunk):
    """Was: every member a success with 0 steps."""
    with pytest.raises(ArgumentError, match="chunk"):
        mbgen.ensemble(load_scene("disc_pendulum"), grid={"l": [2.0]}, chunk=chunk,
                       serial=True, progress=False)


def test_a_chunk_that_kills_its_worker_loses_nothing_else():
    """Was: every chunk cancelled ("already forgotten": the scattered sources died with the
    workers).  A chunk whose task ends its worker process is that chunk's failure only."""
    pytest.importorskip("dask.distributed", reason="dask[distributed] is in the test extra")

    def task(shared, i):  # pickled by value: it runs on the worker
        if i == 1:
            os._exit(70)
        return shared + i

    results, _, _ = cluster.run_chunks(task, 10, [(i,) for i in range(3)], n_workers=2)
    assert results[0] == 10 and results[2] == 12
    assert cluster.lost_worker(results[1]), results[1]


# --- 12. mbgen check: no FAILED from the reference's own lost precision
def test_check_of_the_rolling_disc_at_a_tiny_mass_passes_and_a_fault_still_fails():
    """Was: FAILED at m = 1e-20 (relative error 1.45 of the reference's saddle-point solve)."""
    scene = load_scene("rolling_disc")
    scene = replace(scene, parameters={**scene.parameters, "m": 1e-20})
    result = mbgen.run(scene, ("rhs",))
    assert check(None, result=result, samples=4).verdict == "PASSED"

    class Flipped:
        def rhs(self, t, x, p=None, r=None):
            out = np.array(result.compiled.rhs(t, x, p, r))
            out[-1] = -out[-1]
            return out

    rows = compare({"flipped": Flipped()}, reference_model(result, (Output.RHS,)),
                   (Output.RHS,), p=result.compiled.default_parameters, samples=4)
    assert CheckReport("rolling_disc", rows, 4, 0, 1e-9, 1e-12).verdict == "FAILED"


# --- Clear errors: a bad Dask scheduler address, a huge --points
def test_bad_scheduler_address_and_huge_points_are_one_line(tmp_path, capsys, monkeypatch):
    """Was: a 30 s wait then a misleading "cannot write" line; a 7 TiB allocation and a
    traceback."""
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 1.0)
    csv = ["--quiet", "--csv", str(tmp_path / "s.csv")]
    for argv in (["--scheduler", "tcp://nonexistent:1"], ["--points", str(10**12)]):
        assert main(["sweep", "disc_pendulum", *argv, *csv]) == EXIT_USAGE
        err = capsys.readouterr().err
        assert err.startswith("mbgen: error: ") and err.count("\n") == 1, err


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


# --- The .fmu follows the umask like every other output
def test_the_fmu_follows_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        path = write_fmu(tmp_path, "m", {"modelDescription.xml": "<x/>"}, b"")
    finally:
        os.umask(old)
    assert os.stat(path).st_mode & 0o777 == 0o644                       # not mkstemp's 0600


# --- Injected faults: linearize's B (every input's column, a constrained model's speed rows)
def _input_differences(model, x, r, h=1e-6):
    return np.stack([(model.rhs(0.0, x, None, r + h * e) - model.rhs(0.0, x, None, r - h * e))
                     / (2 * h) for e in np.eye(model.n_r)], axis=1)


def test_linearize_gives_every_input_its_column_and_a_constrained_model_its_speed_rows():
    model = mbgen.compile(two_input_cart(), ("rhs", "jacobian", "input_jacobian"))
    x, r = np.array([0.2, 0.4, -0.3, 0.1]), np.array([0.5, -0.2])
    np.testing.assert_allclose(mbgen.linearize(model, x, r=r).B, _input_differences(model, x, r),
                               rtol=1e-7, atol=1e-9)
    scene = load_scene("slider_crank")
    crank = mbgen.compile(scene, ("rhs", "jacobian", "input_jacobian", "holonomic",
                                  "holonomic_jacobian"))
    x = crank.consistent(scene.x0(crank.layout) + np.array([0.3, 0, 0, 0.5]))
    lin = mbgen.linearize(crank, x, r=np.array([0.4]))
    keep = [crank.state_names.index(s) for s in lin.states]
    np.testing.assert_allclose(lin.B, _input_differences(crank, x, np.array([0.4]))[keep],
                               rtol=1e-7, atol=1e-9)
    assert abs(lin.B[1, 0]) > 0.1                                  # the speed row is there


# --- Injected fault: the articulated-body recursion and loads on massless parts
def test_the_recursion_keeps_the_loads_on_massless_parts():
    scn = massless_link_scene()
    kane = mbgen.compile(scn, ("rhs",), method="kane", name="massless_link_kane")
    rec = run(scn, ("rhs",), method="newton_euler", form=Form.RECURSIVE,
              name="massless_link_rec")
    x = np.array([0.3, -0.7, 0.5, 1.1])
    np.testing.assert_allclose(rec.compiled.rhs(0.0, x), kane.rhs(0.0, x), rtol=1e-11,
                               atol=1e-11)

