"""Ensembles: members built reproducibly, a LocalCluster of two worker processes gives the
serial results bit for bit, failures are recorded and never fatal, each worker compiles once."""

import functools
import os

import numpy as np
import pytest

import fake_dask
import mbgen
from mbgen.cli import main
from mbgen.errors import ArgumentError, MbgenError, SceneError
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.studies import ensemble as ensemble_module
from mbgen.studies.cluster import Patience
from mbgen.studies.ensemble import ensemble, members, run_chunk

distributed = pytest.importorskip("dask.distributed",
                                  reason="dask[distributed] is in the test extra")


@pytest.fixture(scope="module")
def cluster():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
    yield cluster
    cluster.close()


@pytest.fixture(scope="module")
def client(cluster):
    c = distributed.Client(cluster)
    yield c
    c.close()


def _private_cache():
    """Run on a worker: a cache folder of its own (no shared file system)."""
    import os
    import tempfile

    os.environ["MBGEN_CACHE_DIR"] = tempfile.mkdtemp(prefix="mbgen-worker-cache-")
    return os.environ["MBGEN_CACHE_DIR"]


def test_each_worker_compiles_once_into_its_own_cache(cluster, client):
    folders = client.run(_private_cache)
    assert len(set(folders.values())) == 2
    scene = load_scene("paraboloid")
    first = ensemble(scene, samples={"k": ("uniform", 0.2, 0.8)}, n=40, chunk=5,
                     client=client, progress=False)
    assert first.tasks == 8 and first.n_failed == 0
    assert set(first.compiles.values()) == {1}             # every worker that ran: once
    again = ensemble(scene, samples={"k": ("uniform", 0.2, 0.8)}, n=40, chunk=5,
                     address=cluster.scheduler_address, progress=False)  # by address
    assert sum(again.compiles.values()) == 0
    assert np.array_equal(first.table["final_q1"], again.table["final_q1"])


def study(**kw):
    return dict(grid={"l": [2.0, 4.0], "m": [1.0, -1.0]},          # m < 0: M not definite
                samples={"q2": ("normal", 1.0, 0.2), "s": ("uniform", 0.5, 1.5)},
                n=25, seed=7, t_end=3.0, n_out=7, progress=False, **kw)


def test_dask_gives_the_serial_results_bit_for_bit(client):
    scene = load_scene("disc_pendulum")
    serial = ensemble(scene, serial=True, trajectories=True, outputs=("energy",), **study())
    dask = ensemble(scene, client=client, chunk=9, trajectories=True, outputs=("energy",),
                    **study())
    assert dask.mode == "dask" and dask.tasks == 12 and len(dask.table) == 100
    for name in serial.table.dtype.names:
        a, b = serial.table[name], dask.table[name]
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
    # every member is there once, in order, with what was varied
    assert serial.table["member"].tolist() == list(range(100))
    assert set(serial.table["l"]) == {2.0, 4.0}
    # energy at the output times: (n_t, 2) per member, the compiled energy of each state
    model = mbgen.compile(scene, ("rhs", "energy", "dopri5"))
    row = serial.table[serial.table["status"] == 0][5]
    p = model.default_parameters.copy()
    for name in ("l", "m", "s"):
        p[model.parameter_names.index(name)] = row[name]
    assert row["energy"].shape == (7, 2)
    assert np.array_equal(row["energy"], np.array([model.energy(ti, xi, p)
                                                   for ti, xi in zip(serial.t, row["x"])]))
    assert np.all(np.isnan(serial.table[serial.table["status"] != 0]["energy"]))
    # each worker process compiled the model at most once (the cache is by content hash)
    assert all(v <= 1 for v in dask.compiles.values()) and len(dask.compiles) <= 2


def test_failed_members_are_recorded_not_fatal():
    scene = load_scene("disc_pendulum")
    res = ensemble(scene, serial=True, **study())
    bad = res.table["m"] < 0
    assert bad.sum() == 50 and res.n_failed == 50
    assert set(res.table["status"][bad]) == {1}
    assert all("NOT_POSITIVE_DEFINITE" in m for m in res.table["message"][bad])
    assert np.all(np.isnan(res.table["final_q1"][bad]))
    good = res.table[~bad]
    assert np.all(good["status"] == 0) and np.all(np.isfinite(good["final_q1"]))
    # a good member's row is a single integrate call
    model = mbgen.compile(scene)
    i = int(np.flatnonzero(~bad)[3])
    x0, p = members(scene, model.layout, **{k: study()[k] for k in ("grid", "samples", "n",
                                                                        "seed")})[2:]
    single = model.integrate("dopri5", res.t, x0[i], p[i])
    assert np.array_equal([res.table[f"final_{s}"][i] for s in model.state_names],
                          single.x[-1])
    assert "50 failed" in res.summary() and "status 1: 50 members" in res.summary()


