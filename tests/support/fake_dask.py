"""A stand-in for a Dask client whose workers keep dying, for the bounded-wait tests of
:mod:`mbgen.studies.cluster` (no cluster: milliseconds, where a LocalCluster whose workers
crash as they start takes 10 to 60 s to show the same).

The client runs a healthy chunk's task at once, in this process; the future of a chunk that
``hangs(args)`` does not finish, as on a cluster that has no live worker to run it (unless
``release_every`` is given: then every that many looks one of them does).  Every look at the
scheduler's event log finds ``deaths_per_look`` more workers removed.
"""

from __future__ import annotations

import concurrent.futures

from mbgen.studies import cluster


class Future:
    """The part of ``distributed.Future`` that :mod:`mbgen.studies.cluster` uses."""

    def __init__(self, value=None, error=None, finished=True):
        self.value, self.error, self.finished, self.cancelled = value, error, finished, False
        self.callbacks = []

    def add_done_callback(self, fn):
        if self.finished:
            fn(self)
        else:
            self.callbacks.append(fn)

    def result(self):
        if self.cancelled:
            raise concurrent.futures.CancelledError()
        if self.error is not None:
            raise self.error
        return self.value

    def finish(self, value=None, cancelled=False):
        self.value, self.finished, self.cancelled = value, True, cancelled
        for fn in self.callbacks:
            fn(self)

    def cancel(self):
        if not self.finished:
            self.finish(cancelled=True)


class DyingClient:
    """A client of ``n_workers`` workers (0: none) that die ``deaths_per_look`` at a time."""

    def __init__(self, hangs=lambda args: False, n_workers=2, deaths_per_look=1,
                 release_every=None):
        self.hangs, self.n_workers, self.deaths_per_look = hangs, n_workers, deaths_per_look
        self.release_every, self.looks, self.deaths = release_every, 0, 0
        self.hung, self.waiting = [], []        # every hung future; those still waiting (with
                                                # their task and arguments)

    def scheduler_info(self):
        return {"workers": {f"tcp://127.0.0.1:{9000 + i}": {} for i in range(self.n_workers)}}

    def get_events(self, topic=None):
        self.looks += 1
        self.deaths += self.deaths_per_look
        if self.release_every and self.looks % self.release_every == 0 and self.waiting:
            future, fn, args = self.waiting.pop(0)
            future.finish(fn(args[0].result(), *args[1:]))
        return tuple((0.0, {"action": "remove-worker"}) for _ in range(self.deaths))

    def submit(self, fn, *args, pure=True, retries=0):
        if fn is cluster._hold:
            return Future(args[0])
        if self.hangs(args[1:]):
            self.hung.append(Future(finished=False))
            self.waiting.append((self.hung[-1], fn, args))
            return self.hung[-1]
        try:
            return Future(fn(args[0].result(), *args[1:]))
        except Exception as exc:
            return Future(error=exc)
