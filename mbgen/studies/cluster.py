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
* Results are taken as they complete (each future's done callback), each in its own
  ``try``: a :class:`~distributed.KilledWorker`, a ``CommClosedError`` or the task's own
  exception is that chunk's failure, and finished chunks are kept.
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
* The wait is bounded (:class:`Patience`).  Dask counts a worker's death against the
  tasks it was running, so a worker that dies *before* it runs anything (a plugin or
  start-up that crashes it, its nanny restarting it for ever) fails no task, and
  ``as_completed`` waited for ever.  Here the study gives up on every unfinished chunk
  (:class:`Abandoned`, their members marked failed; finished chunks are kept) when

  - no chunk has finished for ``chunk_timeout`` seconds (:data:`CHUNK_TIMEOUT`): the
    per-chunk timeout, counted from the last chunk that finished (or the start), so
    chunks queued behind others are not charged for their wait, or
  - more than ``max_restarts`` workers have died (the scheduler's ``remove-worker``
    events) since the last chunk finished: by default :data:`RESTARTS_PER_WORKER` per
    worker, enough for Dask's default ``allowed_failures`` (3: the 4th death a task
    causes marks it failed) on every worker at once, so a chunk that kills its worker
    still ends as that chunk's ``KilledWorker``.

  - the scheduler has had no worker at all for :data:`NO_WORKER_TIMEOUT` seconds (the
    nanny of a worker that dies as it starts may stop restarting it).

  These are checked every :data:`POLL` seconds while nothing finishes.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import math
import queue
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

from ..errors import ArgumentError, MbgenError, MissingExtraError, UsageError
from ..runtime.arguments import real_number, whole_number

#: Seconds to reach a scheduler given by address (connection and handshake).
CONNECT_TIMEOUT = 5.0
#: Extra runs of a chunk whose task raised (Dask's ``retries``), and on a LocalCluster started
#: here, of a chunk whose worker died (``allowed_failures``): each chunk runs at most twice.
RETRIES = 1
#: Seconds a study waits for the next chunk to finish before it abandons every unfinished
#: chunk (the per-chunk timeout, ``chunk_timeout``; ``math.inf``: no limit).
CHUNK_TIMEOUT = 3600.0
#: Worker deaths per worker of the cluster tolerated while no chunk finishes (``max_restarts``
#: is this times the workers, at least one, found at the start).
RESTARTS_PER_WORKER = 4
#: Seconds a study waits while the scheduler has no worker at all (a crash at start that
#: its nanny stops restarting leaves none, and no death is logged any more).
NO_WORKER_TIMEOUT = 60.0
#: Seconds between checks of those bounds while nothing finishes.
POLL = 0.5


class Abandoned(MbgenError, TimeoutError):
    """A chunk given up on: no chunk finished within the timeout, workers kept dying, or
    none was left."""


@dataclass(frozen=True)
class Patience:
    """How long a study waits: ``timeout`` seconds without a chunk finishing, ``restarts``
    worker deaths without a chunk finishing (None: :data:`RESTARTS_PER_WORKER` per worker),
    ``no_workers`` seconds without a worker at all; checked every ``poll`` seconds."""

    timeout: float = CHUNK_TIMEOUT
    restarts: int | None = None
    no_workers: float = NO_WORKER_TIMEOUT
    poll: float = POLL

    def __post_init__(self):
        for name, what in (("timeout", "chunk_timeout"), ("no_workers", "no_workers"),
                           ("poll", "poll")):
            value = real_number(getattr(self, name), what)
            if not (value > 0 and (name != "poll" or value < math.inf)):
                raise ArgumentError(f"{what} must be a number of seconds > 0"
                                    f"{'' if name == 'poll' else ' (math.inf: no limit)'}; got "
                                    f"{getattr(self, name)!r:.40}")
            object.__setattr__(self, name, value)
        if self.restarts is not None:
            object.__setattr__(self, "restarts", whole_number(self.restarts, "max_restarts", 0))


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
               done: Callable[[int], None] = lambda i: None,
               patience: Patience = Patience()):
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
    patience : Patience
        The bounds on the wait (the module docstring); an unfinished chunk past them is
        an :class:`Abandoned`.

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
        watch = _Watch(client, patience, n_used)
        held = client.submit(_hold, shared, pure=True)
        results: list = [None] * len(chunks)
        lost = []
        for i, result in _completed(client, task, held, chunks, range(len(chunks)), watch):
            results[i] = result
            if isinstance(result, Exception) and lost_worker(result):
                lost.append(i)
            else:
                done(i)
        for i in sorted(lost):  # alone now: a worker's death implicates this chunk only
            if watch.abandoned is None:  # else the cluster was given up on: KilledWorker stays
                for _, result in _completed(client, task, held, chunks, [i], watch):
                    results[i] = result
            done(i)
        return results, n_used, startup
    finally:
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()


