"""Replays each misuse class of the hardening issue: one quick test per class, the way it was
found to fail (issue 18); the thorough tests are in each area's own test files.
"""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pytest

import mbgen
from mbgen.abi import Output
from mbgen.cli import EXIT_USAGE, main
from mbgen.errors import ArgumentError
from mbgen.model.scene import load_scene
from mbgen.studies import cluster
from mbgen.verify.check import CheckReport, check, compare, reference_model


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
