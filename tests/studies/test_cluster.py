"""Chunks on Dask: a bad scheduler address is refused within the connect timeout, a chunk
that raises runs exactly twice and costs that chunk only, the wait on a cluster whose
workers keep dying or stall is bounded (a fake client: tests/support/fake_dask.py; the
worker deaths on a real cluster are in tests/studies/test_ensemble.py)."""

import os
import socket
import threading

import pytest

import fake_dask
from mbgen.errors import ArgumentError, UsageError
from mbgen.studies import cluster

pytest.importorskip("dask.distributed", reason="dask[distributed] is in the test extra")


@pytest.fixture
def silent_server():
    """A TCP server that accepts connections and never answers (not a Dask scheduler)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    held = []
    stop = threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except OSError:
                pass

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join()
    for conn in held:
        conn.close()
    server.close()


def test_a_server_that_is_not_a_dask_scheduler_is_refused_not_waited_on(silent_server,
                                                                         monkeypatch):
    """Dask's own client waits for ever on a server that accepts and never answers its
    handshake (its connect timeout covers the connection only)."""
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 0.5)
    with pytest.raises(UsageError, match="cannot reach a Dask scheduler .*no Dask handshake"):
        cluster.connect(silent_server)


def _attempt(shared, i, log):
    """A chunk: records the attempt, raises for chunk 1."""
    with open(os.path.join(log, f"chunk{i}"), "a") as f:
        f.write("ran\n")
    if i == 1:
        raise ValueError("chunk 1 is bad")
    return shared + i


def test_a_chunk_that_raises_runs_twice_and_costs_that_chunk_only(tmp_path):
    done = []
    results, n_workers, _ = cluster.run_chunks(_attempt, 10, [(i, str(tmp_path))
                                                              for i in range(4)],
                                               n_workers=2, done=done.append)
    assert n_workers == 2 and sorted(done) == [0, 1, 2, 3]
    assert results[0] == 10 and results[2] == 12 and results[3] == 13
    assert isinstance(results[1], ValueError) and "chunk 1 is bad" in str(results[1])
    runs = {i: (tmp_path / f"chunk{i}").read_text().count("ran") for i in range(4)}
    assert runs == {0: 1, 1: 1 + cluster.RETRIES, 2: 1, 3: 1}


# ------------------------------------------------------------------ issue 28: bounded waits
def _add(shared, i):
    return shared + i


FAST = dict(poll=0.01)                          # the bounds checked every 10 ms, not 0.5 s


def test_workers_that_keep_dying_cost_the_unfinished_chunks_only():
    """Workers that die as they start fail no task, and the wait for chunk 2 was endless.
    Now more than max_restarts (4 per worker: 8) deaths with no chunk finishing abandon
    it (its future cancelled); the finished chunks are kept and every chunk is reported."""
    client = fake_dask.DyingClient(hangs=lambda args: args[0] == 2)
    done = []
    results, n_workers, _ = cluster.run_chunks(_add, 10, [(i,) for i in range(4)],
                                               client=client, done=done.append,
                                               patience=cluster.Patience(**FAST))
    assert n_workers == 2 and sorted(done) == [0, 1, 2, 3]
    assert results[0] == 10 and results[1] == 11 and results[3] == 13
    assert isinstance(results[2], cluster.Abandoned)
    assert str(results[2]) == ("workers keep dying: 9 deaths while no chunk finished (more "
                               "than max_restarts=8)")
    assert client.hung[0].cancelled


@pytest.mark.parametrize("client, patience, says", [
    (fake_dask.DyingClient(lambda args: True, deaths_per_look=0), dict(timeout=0.05),
     "no chunk finished within chunk_timeout=0.05 s"),
    (fake_dask.DyingClient(lambda args: True, n_workers=0, deaths_per_look=0),
     dict(no_workers=0.05), "no worker for 0.05 s"),
], ids=["hung", "no worker"])
def test_a_stalled_cluster_is_given_up_on_after_the_timeout(client, patience, says):
    """No deaths to count: a chunk that never finishes, and a cluster with no worker left
    (a nanny that stopped restarting), end at their timeouts."""
    results, _, _ = cluster.run_chunks(_add, 10, [(0,), (1,)], client=client,
                                       patience=cluster.Patience(**FAST, **patience))
    assert all(isinstance(r, cluster.Abandoned) and str(r).startswith(says) for r in results)


def test_deaths_count_from_the_last_chunk_that_finished():
    """Workers dying while chunks still finish is a cluster at work (a chunk that kills its
    worker, Dask retrying it): 12 deaths in all, never more than 3 between two chunks
    finishing, with max_restarts=4, abandon nothing."""
    client = fake_dask.DyingClient(hangs=lambda args: True, release_every=3)
    results, _, _ = cluster.run_chunks(_add, 10, [(i,) for i in range(4)], client=client,
                                       patience=cluster.Patience(restarts=4, **FAST))
    assert results == [10, 11, 12, 13] and client.deaths >= 12


@pytest.mark.parametrize("kw, error", [
    (dict(timeout=0.0), "chunk_timeout must be a number of seconds > 0"),
    (dict(timeout="60"), "chunk_timeout must be a real number"),
    (dict(restarts=-1), "max_restarts=-1 must be at least 0"),
    (dict(restarts=2.0), "max_restarts must be a whole number"),
    (dict(poll=float("inf")), "poll must be a number of seconds > 0; got inf"),
])
def test_bounds_that_are_not_numbers_of_the_right_kind_are_refused(kw, error):
    with pytest.raises(ArgumentError, match=error):
        cluster.Patience(**kw)
