"""Replays each misuse class of the hardening issue: one quick test (or a few) per class,
each failing on the code before its fix; the thorough tests sit in the area's own test files.

Sections follow the issue's numbering: files (1, 2, 5), building and the cache (3, 4),
numbers (6, 7, 9, 10), time in the step API and the FMU (8), ensembles and the check
(11, 12), the clear errors and the injected faults the suite must catch.

Issue 28 (hardening 3, the new doors) follows, by its numbering: the cache and the lock
(1-4), robot files (5-10: URDF, then MJCF), ensembles (11), the step API (12), output folders
(13) and constraints (14).  The thorough tests sit in the area's files (tests/build/,
tests/test_fileio.py, tests/model/test_urdf.py, tests/model/test_mjcf.py, tests/studies/,
tests/runtime/test_stepper.py, tests/runtime/test_consistent.py), as do those of the injected
faults.
"""

import errno
import hashlib
import json
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

import fake_dask
import mbgen
from mbgen import fileio
from mbgen.abi import Output, status_name
from mbgen.build import extension
from mbgen.build.cache import cache_dir, verified
from mbgen.build.extension import build, load, module_name
from mbgen.build.fmu import write_fmu
from mbgen.cli import EXIT_MODEL, EXIT_OK, EXIT_USAGE, main
from mbgen.codegen.optimize import Form
from mbgen.codegen.targets import Targets
from mbgen.errors import (
    ArgumentError,
    ArgumentTypeError,
    BuildError,
    CacheError,
    ConstraintError,
    MjcfError,
    OutputPathError,
    SingularMassMatrixError,
    UrdfInertiaError,
    UrdfSyntaxError,
)
from mbgen.export import export_fmu
from mbgen.model import urdf_xml
from mbgen.model.limits import allow_large_models
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.stepper import Stepper
from mbgen.scenes import four_bar
from mbgen.studies import cluster
from mbgen.verify.check import CheckReport, check, compare, reference_model
from models import (
    count_joint_parent_reads,
    massless_link_scene,
    pendulum,
    read_in_thread,
    scene_file,
    two_input_cart,
)

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
    docs = ROOT / "docs"
    safety = (docs / "reference" / "safety.md").read_text()
    assert "Scene files are Python" in safety and "trust" in safety
    for text in ((docs / "tutorials" / "scenes.md").read_text(),
                 (docs / "modelling.md").read_text()):
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


# ==================== Issue 28: the cache, the lock, compiler flags, output folders (1-4, 13)

OTHER_UID = 65534      # "nobody": another user (root gives files to it; others pretend)

PLANTED = r"""
#include <stdio.h>
__attribute__((constructor)) static void planted(void) {
    FILE *f = fopen("%s", "w");
    if (f) fclose(f);
}
"""


def _as_someone_elses(path, monkeypatch):
    """Make ``path`` (a link or a file) look owned by another user: ``lchown`` as root, else
    an ``os.lstat``/``os.fstat`` that says so for this inode."""
    if os.geteuid() == 0:
        os.lchown(path, OTHER_UID, OTHER_UID)
        return
    ino = os.lstat(path).st_ino

    def other(real):
        def stat_(*args, **kwargs):
            st = real(*args, **kwargs)
            if st.st_ino != ino:
                return st
            fields = list(st[:10])
            fields[4] = st.st_uid + 1
            return os.stat_result(fields)
        return stat_

    monkeypatch.setattr(os, "lstat", other(os.lstat))
    monkeypatch.setattr(os, "fstat", other(os.fstat))


# --- 1. A cache reached through another user's link; the checked bytes are the loaded bytes
def test_a_cache_reached_through_another_users_link_is_refused(tmp_path, monkeypatch):
    real = tmp_path / "real"
    real.mkdir(mode=0o700)
    link = tmp_path / "cache"
    link.symlink_to(real)
    _as_someone_elses(link, monkeypatch)
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(link))
    with pytest.raises(CacheError, match=f"{link}.*link.*owned by.*MBGEN_CACHE_DIR"):
        cache_dir()


