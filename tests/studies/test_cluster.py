"""Chunks on Dask: a bad scheduler address is refused within the connect timeout, a chunk
that raises runs exactly twice and costs that chunk only (the worker deaths are in
tests/studies/test_ensemble.py)."""

import os
import socket
import threading

import pytest

from mbgen.errors import UsageError
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