def test_tampered_sources_and_baked_parameters_are_refused():
    scene = load_scene("disc_pendulum")
    sources = run(scene, build=False).rendered.sources()
    sources["files"] = {**sources["files"], "disc_pendulum.c": "int x;"}
    spec = dict(method="dopri5", t=[0.0, 1.0], rtol=1e-6, atol=1e-9, h0=0.0, max_steps=0,
                n_x=4, n_p=4, n_r=0, trajectories=False)
    with pytest.raises(MbgenError, match="content hash"):
        run_chunk(sources, spec, np.zeros((1, 4)), np.ones((1, 4)))
    with pytest.raises(SceneError, match="baked into the code"):
        ensemble(load_scene("bead_wire"), grid={"m": [1.0, 2.0]}, serial=True, progress=False)


def test_sweep_command_writes_the_table(tmp_path):
    csv = tmp_path / "sweep.csv"
    code = main(["sweep", "disc_pendulum", "--grid", "l=2:4:3", "--samples",
                 "q2=uniform:0.5:1.0", "-n", "2", "--serial", "--quiet", "--csv", str(csv)])
    assert code == 0
    lines = csv.read_text().splitlines()
    assert len(lines) == 7 and lines[0].startswith("member,l,q2,status,message")


# ------------------------------------------------------------------ misuse (issue 18, class 11)
@pytest.mark.parametrize("chunk", [0, -3, 2.5, "4", True])
def test_a_chunk_that_is_not_a_positive_whole_number_is_refused(chunk):
    """Today chunk=0 ran nothing and reported every member a success with 0 steps."""
    with pytest.raises(ArgumentError, match="chunk"):
        ensemble(load_scene("disc_pendulum"), grid={"l": [2.0, 3.0]}, chunk=chunk,
                 serial=True, progress=False)


#: The value of ``l`` whose chunk kills its worker in the test below.
DEADLY_L = 4.25


def test_a_chunk_that_kills_its_worker_costs_that_chunk_only(monkeypatch):
    """One chunk's task ends its worker process (``os._exit``, as a segfault would): the
    other chunks' results are kept, bit for bit the serial ones, and the dead chunk's
    members are marked failed with the reason.  Our own LocalCluster; 4 chunks of 3."""
    run_chunk_on_worker = ensemble_module.run_chunk

    def deadly_chunk(sources, spec, x0, p):  # pickled by value: it runs on the worker
        if np.any(p == DEADLY_L):
            os._exit(70)
        return run_chunk_on_worker(sources, spec, x0, p)

    scene = load_scene("disc_pendulum")
    kw = dict(grid={"l": [2.0, 3.0, DEADLY_L, 5.0]}, n=3, t_end=1.0, progress=False)
    serial = ensemble(scene, serial=True, **kw)
    monkeypatch.setattr(ensemble_module, "run_chunk", deadly_chunk)
    res = ensemble(scene, chunk=3, n_workers=2, **kw)
    dead = res.table["l"] == DEADLY_L
    assert res.tasks == 4 and dead.sum() == 3 and res.n_failed == 3, res.summary()
    assert np.all(res.table["status"][dead] == -1)
    assert all("worker" in m and "KilledWorker" in m for m in res.table["message"][dead])
    assert np.all(np.isnan(res.table["final_q1"][dead]))
    for name in ("status", "n_steps", "final_q1", "final_u2"):
        assert np.array_equal(res.table[name][~dead], serial.table[name][~dead]), name


@pytest.mark.parametrize("kw, message", [
    (dict(n_out=10**12), "n_out=1,000,000,000,000 is more than 1,000,000"),
    (dict(grid={"l": [2.0, 3.0]}, n=10**7), "20,000,000 members"),
    (dict(n=10**6, n_out=10**6, trajectories=True), "more than this machine's"),
    (dict(n=3, n_workers=0, serial=False), "n_workers=0 must be at least 1"),
])
def test_huge_counts_are_refused_before_any_work(kw, message):
    """Each of these allocated terabytes (a MemoryError) or waited for ever."""
    with pytest.raises(ArgumentError, match=message):
        ensemble(load_scene("disc_pendulum"), **{"serial": True, "progress": False, **kw})


