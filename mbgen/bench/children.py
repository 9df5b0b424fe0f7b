"""Benchmarks' child processes: one side of a comparison under a time budget and a memory cap.

A benchmark runs each tool (mbgen, sympy, ...) in its own Python process, so that a side that
runs too long or out of memory is stopped without taking the benchmark down.  The child prints
one JSON object per line as each stage finishes (``{"derive_s": 0.8}``); the parent collects
what arrived before the end, and :func:`status` says where a stopped or failed side stopped.

Each child has a compile cache of its own, empty, so that nothing of an earlier run is
reused.  ``seeded=True`` first fills it with what a cache holds once per install, not per
model -- the Python crossing and Jinja's compiled templates (:data:`SEED`, one tiny model
built in a process of its own, untimed) -- so that the timed child pays what a user pays
for a new model, and no more: the 2-link arm's stages were 0.39 s in an empty cache,
of them 0.23 s for those two (this machine).
"""

from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
import tempfile
from collections.abc import Callable, Sequence


def memory_cap(memory_gb: float) -> Callable[[], None]:
    """A ``preexec_fn`` that caps the child's address space at ``memory_gb`` GiB."""
    def limit() -> None:
        cap = int(memory_gb * 2 ** 30)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    return limit


#: The seed's own time limit (a few seconds here).
SEED_TIMEOUT_S = 300.0
#: What ``seeded`` runs first in the child's cache: a 1-link arm's RHS, built.
SEED = ("from mbgen.abi import Output; from mbgen.bench.arm import arm_scene; "
        "from mbgen.pipeline import run; run(arm_scene(1), (Output.RHS,), name='seed', "
        "warm=False)")


def run_json_child(argv: Sequence[str], *, budget_s: float, memory_gb: float,
                   stdin: str | None = None, prefix: str = "mbgen-child-",
                   seeded: bool = False) -> tuple[dict, int | None, list[str]]:
    """Run ``python argv...`` with its own compile cache; ``(results, rc, stderr lines)``.

    ``results`` merges every JSON line the child printed; ``rc`` is None when the
    child was killed at ``budget_s`` seconds (``math.inf``: never).  ``seeded``: the cache
    first gets what it holds once per install (:data:`SEED`, untimed).
    """
    with tempfile.TemporaryDirectory(prefix=prefix) as cache, \
            tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        env = dict(os.environ, MBGEN_CACHE_DIR=cache)
        if seeded:   # its own cap: the budget is the timed child's
            try:
                subprocess.run([sys.executable, "-c", SEED], env=env, capture_output=True,
                               timeout=SEED_TIMEOUT_S, check=False)
            except subprocess.TimeoutExpired:
                pass     # the timed child then builds them itself, and says so in its time
        proc = subprocess.Popen([sys.executable, *argv], stdout=out, stderr=err, env=env,
                                stdin=subprocess.PIPE if stdin is not None else None,
                                preexec_fn=memory_cap(memory_gb), text=True)
        if stdin is not None:
            proc.stdin.write(stdin)
            proc.stdin.close()
        try:
            rc = proc.wait(timeout=None if math.isinf(budget_s) else budget_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            rc = None
        out.seek(0)
        err.seek(0)
        results: dict = {}
        for line in out:
            if line.startswith("{"):
                results.update(json.loads(line))
        return results, rc, err.read().strip().splitlines()


def status(results: dict, stages: Sequence[str], rc: int | None, error: list[str],
           budget_s: float, width: int = 160) -> str:
    """``"ok"``, or where the side stopped (the first stage without a result) and why."""
    pending = next((s for s in stages if s not in results), None)
    where = (pending or "").removeprefix("sympy_").removesuffix("_s").removesuffix("_ns")
    if rc is None:
        return f"stopped in {where} at the {budget_s:g} s budget"
    if rc != 0:
        last = error[-1] if error else f"exit status {rc}"
        return f"failed in {where}: {'out of memory' if 'MemoryError' in last else last}"[:width]
    return "ok"


__all__ = ["memory_cap", "run_json_child", "status"]
