"""A split source compiled as several translation units (mbgen.build.units): each part once,
the library's numbers bit for bit those of the one unit, the parts not exported."""

import ctypes
import re

import cffi
import numpy as np
import pytest

from mbgen.build import extension, units
from mbgen.codegen import split
from mbgen.errors import BuildError
from mbgen.model.scene import load_scene
from mbgen.pipeline import run

OUTPUTS = ("rhs", "jacobian")
DEFINED = re.compile(r"^(?:MBGEN_PART|static) (?:int|void) (\w+_part\d+)\([^)]*\)\n\{", re.M)


@pytest.fixture(scope="module")
def rendered():
    """The 3-link arm's RHS and Jacobian, cut into parts of 400 characters."""
    mp = pytest.MonkeyPatch()
    mp.setattr(split, "SPLIT_CHARS", 400)
    mp.setattr(split, "PART_CHARS", 400)
    try:
        return run(load_scene("spatial_arm", n=3), OUTPUTS, build=False).rendered
    finally:
        mp.undo()


def test_each_part_is_defined_once_and_the_moved_ones_declared(rendered):
    source = rendered.files[f"{rendered.prefix}.c"]
    names = DEFINED.findall(source)
    assert len(names) > 8
    texts = units.units(source, 2)
    assert 2 < len(texts) <= 2 * units.UNITS_PER_JOB
    defined = [n for t in texts for n in DEFINED.findall(t)]
    assert sorted(defined) == sorted(names)
    moved = [n for t in texts[1:] for n in DEFINED.findall(t)]
    assert moved
    declared = re.findall(r"^MBGEN_PART (?:int|void) (\w+)\([^)]*\);$", texts[0], re.M)
    assert sorted(declared) == sorted(moved)
    assert all("static" not in t for t in texts[1:])


def test_a_source_without_parts_or_cores_stays_one_unit(rendered):
    source = rendered.files[f"{rendered.prefix}.c"]
    assert units.units(source, 1) == [source]
    whole = run(load_scene("spatial_arm", n=2), ("rhs",), build=False).rendered
    assert units.units(whole.files[f"{whole.prefix}.c"], 8) == [whole.files[f"{whole.prefix}.c"]]


def _library(rendered, folder, jobs, monkeypatch):
    monkeypatch.setenv("MBGEN_BUILD_JOBS", str(jobs))
    folder.mkdir()
    path = extension._compile(rendered, "_mbgen_units_test", folder, False)
    ffi = cffi.FFI()
    ffi.cdef(rendered.cdef)
    return ffi, ffi.dlopen(str(path)), path


def test_the_units_give_the_numbers_of_one_unit_and_keep_the_parts_private(
        rendered, tmp_path, monkeypatch):
    one = _library(rendered, tmp_path / "one", 1, monkeypatch)
    many = _library(rendered, tmp_path / "many", 3, monkeypatch)
    assert len(list((tmp_path / "many").glob("*.o"))) > 2
    assert not list((tmp_path / "one").glob("*.o"))
    L = rendered.layout
    p = np.array([rendered.defaults[k] for k in L.parameter_names])
    rng = np.random.default_rng(11)
    for _ in range(3):
        x = rng.uniform(-1, 1, L.n_x)
        got = []
        for ffi, lib, _ in (one, many):
            rhs, jac = np.zeros(L.n_x), np.zeros(L.n_x * L.n_x)
            buf = ffi.from_buffer
            assert getattr(lib, f"{rendered.prefix}_rhs")(
                0.0, buf("double[]", x), buf("double[]", p), buf("double[]", rhs)) == 0
            assert getattr(lib, f"{rendered.prefix}_jacobian")(
                0.0, buf("double[]", x), buf("double[]", p), buf("double[]", jac)) == 0
            got.append((rhs, jac))
        for a, b in zip(*got):
            np.testing.assert_array_equal(a, b)
    exported = ctypes.CDLL(str(many[2]))
    getattr(exported, f"{rendered.prefix}_rhs")
    with pytest.raises(AttributeError):
        getattr(exported, DEFINED.findall(rendered.files[f"{rendered.prefix}.c"])[-1])


@pytest.mark.parametrize("given", ["0", "two", "-1"])
def test_a_bad_job_count_is_named(given, monkeypatch):
    monkeypatch.setenv("MBGEN_BUILD_JOBS", given)
    with pytest.raises(BuildError, match="MBGEN_BUILD_JOBS.*whole number"):
        units.build_jobs()
    monkeypatch.delenv("MBGEN_BUILD_JOBS")
    assert units.build_jobs() >= 1


def test_meanwhile_runs_while_the_compilers_do_and_a_failure_is_named(tmp_path):
    """``meanwhile`` (cffi's parse in a build) runs once, in this thread, and a compiler that
    fails still raises a BuildError with the model's name."""
    seen = []
    out = units.run_compilers([["sh", "-c", "sleep 0.2; echo done"]], tmp_path, "m", "arm",
                              meanwhile=lambda: seen.append(1))
    assert seen == [1] and out == "done"
    with pytest.raises(BuildError, match="compiling model 'arm' failed.*status 3"):
        units.run_compilers([["sh", "-c", "exit 3"], ["true"]], tmp_path, "m", "arm", jobs=1,
                            meanwhile=lambda: None)
