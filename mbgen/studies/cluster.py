"""Chunks of a study on Dask: one task per chunk, each chunk's result or its failure, never a
lost result.

:func:`run_chunks` runs ``task(shared, *args)`` for every chunk's ``args`` on a Dask
``LocalCluster`` (started and closed here), a scheduler given by address, or a client the
caller holds, and returns every chunk's result or the exception that ended it.  One
chunk's failure costs that chunk only; what Dask's documentation advises for lost workers
is followed:

* ``shared`` (a study's sources) is held by a *task*, not scattered: scattered data dies
  with the workers that hold it (every task that needs it is then cancelled), a task's
  result is computed again.
* Results are taken as they complete (``as_completed``), each in its own ``try``: a
  :class:`~distributed.KilledWorker`, a ``CommClosedError`` or the task's own exception
  is that chunk's failure, and finished chunks are kept.
* Retries are bounded (:data:`RETRIES`): a chunk whose task raised runs once more
  (Dask's ``retries``), and on a ``LocalCluster`` started here a chunk whose worker died
  runs once more (the scheduler's ``allowed_failures``); its second death is a
  ``KilledWorker``.  A scheduler given by address or a client keeps its own settings
  (Dask's default lets a task kill 3 workers before it is marked failed).
* Dask blames every task a dying worker held, and a worker holds more than the one it
  runs: a chunk queued behind the guilty one can be marked ``KilledWorker`` too.  So each
  chunk lost with a worker is resubmitted once more, *alone* (one at a time, nothing of
  ours beside it): an innocent chunk then finishes, and a chunk that kills its worker
  even alone is the failure, its members marked with the reason.
* A scheduler address is tried first, within :data:`CONNECT_TIMEOUT` (the connection and
  Dask's handshake): a bad address is a :class:`~mbgen.errors.UsageError` naming it, not
  a 30 s wait or a hang on a server that is not a Dask scheduler.
"""

from __future__ import annotations

import asyncio
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Sequence

from ..errors import MissingExtraError, UsageError

#: Seconds to reach a scheduler given by address (connection and handshake).
CONNECT_TIMEOUT = 5.0
#: Extra runs of a chunk whose task raised (Dask's ``retries``), and on a LocalCluster started
#: here, of a chunk whose worker died (``allowed_failures``): each chunk runs at most twice.
RETRIES = 1


def _distributed():
    try:
        import dask
        import dask.distributed as distributed
    except ImportError:
        raise MissingExtraError("studies on Dask need dask.distributed: pip install "
                                "'mbgen[dask]' (or run them serially)") from None
    return dask, distributed


def reach(address: str) -> None:
    """Check that a Dask scheduler answers at ``address`` (a connection and Dask's handshake).

    Raises
    ------
    UsageError
        Nothing answers as a Dask scheduler at ``address`` within :data:`CONNECT_TIMEOUT`
        seconds, or ``address`` is not an address.
    """
    _, distributed = _distributed()

    async def handshake():
        comm = await distributed.comm.connect(address, timeout=CONNECT_TIMEOUT)
        await comm.close()

    try:  # in a thread of its own: the caller may be running an event loop (Jupyter)
        with ThreadPoolExecutor(1) as pool:
            pool.submit(asyncio.run, asyncio.wait_for(handshake(), CONNECT_TIMEOUT)).result()
    except (OSError, ValueError, TypeError, asyncio.TimeoutError) as exc:
        reason = str(exc) or f"no Dask handshake within {CONNECT_TIMEOUT:g} s"
        raise UsageError(f"cannot reach a Dask scheduler at {address!r} ({reason}); start one "
                         f"('dask scheduler' prints its address, tcp://HOST:8786) and pass "
                         f"that, or leave the address out to run on a LocalCluster") from None


def connect(address: str):
    """A ``dask.distributed.Client`` of the scheduler at ``address``, :func:`reach`-ed first."""
    _, distributed = _distributed()
    reach(address)
    return distributed.Client(address, timeout=CONNECT_TIMEOUT)


def lost_worker(exc: BaseException) -> bool:
    """Whether ``exc`` says the chunk's worker was lost (it died, or its connection did)."""
    try:
        _, distributed = _distributed()
    except MissingExtraError:  # no Dask: no worker to lose
        return False
    return isinstance(exc, (distributed.KilledWorker, distributed.comm.CommClosedError))


def run_chunks(task: Callable, shared: Any, chunks: Sequence[tuple], *,
               address: str | None = None, n_workers: int = 2, client: Any = None,
               done: Callable[[int], None] = lambda i: None):
    """Run ``task(shared, *chunks[i])`` for every chunk on Dask.

    Parameters
    ----------
    task : callable
        Pickled to the workers (by reference when it is a module's function).
    shared : object
        The first argument of every task (sent once, held by a task).
    chunks : sequence of tuples
        Each chunk's further arguments.
    address, n_workers, client
        A scheduler's address, else a client to use (left open), else a ``LocalCluster``
        of ``n_workers`` single-threaded processes (closed afterwards).
    done : callable
        Called with each chunk's index as it completes (a progress bar).

    Returns
    -------
    results : list
        Per chunk, the task's result or the exception that ended it.
    n_workers : int
        Workers of the cluster.
    startup : float
        Seconds spent starting the cluster or connecting.
    """
    _, distributed = _distributed()
    own_cluster = own_client = None
    t_start = time.perf_counter()
    if client is None:
        if address:
            client = own_client = connect(address)
        else:
            own_cluster = distributed.LocalCluster(
                n_workers=n_workers, threads_per_worker=1, processes=True,
                dashboard_address=None, scheduler_kwargs={"allowed_failures": RETRIES})
            client = own_client = distributed.Client(own_cluster)
    startup = time.perf_counter() - t_start
    try:
        n_used = len(client.scheduler_info().get("workers", {})) or n_workers
        held = client.submit(_hold, shared, pure=True)
        results: list = [None] * len(chunks)
        lost = []
        for i, result in _completed(client, distributed, task, held, chunks,
                                    range(len(chunks))):
            results[i] = result
            if isinstance(result, Exception) and lost_worker(result):
                lost.append(i)
            else:
                done(i)
        for i in sorted(lost):  # alone now: a worker's death implicates this chunk only
            for _, results[i] in _completed(client, distributed, task, held, chunks, [i]):
                done(i)
        return results, n_used, startup
    finally:
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()


def _completed(client, distributed, task, held, chunks, indices):
    """``(i, result or exception)`` of the chunks ``indices``, in the order they complete."""
    futures = {client.submit(task, held, *chunks[i], pure=False, retries=RETRIES): i
               for i in indices}
    for future in distributed.as_completed(list(futures)):
        i = futures.pop(future)
        try:
            yield i, future.result()
        except Exception as exc:  # that chunk's failure; the others go on
            yield i, exc


def _hold(value):
    """A task returning ``value``: data Dask can compute again when a worker holding it dies."""
    return value


__all__ = ["CONNECT_TIMEOUT", "RETRIES", "connect", "lost_worker", "reach", "run_chunks"]