def test_a_module_swapped_after_its_check_is_not_loaded(tmp_path, monkeypatch):
    """The issue's race, made certain: the module is swapped for a planted library (with a
    matching record) after the build checked it; the load must not run the plant."""
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path / "cache"))
    rendered = run(pendulum("swapped"), build=False).rendered
    marker, real_build = tmp_path / "constructor-ran", extension.build

    def build_then_swap(*args, **kwargs):
        path = real_build(*args, **kwargs)
        if not marker.with_suffix(".planted").exists():            # once
            (tmp_path / "p.c").write_text(PLANTED % marker)
            plant = tmp_path / "p.so"
            subprocess.run([extension.compiler(), "-shared", "-fPIC", "-o", str(plant),
                            str(tmp_path / "p.c")], check=True)
            data = plant.read_bytes()
            record = path.with_name(path.name + ".sha256")
            record.write_text(f"{len(data)} {hashlib.sha256(data).hexdigest()}\n")
            plant.chmod(0o666)                                     # others could write it
            _as_someone_elses(plant, monkeypatch)
            os.replace(plant, path)
            marker.with_suffix(".planted").touch()
        return path

    monkeypatch.setattr(extension, "build", build_then_swap)
    mod = load(rendered)
    assert not marker.exists(), "the planted library's constructor ran"
    assert hasattr(mod.lib, "swapped_rhs")


# --- 2. The output lock never follows a link
def test_the_output_lock_does_not_follow_a_link(tmp_path):
    (tmp_path / "elsewhere").mkdir()
    victim = tmp_path / "elsewhere" / "victim"
    (tmp_path / ".out.lock").symlink_to(victim)
    with pytest.raises(OutputPathError, match=r"\.out\.lock.*link"):
        fileio.write_generated(tmp_path / "out", {"a.c": "int a;\n"})
    assert not victim.exists()


# --- 3. Every flag that reaches the compiler is in the cache key; fast math is refused
def test_cflags_are_in_the_cache_key_and_fast_math_is_refused(monkeypatch):
    rendered = run(pendulum("flags"), build=False).rendered
    monkeypatch.delenv("CFLAGS", raising=False)
    plain = module_name(rendered)
    monkeypatch.setenv("CFLAGS", "-DMBGEN_SOME_FLAG=1")
    assert module_name(rendered) != plain
    monkeypatch.setenv("CFLAGS", "-O2 -ffast-math")
    with pytest.raises(BuildError, match=r"CFLAGS.*-ffast-math.*NaN"):
        module_name(rendered)


