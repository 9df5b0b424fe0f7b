"""Per-call timings of the benchmarks: a Python loop, and the generated RHS in a C loop.

:func:`per_call_ns` times ``fn()`` from Python: the call count doubles until one loop
lasts :data:`MIN_LOOP_S`, then the median over ``repeats`` such loops (garbage collection
off) is divided by the count.  :func:`c_rhs_ns` writes the generated C next to a small
driver (``templates/bench/rhs.c.j2``) that calls ``<prefix>_rhs`` in a loop timed with
``clock_gettime`` the same way, compiles both with :data:`DRIVER_FLAGS` and runs it as a
subprocess: the RHS's own time, no Python crossing; :func:`c_function_ns` does the same
for another output of the state (the Jacobian).  Results are nanoseconds per call.
"""

from __future__ import annotations

import gc
import statistics
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from ..build.extension import compiler
from ..codegen.optimize import Kernel
from ..codegen.templating import environment
from ..errors import BenchmarkError, BuildError
from ..pipeline import StageTimer

#: Shortest timed loop, seconds (C drivers and Python per-call loops).
MIN_LOOP_S = 0.02
#: Compiler flags of both drivers (the generated C and Pinocchio's C++ alike).
DRIVER_FLAGS = ("-O3", "-march=native", "-DNDEBUG")


def staged(emit: Callable[[str, object], None]) -> Callable:
    """``stage(key, fn, *args, **kw)``: run ``fn`` once, ``emit(key, seconds)``, return its value
    (the per-stage timing of every benchmark child)."""
    def stage(key, fn, *args, **kw):
        t0 = time.perf_counter()
        value = fn(*args, **kw)
        emit(key, time.perf_counter() - t0)
        return value
    return stage


def pipeline_timer(emit: Callable[[str, object], None], prefix: str = "",
                   counts: Mapping[str, str] | None = None) -> StageTimer:
    """The :class:`~mbgen.pipeline.StageTimer` of a benchmark child.

    ``emit(f"{prefix}{stage}_s", seconds)`` as each stage of :func:`mbgen.pipeline.run` ends
    (``derive_s``, ``bake_s``, ``cse_s``, ``render_s``, ``compile_s``: every benchmark times
    the one pipeline, a new stage included); a stage that runs twice (both derivations
    compared) reports its sum.  ``counts`` (a :class:`~mbgen.codegen.optimize.Kernel`
    attribute -> key) are emitted as the kernel is made, so that a side stopped later in
    render or compile still reports them.
    """
    counts = dict(counts or {})

    def finished(stage: str, seconds: float, value) -> None:
        emit(f"{prefix}{stage}_s", seconds)
        if isinstance(value, Kernel):
            for attribute, key in counts.items():
                emit(key, getattr(value, attribute))
    return StageTimer(finished=finished)


def per_call_ns(fn: Callable[[], object], repeats: int) -> float:
    """Median nanoseconds of one ``fn()`` call: loops of at least MIN_LOOP_S, gc off."""

    def loop(number: int) -> float:
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        return time.perf_counter() - t0

    was = gc.isenabled()
    gc.disable()
    try:
        number = 1
        while loop(number) < MIN_LOOP_S:
            number *= 2
        return 1e9 * statistics.median(loop(number) / number for _ in range(repeats))
    finally:
        if was:
            gc.enable()


def c_rhs_ns(rendered, x: np.ndarray, p: np.ndarray, r: np.ndarray, repeats: int,
             folder: Path) -> float:
    """Median ns per ``<prefix>_rhs`` call in a compiled C loop (driver from the template)."""
    return c_function_ns(rendered, "rhs", rendered.layout.n_x, x, p, r, repeats, folder)


def c_function_ns(rendered, function: str, n_out: int, x: np.ndarray, p: np.ndarray,
                  r: np.ndarray, repeats: int, folder: Path,
                  model_flags: Sequence[str] | None = None) -> float:
    """Median ns per ``<prefix>_<function>(t, x, [p], [r], out)`` call in a compiled C loop.

    ``function`` is an output taking the state (``rhs``, ``jacobian``), ``n_out`` the length
    of its output array (``n_x`` for the RHS, ``n_x * n_x`` for the Jacobian).  The model's
    source is compiled with :data:`DRIVER_FLAGS`, or with ``model_flags`` where given (those
    of the user's module: :func:`mbgen.build.extension.model_flags`).
    """
    layout = rendered.layout
    for name, text in rendered.files.items():
        if name.endswith((".c", ".h")):
            (folder / name).write_text(text, encoding="utf-8")
    args = ["0.0", "x"] + (["p"] if layout.n_p else []) + (["r"] if layout.n_r else []) + ["out"]
    driver = environment().get_template("bench/rhs.c.j2").render(
        prefix=rendered.prefix, function=function, n_out=n_out, n_x=layout.n_x,
        n_p=layout.n_p, n_r=layout.n_r,
        x=[repr(float(v)) for v in x], p=[repr(float(v)) for v in p],
        r=[repr(float(v)) for v in r], call_args=", ".join(args), min_loop_s=MIN_LOOP_S,
        repeats=repeats, flags=" ".join(DRIVER_FLAGS))
    (folder / "bench_rhs.c").write_text(driver, encoding="utf-8")
    exe = folder / "bench_rhs"
    model = [f"{rendered.prefix}.c"]
    if model_flags is not None:
        model = [f"{rendered.prefix}.o"]
        cmds = [[compiler(), *model_flags, "-c", f"{rendered.prefix}.c", "-o", model[0]]]
    else:
        cmds = []
    cmds.append([compiler(), "-std=c99", *DRIVER_FLAGS, "-o", str(exe), "bench_rhs.c", *model,
                 "-lm"])
    for cmd in cmds:
        proc = subprocess.run(cmd, cwd=folder, capture_output=True, text=True)
        if proc.returncode != 0:
            raise BuildError(f"compiling the {function} benchmark driver failed:\n"
                             f"{proc.stderr[-3000:]}")
    return median_ns(run_driver([str(exe)], f"the {function} driver"))


def run_driver(cmd, what: str, stdin: str | None = None) -> str:
    """Run a timing driver; its standard output, or :class:`BenchmarkError` when it fails."""
    run = subprocess.run(cmd, input=stdin, capture_output=True, text=True)
    if run.returncode != 0:
        raise BenchmarkError(f"{what} failed: {run.stdout[-300:]} {run.stderr[-300:]}")
    return run.stdout


def median_ns(stdout: str) -> float:
    """The median of a driver's per-repeat lines (those that start with a digit)."""
    return statistics.median(float(s) for s in stdout.splitlines() if s[:1].isdigit())
