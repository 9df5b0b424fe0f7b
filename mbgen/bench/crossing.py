"""The Python crossing on the spatial arm: ``model.rhs`` through the C entry, through cffi,
and Pinocchio's ``pin.aba`` from Python, in one run (``python -m mbgen.bench.crossing``).

For every number of links ``n`` the built-in scene ``spatial_arm`` is compiled twice:
one model as it is (its RHS through the C entry, :mod:`mbgen.runtime.crossing`) and one
whose RHS is the Python path the entry falls back to (the cffi call of mbgen before the
entry: two ``ffi.from_buffer``, ``np.empty``, the checks in Python).  Each is timed
with ``p`` given and with the default ``p``, beside ``pin.aba(model, data, q, v, tau)``
on the same arm (:func:`mbgen.bench.arm_pinocchio.pinocchio_arm`) and the RHS in C (the
model's own batch loop over one state, one crossing per 10,000 calls), so that the
crossing itself is the Python figure less the C one.

Every figure is the best of ``rounds`` timings of ``calls`` calls (garbage collection
off), the variants interleaved round by round, so that a busy machine slows them alike.
Without Pinocchio (the ``bench`` extra) its column is empty.
"""

from __future__ import annotations

import argparse
import gc
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import BenchmarkError
from ..model.scene import load_scene
from ..pipeline import compile as compile_model

#: Timed variants, in the table's order: (column, label).
VARIANTS = (("c_ns", "C loop"), ("before_p_ns", "cffi (t,x,p)"), ("after_p_ns", "entry (t,x,p)"),
            ("before_ns", "cffi (t,x)"), ("after_ns", "entry (t,x)"), ("pin_ns", "pin.aba"))


@dataclass
class CrossingRow:
    """ns per call at one ``n`` (None: not measured)."""

    n: int
    c_ns: float | None = None
    before_p_ns: float | None = None
    after_p_ns: float | None = None
    before_ns: float | None = None
    after_ns: float | None = None
    pin_ns: float | None = None


def _ns(fn, args: tuple, calls: int) -> float:
    """ns per ``fn(*args)`` over ``calls`` calls, garbage collection off."""
    was = gc.isenabled()
    gc.disable()
    try:
        t0 = time.perf_counter()
        for _ in range(calls):
            fn(*args)
        return 1e9 * (time.perf_counter() - t0) / calls
    finally:
        if was:
            gc.enable()


def _pinocchio(n: int, x: np.ndarray):
    """``(pin.aba, its arguments)`` for the arm at state ``x``, or None without Pinocchio."""
    from .arm_pinocchio import import_pinocchio, pinocchio_arm

    try:
        pin = import_pinocchio()
    except BenchmarkError:
        return None
    model = pinocchio_arm(n)
    return pin.aba, (model, model.createData(), x[:n].copy(), x[n:].copy(), np.zeros(n))


#: Items of the batch loop that times the RHS in C (one crossing per this many calls).
BATCH = 10_000


def _c_loop(model, x: np.ndarray, p: np.ndarray, calls: int):
    """``(fn, args)``: ``max(1, calls // BATCH)`` calls of the model's C batch loop
    ``<prefix>_rhs_batch`` over :data:`BATCH` copies of ``x`` (stride 0), each item one
    ``<prefix>_rhs`` call into its own row: the RHS in C, in this module and process, with
    a crossing per :data:`BATCH` calls."""
    buf = model.ffi.from_buffer
    loop = getattr(model.lib, f"{model.rendered.prefix}_rhs_batch")
    t, out = np.zeros(1), np.empty((BATCH, model.n_x))
    status = np.empty(BATCH, dtype=np.intc)
    args = [BATCH, buf("double[]", t), 0, buf("double[]", x), 0]
    if model.n_p:
        args += [buf("double[]", p), 0]
    if model.n_r:
        args += [buf("double[]", np.zeros(model.n_r)), 0]
    args += [buf("double[]", out), buf("int[]", status)]  # the buffers keep the arrays
    reps = max(1, calls // BATCH)

    def run(*args):
        for _ in range(reps):
            loop(*args)
    return run, tuple(args), reps * BATCH


def measure(n: int, rounds: int = 7, calls: int = 200_000, c_loop: bool = True) -> CrossingRow:
    """One row: the variants of :data:`VARIANTS` at ``n`` links (see the module's text)."""
    scene = load_scene("spatial_arm", n=n)
    after = compile_model(scene, ("rhs",))
    before = compile_model(scene, ("rhs",))
    before._rhs = before._python_calls["rhs"]      # the Python path: mbgen's cffi call
    x = np.random.default_rng(1000 + n).uniform(-1.0, 1.0, after.n_x)
    p = after.default_parameters.copy()
    if not np.array_equal(after.rhs(0.0, x, p), before.rhs(0.0, x, p)):
        raise BenchmarkError("the C entry and the Python path disagree")  # pragma: no cover
    timed = {"before_p_ns": (before.rhs, (0.0, x, p), calls),
             "after_p_ns": (after.rhs, (0.0, x, p), calls),
             "before_ns": (before.rhs, (0.0, x), calls), "after_ns": (after.rhs, (0.0, x), calls)}
    if c_loop:
        fn, args, items = _c_loop(after, x, p, calls)
        timed["c_ns"] = (fn, args, 1)
    pin = _pinocchio(n, x)
    if pin is not None:
        timed["pin_ns"] = (*pin, calls)
    best: dict[str, float] = {}
    for _ in range(rounds):
        for key, (fn, args, count) in timed.items():
            ns = _ns(fn, args, count) / (items if key == "c_ns" else 1)
            best[key] = min(best.get(key, float("inf")), ns)
    return CrossingRow(n, **best)


def format_rows(rows: Sequence[CrossingRow]) -> str:
    """Fixed-width table, ns per call, and what each column is."""
    head = ["n"] + [label for _, label in VARIANTS]
    width = [3] + [max(len(label), 8) for _, label in VARIANTS]
    lines = ["  ".join(f"{h:>{w}}" for h, w in zip(head, width))]
    for r in rows:
        cells = [str(r.n)] + ["-" if getattr(r, k) is None else f"{getattr(r, k):,.0f}"
                              for k, _ in VARIANTS]
        lines.append("  ".join(f"{c:>{w}}" for c, w in zip(cells, width)))
    return "\n".join(lines + [
        "", "ns per call of the spatial arm's RHS: C loop = <prefix>_rhs in the module's batch "
        "loop (one crossing per 10,000 calls); "
        "cffi = model.rhs through the Python path (mbgen before the C entry); entry = "
        "model.rhs as it is; pin.aba = Pinocchio from Python; best of the rounds."])


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m mbgen.bench.crossing [--ns 2,4,8,16,32] [--rounds 7] [--calls 200000]``."""
    parser = argparse.ArgumentParser(prog="python -m mbgen.bench.crossing",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--ns", default="2,4,8,16,32", help="link counts (default 2,4,8,16,32)")
    parser.add_argument("--rounds", type=int, default=7, help="timings per variant, best kept")
    parser.add_argument("--calls", type=int, default=200_000, help="calls per timing")
    parser.add_argument("--no-c-loop", action="store_true", help="leave the C loop out")
    args = parser.parse_args(argv)
    rows = []
    for n in (int(s) for s in args.ns.split(",")):
        rows.append(measure(n, args.rounds, args.calls, not args.no_c_loop))
        print(format_rows(rows[-1:]).splitlines()[1], flush=True)
    print(format_rows(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