# --- 4. Quotes in $CFLAGS, an output folder that is a mount point, a long folder name
def test_an_unbalanced_quote_in_cflags_is_a_named_error(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CFLAGS", "-DNAME='x")
    with pytest.raises(BuildError, match=r"CFLAGS.*quotation"):
        build(run(pendulum("quote"), build=False).rendered)


def test_an_output_folder_that_cannot_be_renamed_is_generated_into(tmp_path, monkeypatch):
    """A mount point (a Docker volume, a tmpfs) cannot be renamed: EBUSY, simulated here."""
    out = tmp_path / "out"
    out.mkdir()
    real_rename = os.rename

    def busy(fn):
        def call(a, b, *rest):
            if str(out) in (os.fsdecode(a), os.fsdecode(b)):
                raise OSError(errno.EBUSY, os.strerror(errno.EBUSY), str(out))
            return fn(a, b, *rest)
        return call

    monkeypatch.setattr(os, "rename", busy(real_rename))
    monkeypatch.setattr(fileio.generations, "_exchange", busy(lambda a, b: False))
    fileio.write_generated(out, {"a.c": "int a;\n"})
    fileio.write_generated(out, {"a.c": "int a2;\n"})
    assert (out / "a.c").read_text() == "int a2;\n"
    assert sorted(os.listdir(out)) == [fileio.MANIFEST, "a.c"]


def test_a_long_legal_folder_name_is_generated_into(tmp_path):
    out = tmp_path / ("x" * 250)
    fileio.write_generated(out, {"a.c": "int a;\n"})
    fileio.write_generated(out, {"a.c": "int a2;\n"})
    assert (out / "a.c").read_text() == "int a2;\n"
    assert sorted(os.listdir(tmp_path)) == [out.name]


# --- 13. A killed generation leaves nothing that the next run keeps
KILLED = textwrap.dedent("""
    import os, signal, sys
    from mbgen import fileio
    unlinks = []
    def unlink(*args, **kwargs):
        unlinks.append(args)
        if len(unlinks) == 2:                    # the old folder's manifest is gone
            os.kill(os.getpid(), signal.SIGKILL)
        return real(*args, **kwargs)
    real, os.unlink = os.unlink, unlink
    fileio.write_generated(sys.argv[1], {f"f{i}.c": f"int two{i};\\n" for i in range(3)})
""")


def test_a_generation_killed_while_discarding_leaves_no_stale_folder(tmp_path):
    out = tmp_path / "out"
    fileio.write_generated(out, {f"f{i}.c": f"int one{i};\n" for i in range(3)})
    proc = subprocess.run([sys.executable, "-c", KILLED, str(out)], capture_output=True)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    done = fileio.write_generated(out, {f"f{i}.c": f"int three{i};\n" for i in range(3)})
    assert not [line for line in done.remarks() if "kept" in line], done.remarks()
    assert sorted(os.listdir(tmp_path)) == ["out"]
    assert json.loads((out / fileio.MANIFEST).read_text())["files"].keys() == {
        "f0.c", "f1.c", "f2.c"}


# ==================== Issue 28: URDF files and floating bases (5-7, 10)

INERTIAL = ('<inertial><origin xyz="{xyz}"/><mass value="1"/>'
            '<inertia ixx="0.02" iyy="0.03" izz="0.025"/></inertial>')


def robot(links: dict, joints: list) -> str:
    """``links``: name -> mass centre (None: massless); ``joints``: (name, type, parent,
    child, origin xyz, axis)."""
    text = [f'<link name="{n}">{INERTIAL.format(xyz=c) if c else ""}</link>'
            for n, c in links.items()]
    text += [f'<joint name="{n}" type="{k}"><parent link="{p}"/><child link="{c}"/>'
             f'<origin xyz="{o}"/><axis xyz="{a}"/></joint>' for n, k, p, c, o, a in joints]
    return '<robot name="r">' + "".join(text) + "</robot>"


def write_urdf(tmp_path, text, name="robot.urdf"):
    (tmp_path / name).write_text(text)
    return tmp_path / name


# --- 5. A path that is not a regular file: named for what it is, never read, no hang
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_urdf_path_that_is_a_named_pipe_is_refused_at_once(tmp_path, capsys):
    fifo = tmp_path / "robot.urdf"
    os.mkfifo(fifo)
    caught = [read_in_thread(mbgen.from_urdf, fifo)]
    assert isinstance(caught[0], UrdfSyntaxError) and "named pipe" in str(caught[0])
    assert main(["check", str(fifo)]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert "is a named pipe (FIFO), not a file" in err and "does not exist" not in err


# --- 6. Reading is linear in the links
def test_reading_a_chain_looks_at_each_joint_a_few_times(monkeypatch):
    Counted = count_joint_parent_reads(monkeypatch)
    n = 1000
    text = robot({f"l{i}": "0 0 0.05" for i in range(n)},
                 [(f"j{i}", "revolute", f"l{i - 1}", f"l{i}", "0 0 0.1", "0 1 0")
                  for i in range(1, n)])
    with allow_large_models():                      # past the size guard, to be read
        urdf_xml.parse_urdf(text)
    assert Counted.reads <= 4 * n, Counted.reads    # was 1,500,500: once per link and joint


# --- 7. Numbers read from a file: scale-safe axes, overflowing values refused by name
def test_a_huge_axis_keeps_its_direction_and_a_huge_offset_is_refused(tmp_path):
    links = {"base": "0 0 0", "arm": "0.3 0 0"}
    text = robot(links, [("j", "revolute", "base", "arm", "0 0 0", "1e200 0 0")])
    assert urdf_xml.parse_urdf(text).joints["arm"].axis == (1.0, 0.0, 0.0)   # was (0, 0, 0)
    text = robot(links, [("j", "revolute", "base", "arm", "0 0 1e300", "1 0 0")])
    with pytest.raises(UrdfSyntaxError, match="joint 'j'.*<origin> xyz"):
        mbgen.from_urdf(write_urdf(tmp_path, text))


# --- 10. A floating root whose motion moves no mass is refused when the file is read
def test_a_massless_floating_root_on_one_joint_is_refused(tmp_path):
    text = robot({"trunk": None, "leg": "0 0 -0.1"},
                 [("hip", "revolute", "trunk", "leg", "0.1 0 0", "0 1 0")])
    with pytest.raises(UrdfInertiaError, match="floating root link 'trunk'"):
        mbgen.from_urdf(write_urdf(tmp_path, text), floating=True)


# --- fault: a joint axis along a negative coordinate axis turns the joint the other way
def test_an_axis_along_minus_z_turns_the_child_the_other_way(tmp_path):
    text = robot({"base": "0 0 0", "arm": "0.3 0 0"},
                 [("j", "revolute", "base", "arm", "0 0 0", "0 0 -1")])
    model = mbgen.from_urdf(write_urdf(tmp_path, text))
    q, = model.coordinates_
    centre = model.bodies[0].center.pos_from(model.origin).to_matrix(model.N).subs(q, 0.5)
    np.testing.assert_allclose(np.array(centre, dtype=float).ravel(),
                               [0.3 * np.cos(0.5), -0.3 * np.sin(0.5), 0.0], atol=1e-15)


# ==================== Issue 28: MJCF files (5, 7-10)

def _mujoco():
    return pytest.importorskip("mujoco", reason="MuJoCo is in the test extra")


ONE_BODY = """<mujoco model="one"><worldbody><body name="b" pos="0 0 1">
<joint name="j" {joint}/><geom type="sphere" size="0.1"/></body></worldbody></mujoco>"""


def write_mjcf(tmp_path, text, name="robot.xml"):
    (tmp_path / name).write_text(text)
    return tmp_path / name


# --- 5. A path that is not a regular file: named for what it is, never opened, no hang
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_an_mjcf_path_that_is_a_named_pipe_is_refused_by_its_kind(tmp_path):
    _mujoco()
    pipe = tmp_path / "robot.xml"
    os.mkfifo(pipe)

    def feed():          # code that opens the pipe reads a model and fails, not hangs
        try:
            with open(pipe, "w", encoding="utf-8") as f:
                f.write(ONE_BODY.format(joint=""))
        except OSError:
            pass
    writer = threading.Thread(target=feed, daemon=True)
    writer.start()
    try:
        with pytest.raises(MjcfError, match=r"robot\.xml' is a named pipe \(FIFO\)"):
            mbgen.from_mjcf(pipe)
    finally:
        fd = os.open(pipe, os.O_RDONLY | os.O_NONBLOCK)     # lets the writer go
        writer.join()
        os.close(fd)


# --- 7. An axis whose square overflows: refused, never a joint about another axis
def test_an_mjcf_axis_of_1e200_is_refused_not_turned_about_another_axis(tmp_path, monkeypatch):
    mujoco = _mujoco()
    monkeypatch.chdir(tmp_path)                   # MuJoCo's warning log goes there
    text = ONE_BODY.format(joint='axis="1e200 0 0"')
    with pytest.raises(MjcfError, match=r"<joint name='j'> axis=\"1e200 0 0\""):
        mbgen.from_mjcf(write_mjcf(tmp_path, text))
    with pytest.raises(MjcfError, match=r"joint 'j': jnt_axis is \[0.0, 0.0, 0.0\]"):
        mbgen.from_mujoco(mujoco.MjModel.from_xml_string(text))


# --- 8. NaN in the file: MjcfError naming the element and attribute
def test_an_mjcf_nan_damping_is_named_by_element_and_attribute(tmp_path):
    _mujoco()
    with pytest.raises(MjcfError, match=r"line 2: <joint name='j'> damping=\"nan\""):
        mbgen.from_mjcf(write_mjcf(tmp_path, ONE_BODY.format(joint='damping="nan"')))


# --- 9. 300 bytes that replicate a body 10^9 times: refused before MuJoCo compiles
def test_an_mjcf_replicate_bomb_is_refused_before_compiling(tmp_path, monkeypatch):
    mujoco = _mujoco()
    def compiled(*_args, **_kwargs):
        raise AssertionError("the file went to MuJoCo's compiler (no answer after 90 s)")
    monkeypatch.setattr(mujoco.MjModel, "from_xml_path", staticmethod(compiled))
    bomb = ('<mujoco><worldbody><replicate count="1000" offset="1 0 0">'
            '<replicate count="1000" offset="0 1 0"><replicate count="1000" offset="0 0 1">'
            '<body><joint/><geom size="0.1"/></body></replicate></replicate></replicate>'
            '</worldbody></mujoco>')
    with pytest.raises(MjcfError, match=r"bomb\.xml.*would make at least [0-9]{6,} elements"):
        mbgen.from_mjcf(write_mjcf(tmp_path, bomb, "bomb.xml"))


# --- 10. A free body that moves no mass whichever way it moves: refused when read
def test_a_compiled_model_with_a_massless_free_body_is_refused():
    mujoco = _mujoco()
    mj = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body name='trunk'><freejoint name='root'/><geom size='0.1'/>"
        "<body name='leg' pos='0 0 -0.3'><joint name='hip' axis='0 1 0'/>"
        "<geom type='capsule' fromto='0 0 0 0 0 -0.4' size='0.05'/></body></body>"
        "</worldbody></mujoco>")
    mj.body_mass[1], mj.body_inertia[1] = 0.0, 0.0
    with pytest.raises(MjcfError, match="singular at every state"):
        mbgen.from_mujoco(mj)


# ==================== Issue 28: ensembles, the step API, constraints (11, 12, 14)

# --- 11. An ensemble on workers that keep dying waits a bounded time
def _add(shared, i):
    return shared + i


def test_a_cluster_whose_workers_keep_dying_is_given_up_on():
    """Waited for ever (workers crashing as they start fail no task); now past max_restarts
    deaths with no chunk finishing the unfinished chunk is abandoned, the rest kept."""
    pytest.importorskip("dask.distributed", reason="dask[distributed] is in the test extra")
    client = fake_dask.DyingClient(hangs=lambda args: args[0] == 1)
    results, _, _ = cluster.run_chunks(_add, 10, [(0,), (1,), (2,)], client=client,
                                       patience=cluster.Patience(poll=0.01))
    assert results[0] == 10 and results[2] == 12 and client.hung[0].cancelled
    assert isinstance(results[1], cluster.Abandoned) and "workers keep dying" in str(results[1])


# --- 12. The step API's numbers of the wrong type
@pytest.mark.parametrize("name, value", [("t0", "5"), ("rtol", None), ("atol", 1j),
                                         ("h", "0.01")])
def test_stepper_numbers_of_the_wrong_type_are_named(name, value):
    """None and complex gave raw TypeErrors, '0.01' and '5' were silently parsed."""
    scene = load_scene("disc_pendulum")
    model = mbgen.compile(scene, ("rhs", "dopri5"), targets=Targets(step=True))
    kw = {"t0": 0.0, "rtol": 1e-6, "atol": 1e-9, "h": 0.01, name: value}
    with pytest.raises(ArgumentTypeError, match=f"^{name} must be a real number"):
        Stepper(model, "dopri5", kw["t0"], scene.x0(model.layout), rtol=kw["rtol"],
                atol=kw["atol"]).step(kw["h"])


# --- 14. A start off the loop is judged in the constraint's units, not the angles'
def test_a_four_bar_start_with_huge_angles_off_the_loop_is_refused():
    """Dependent angles of ~1e13 rad made the start tolerance 1e5: a loop open by 2.9 was
    integrated.  Now it is refused, and consistent() closes it to the rounding floor."""
    scene = load_scene("four_bar")
    model = mbgen.compile(scene, ("rhs", "holonomic", "holonomic_jacobian", "dopri5"))
    x = scene.x0(model.layout)
    x[1:3] = 1e13, -7e12
    with pytest.raises(ConstraintError, match="violates the configuration constraints"):
        model.integrate("dopri5", [0.0, 0.5], x)
    assert np.max(np.abs(model.holonomic(0.0, model.consistent(x)))) < 0.05
