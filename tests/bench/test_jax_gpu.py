"""The JAX-on-a-GPU benchmark on the CPU, with a small arm and small batches: ``prepare``
writes files that agree with MuJoCo's C, ``run`` fills every cell it times and checks it
against the C (a wrong reference fails the run), and the file runs without mbgen (as it must
on the GPU machine).  Nothing timed is asserted; the GPU run itself is not a test."""

from __future__ import annotations

import csv
import json
import math
import runpy
import sys

import numpy as np
import pytest

pytest.importorskip("jax")
pytest.importorskip("mujoco")

from mbgen.bench import jax_gpu  # noqa: E402
from mbgen.errors import BenchmarkError  # noqa: E402

SMALL = {"batches": (1, 3), "jacobian_batches": (2,), "repeats": 1, "min_time": 0.0}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("gpubench")
    jax_gpu.prepare(out, robots=("arm",), arm_n=2, samples=3)
    return out


def test_prepare_writes_one_robot_twice(folder):
    [entry] = json.loads((folder / jax_gpu.MANIFEST).read_text())
    assert entry["name"] == "arm2" and entry["n"] == 2
    assert entry["mujoco_vs_c"] <= jax_gpu.PREPARE_RTOL
    for key in ("module", "mjb", "source", "ref"):
        assert (folder / entry[key]).is_file()
    text = (folder / entry["module"]).read_text()
    assert "import jax.numpy as jnp" in text and "mbgen" not in text.split('"""')[2]
    ref = np.load(folder / entry["ref"])
    assert ref["X"].shape == (3, 4) and ref["jacobian"].shape == (3, 4, 4)


def test_an_unknown_robot_is_named(tmp_path):
    with pytest.raises(BenchmarkError, match="no robot 'panda'"):
        jax_gpu.prepare(tmp_path, robots=("panda",))


def test_mbgen_cells_agree_with_the_c_in_both_precisions(folder, tmp_path):
    rows = jax_gpu.bench(folder, ways=("mbgen",), **SMALL)
    assert [(r.kind, r.dtype, r.batch) for r in rows] == [
        ("rhs", "float64", 1), ("rhs", "float64", 3), ("rhs", "float32", 1),
        ("rhs", "float32", 3), ("jacobian", "float64", 2), ("jacobian", "float32", 2)]
    for r in rows:
        assert not r.note and r.repeats == 1 and r.ns_per_state > 0 and r.compile_s > 0
        assert r.fusions >= 1
        assert r.max_rel_err <= (1e-12 if r.dtype == "float64" else 1e-4), r
    path = tmp_path / "out.csv"
    jax_gpu.write_csv(rows, path, jax_gpu.environment())
    read = list(csv.DictReader(path.open()))
    assert len(read) == 6 and float(read[1]["ns_per_state"]) == rows[1].ns_per_state
    assert json.loads((tmp_path / "out.csv.json").read_text())["device"].startswith("cpu")
    assert "states/s" in jax_gpu.format_table(rows)


def test_a_wrong_reference_fails_the_run_after_its_rows(folder, tmp_path):
    bad = tmp_path / "bad"
    bad.mkdir()
    for f in folder.iterdir():
        (bad / f.name).write_bytes(f.read_bytes())
    [entry] = json.loads((bad / jax_gpu.MANIFEST).read_text())
    ref = dict(np.load(bad / entry["ref"]))
    ref["dxdt"] = ref["dxdt"] * 1.001
    np.savez(bad / entry["ref"], **ref)
    with pytest.raises(BenchmarkError, match="disagree with mbgen's C") as info:
        jax_gpu.bench(bad, dtypes=("float64",), kinds=("rhs",), ways=("mbgen",), **SMALL)
    assert len(info.value.rows) == 2


def test_an_unprepared_folder_is_named(tmp_path):
    with pytest.raises(BenchmarkError, match="prepare"):
        jax_gpu.bench(tmp_path)


def test_the_file_runs_without_mbgen(folder, tmp_path, monkeypatch):
    """As on the GPU machine: run as a plain file, every ``import mbgen...`` fails."""
    monkeypatch.setitem(sys.modules, "mbgen", None)
    path = tmp_path / "out.csv"
    args = ["run", str(folder), "--csv", str(path), "--ways", "mbgen", "--kinds", "rhs",
            "--dtypes", "float64", "--batches", "2", "--repeats", "1", "--min-time", "0"]
    monkeypatch.setattr(sys, "argv", ["jax_gpu.py", *args])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(jax_gpu.__file__, run_name="__main__")
    assert done.value.code == 0
    [row] = list(csv.DictReader(path.open()))
    assert row["way"] == "mbgen" and float(row["max_rel_err"]) <= 1e-12


@pytest.mark.slow
def test_mjx_cells_agree_with_the_c(folder):
    rows = jax_gpu.bench(folder, ways=("mjx",), **SMALL)
    assert len(rows) == 6
    for r in rows:
        assert not r.note and not math.isnan(r.ns_per_state)
        assert r.max_rel_err <= (1e-9 if r.dtype == "float64" else 1e-4), r
