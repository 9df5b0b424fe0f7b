"""Every pipeline stage's time for one scene, each under its own budget
(``mbgen bench SCENE --stages``).

The pipeline runs in a child process that reports each stage as it starts and
ends (seconds, the child's peak memory, operations before and after CSE); the
parent stops the child when one stage runs past ``budget_s``, so a stage that
takes hours shows up as "over budget" instead of hanging the measurement.

Stages: ``derive``, ``bake``, ``cse[OUTPUT]`` for each requested output alone
(``optimize`` with that output only; an integrator pulls in what it calls),
``cse[all]`` (the one pass over all outputs that the code is rendered from),
``render`` and ``compile`` (cffi, into an empty cache).  The stages run one after
the other in one process, so a later ``cse[...]`` may reuse what sympy cached
for an earlier one; ``cse[all]`` is the figure the generated code costs.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ..abi import Output
from ..build.extension import load
from ..codegen.optimize import optimize
from ..codegen.render import render
from ..codegen.slicing import bake
from ..model.scene import load_scene
from ..pipeline import equations_of
from .children import memory_cap


@dataclass(frozen=True)
class StageTime:
    """One stage: ``seconds`` (None when it did not finish), peak memory, operation counts."""

    stage: str
    seconds: float | None
    max_rss_gb: float | None = None
    ops_before: int | None = None
    ops_after: int | None = None
    status: str = "ok"


def _child(scene_name: str, options: dict, outputs: Sequence[str]) -> None:
    def emit(**event):
        event["rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20
        print(json.dumps(event), flush=True)

    def stage(name, fn, *args, **kw):
        emit(start=name)
        t0 = time.perf_counter()
        value = fn(*args, **kw)
        extra = {}
        if hasattr(value, "ops_after"):
            extra = dict(ops_before=value.ops_before, ops_after=value.ops_after)
        emit(done=name, seconds=time.perf_counter() - t0, **extra)
        return value

    scene = load_scene(scene_name, **options)
    outs = Output.parse(outputs or scene.outputs)
    equations = stage("derive", equations_of, scene, energy=Output.ENERGY in outs)
    baked = stage("bake", bake, equations, scene.fixed, scene.inputs)
    if len(outs) > 1:
        for out in outs:
            stage(f"cse[{out.value}]", optimize, baked, (out,))
    kernel = stage("cse[all]", optimize, baked, outs)
    rendered = stage("render", render, kernel)
    stage("compile", load, rendered)


def stage_times(scene_name: str, options: dict | None = None, outputs: Sequence[str] = (), *,
                budget_s: float = 300.0, memory_gb: float = 16.0,
                progress: Callable[[str], None] | None = None) -> list[StageTime]:
    """Time every stage of ``scene_name`` in a child process, each stage under ``budget_s``.

    Returns the stages that started, in order; the last one has ``seconds=None``
    and a status saying why when the child was stopped or failed.  ``budget_s =
    math.inf`` stops no stage (the tests' setting: no verdict of theirs depends on the
    machine's speed).
    """
    say = progress or (lambda message: None)

    args = json.dumps({"scene": scene_name, "options": options or {}, "outputs": list(outputs)})
    results: list[StageTime] = []
    with tempfile.TemporaryDirectory(prefix="mbgen-stages-") as cache, \
            tempfile.NamedTemporaryFile("w+", suffix=".jsonl") as out, \
            tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen([sys.executable, "-m", "mbgen.bench.stages", args], stdout=out,
                                stderr=err, env=dict(os.environ, MBGEN_CACHE_DIR=cache),
                                preexec_fn=memory_cap(memory_gb))
        started, current, seen = time.monotonic(), None, 0
        while True:
            rc = proc.poll()
            with open(out.name, encoding="utf-8") as fh:
                events = [json.loads(line) for line in fh if line.startswith("{")]
            for ev in events[seen:]:
                if "start" in ev:
                    current, started = ev["start"], time.monotonic()
                    say(f"{scene_name}: {current}")
                else:
                    results.append(StageTime(ev["done"], ev["seconds"], ev["rss_gb"],
                                             ev.get("ops_before"), ev.get("ops_after")))
                    current = None
            rss = events[-1]["rss_gb"] if events else None
            seen = len(events)
            if rc is not None:
                if rc != 0 and current is not None:
                    err.seek(0)
                    last = (err.read().strip().splitlines() or [f"exit status {rc}"])[-1]
                    results.append(StageTime(current, None, rss, status=f"failed: {last}"[:120]))
                break
            if current is not None and time.monotonic() - started > budget_s:
                proc.kill()
                proc.wait()
                results.append(StageTime(current, None, rss,
                                         status=f"over the {budget_s:g} s budget, stopped"))
                break
            time.sleep(0.2)
    return results


def format_stages(scene_name: str, rows: Sequence[StageTime]) -> str:
    """One line per stage: seconds, peak memory of the process so far, operations."""
    lines = [f"{'stage':24s} {'seconds':>9s} {'peak GB':>8s} {'ops before':>12s} "
             f"{'ops after':>10s}  status", "-" * 80]
    for r in rows:
        sec = "-" if r.seconds is None else f"{r.seconds:.2f}"
        rss = "-" if r.max_rss_gb is None else f"{r.max_rss_gb:.2f}"
        before = "" if r.ops_before is None else str(r.ops_before)
        after = "" if r.ops_after is None else str(r.ops_after)
        lines.append(f"{r.stage:24s} {sec:>9s} {rss:>8s} {before:>12s} {after:>10s}  {r.status}")
    total = sum(r.seconds for r in rows if r.seconds is not None)
    lines.append(f"{'total (finished stages)':24s} {total:9.2f}   scene {scene_name}")
    return "\n".join(lines)


if __name__ == "__main__":  # the child process
    spec = json.loads(sys.argv[1])
    _child(spec["scene"], spec["options"], spec["outputs"])