# ------------------------------------------------------------------ issue 28: failed chunks
def test_a_serial_chunk_whose_task_raises_costs_that_chunk_only(monkeypatch):
    """In a serial ensemble a task that raises (a compiler error, a bug) marks its chunk's
    members failed with the reason; the other chunks' results are kept."""
    run_chunk_here = ensemble_module.run_chunk

    def refusing_chunk(sources, spec, x0, p):
        if np.any(p == DEADLY_L):
            raise RuntimeError("this chunk is refused")
        return run_chunk_here(sources, spec, x0, p)

    monkeypatch.setattr(ensemble_module, "run_chunk", refusing_chunk)
    res = ensemble(load_scene("disc_pendulum"), grid={"l": [2.0, DEADLY_L, 5.0]}, n=2,
                   t_end=0.5, chunk=2, serial=True, progress=False)
    bad = res.table["l"] == DEADLY_L
    assert res.tasks == 3 and bad.sum() == 2 and res.n_failed == 2
    assert set(res.table["message"][bad]) == {"task failed: RuntimeError: this chunk is refused"}
    assert np.all(res.table["status"][bad] == -1) and np.all(np.isnan(res.table["final_q1"][bad]))
    assert np.all(res.table["status"][~bad] == 0)
    assert np.all(np.isfinite(res.table["final_q1"][~bad]))


def test_an_ensemble_on_workers_that_keep_dying_returns_what_finished(monkeypatch):
    """Issue 28: on a client whose workers keep dying (a plugin that crashes them as they
    start) the ensemble waited for ever.  A fake client (tests/support/fake_dask.py) runs
    the healthy chunks and never the one of ``l = DEADLY_L``, while its workers die: past
    max_restarts that chunk's members are marked abandoned, the rest returned."""
    monkeypatch.setattr(ensemble_module, "Patience", functools.partial(Patience, poll=0.01))
    client = fake_dask.DyingClient(hangs=lambda args: np.any(args[2] == DEADLY_L))
    res = ensemble(load_scene("disc_pendulum"), grid={"l": [2.0, DEADLY_L, 5.0]}, n=2,
                   t_end=0.5, chunk=2, client=client, max_restarts=3, progress=False)
    bad = res.table["l"] == DEADLY_L
    assert res.mode == "dask" and res.n_failed == 2 and client.hung[0].cancelled
    assert set(res.table["message"][bad]) == {
        "task abandoned: workers keep dying: 4 deaths while no chunk finished (more than "
        "max_restarts=3)"}
    assert np.all(res.table["status"][~bad] == 0)
    assert np.all(np.isfinite(res.table["final_q1"][~bad]))


@pytest.mark.slow
def test_a_real_cluster_whose_workers_die_as_they_start_is_given_up_on(monkeypatch, tmp_path):
    """The real thing (10 to 20 s): a worker plugin crashes every worker that starts once
    the chunk of ``l = DEADLY_L`` has killed its worker.  The ensemble returns: that chunk's
    members and those of every chunk left unfinished are marked failed, and every member
    that finished has the serial result bit for bit.  (Before: waited for ever.)"""
    marker = tmp_path / "poisoned"

    class CrashAtStart(distributed.WorkerPlugin):  # pickled by value: it runs on the workers
        name = "crash-at-start"

        def setup(self, worker):
            if os.path.exists(marker):
                os._exit(71)

    run_chunk_on_worker = ensemble_module.run_chunk

    def poisoning_chunk(sources, spec, x0, p):
        if np.any(p == DEADLY_L):
            open(marker, "w").close()
            os._exit(70)
        return run_chunk_on_worker(sources, spec, x0, p)

    scene = load_scene("disc_pendulum")
    kw = dict(grid={"l": [2.0, 3.0, DEADLY_L, 5.0, 6.0, 7.0]}, n=3, t_end=1.0, progress=False)
    serial = ensemble(scene, serial=True, **kw)
    monkeypatch.setattr(ensemble_module, "run_chunk", poisoning_chunk)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as local, \
            distributed.Client(local) as client:
        client.register_plugin(CrashAtStart())
        res = ensemble(scene, client=client, chunk=3, **kw)
    ok = res.table["status"] == 0
    assert not np.any(ok[res.table["l"] == DEADLY_L]) and res.n_failed >= 3
    assert all(m.startswith(("task abandoned: ", "task failed: worker lost"))
               for m in res.table["message"][~ok])
    for name in ("n_steps", "final_q1", "final_u2"):
        assert np.array_equal(res.table[name][ok], serial.table[name][ok]), name