def _completed(client, task, held, chunks, indices, watch: _Watch):
    """``(i, result or exception)`` of the chunks ``indices``, in the order they complete
    (within ``watch``'s bounds)."""
    futures = {client.submit(task, held, *chunks[i], pure=False, retries=RETRIES): i
               for i in indices}
    yield from watch.results(futures)


#: What a finished future's ``result()`` may raise: the task's exception, or a cancellation
#: (``asyncio.CancelledError`` is no ``Exception``).
_ENDED = (Exception, asyncio.CancelledError, concurrent.futures.CancelledError)


class _Watch:
    """The wait of one study within its :class:`Patience`, kept across its rounds (the
    chunks lost with a worker, run again alone): once it has given up, nothing more is
    waited for.  ``since``, ``base`` and ``empty_since`` describe the stall since the last
    chunk finished: when, the worker deaths counted then (None: not counted yet), since
    when the cluster has had no worker."""

    def __init__(self, client, patience: Patience, n_workers: int, clock=time.monotonic):
        self.client, self.clock, self.patience = client, clock, patience
        self.restarts = (RESTARTS_PER_WORKER * max(n_workers, 1) if patience.restarts is None
                         else patience.restarts)
        self.abandoned: Abandoned | None = None
        self._progress()

    def _progress(self) -> None:
        self.since, self.base, self.empty_since = self.clock(), None, None

    def deaths(self) -> int | None:
        """Workers the scheduler has removed so far (None: it keeps no such log)."""
        try:
            events = self.client.get_events("all")
        except Exception:  # an old or foreign scheduler: the other bounds remain
            return None
        return sum(1 for _, msg in events
                   if isinstance(msg, dict) and msg.get("action") == "remove-worker")

    def workers(self) -> int | None:
        """Workers connected to the scheduler now (None: it does not say)."""
        try:
            return len(self.client.scheduler_info().get("workers", {}))
        except Exception:
            return None

    def verdict(self) -> str:
        """Why to give up now ("" to go on waiting): asked every :data:`POLL` seconds while
        no chunk finishes."""
        now, died = self.clock(), self.deaths()
        if self.base is None:  # counted from the first check after the last chunk finished
            self.base = died
        if died is not None and self.base is not None and died - self.base > self.restarts:
            return (f"workers keep dying: {died - self.base} deaths while no chunk finished "
                    f"(more than max_restarts={self.restarts})")
        if self.workers() == 0:
            self.empty_since = now if self.empty_since is None else self.empty_since
            if now - self.empty_since > self.patience.no_workers:
                return (f"no worker for {self.patience.no_workers:g} s (they die as they "
                        f"start, or none was started)")
        else:
            self.empty_since = None
        if now - self.since > self.patience.timeout:
            return f"no chunk finished within chunk_timeout={self.patience.timeout:g} s"
        return ""

    def results(self, futures: dict):
        """``(i, result or exception)`` as the ``futures`` (future -> i) finish; past the
        bounds, every unfinished one's is an :class:`Abandoned` (its future cancelled).

        The results are fetched in a thread of their own: a finished chunk's data may
        have died with its worker, and ``result()`` then waits for Dask to compute it
        again (for ever, on a cluster whose workers keep dying), while a large result
        must not be cut off by a timeout.  Cancelling the future ends that wait.
        """
        done: queue.SimpleQueue = queue.SimpleQueue()
        fetched: queue.SimpleQueue = queue.SimpleQueue()
        stop = threading.Event()
        for future in futures:
            future.add_done_callback(done.put)

        def fetch():
            while not stop.is_set():
                try:
                    future = done.get(timeout=self.patience.poll)
                except queue.Empty:
                    continue
                try:
                    result = future.result()
                except _ENDED as exc:  # that chunk's failure; the others go on
                    result = exc
                fetched.put((future, result))

        threading.Thread(target=fetch, name="mbgen-chunk-results", daemon=True).start()
        pending = dict(futures)
        self._progress()
        try:
            while pending:
                try:
                    future, result = fetched.get(timeout=self.patience.poll)
                except queue.Empty:
                    reason = self.verdict()
                    if reason:
                        self.abandoned = Abandoned(reason)
                        for future, i in list(pending.items()):
                            del pending[future]
                            future.cancel()
                            yield i, self.abandoned
                    continue
                i = pending.pop(future, None)
                if i is not None:
                    self._progress()
                    yield i, result
        finally:
            stop.set()


def _hold(value):
    """A task returning ``value``: data Dask can compute again when a worker holding it dies."""
    return value


__all__ = ["CHUNK_TIMEOUT", "CONNECT_TIMEOUT", "NO_WORKER_TIMEOUT", "POLL", "RESTARTS_PER_WORKER",
           "RETRIES", "Abandoned", "Patience", "connect", "lost_worker", "reach", "run_chunks"]
