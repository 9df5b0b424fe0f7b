"""Measurements for issue 12's closing note (not tests): ``python -m mbgen.bench.targets``.

* Batch RHS: per-item cost of ``<prefix>_rhs_batch`` against the single C call in a C loop
  (timed in C with ``clock_gettime``, median of 7), and against ``model.rhs`` in a Python
  loop and one ``model.rhs(t, X)`` batch call from Python, at k = 1, 100, 10,000.
* Ensembles of 10,000 members: serial C (one process) and a LocalCluster of 2 workers,
  its first use (workers import mbgen, load the model) and a second, warm one; the Dask
  overhead per member is the warm wall time minus the ideal half of the serial time.
* FMU round trip: FMPy co-simulation and model exchange against ``integrate``.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..export import export_fmu
from ..model.scene import load_scene
from ..pipeline import compile as compile_
from ..pipeline import run
from ..studies.ensemble import ensemble

C_TIMER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "%(prefix)s.h"
%(batch)s
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
static int cmp(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}
int main(int argc, char **argv)
{
    const long k = atol(argv[1]), reps = atol(argv[2]);
    double *x = malloc(sizeof(double) * k * %(N)s), *out = malloc(sizeof(double) * k * %(N)s);
    int *status = malloc(sizeof(int) * k);
    double p[%(NP)s] = { %(p)s }, t = 0.0, single[7], batch[7], t0;
    long i, r, j;
    for (i = 0; i < k * %(N)s; ++i) {
        x[i] = 0.5 + 0.3 * ((i * 7919) %% 101) / 101.0;
    }
    for (j = 0; j < 7; ++j) {
        t0 = now();
        for (r = 0; r < reps; ++r) {
            for (i = 0; i < k; ++i) {
                %(prefix)s_rhs(t, x + i * %(N)s%(parg)s, out + i * %(N)s);
            }
        }
        single[j] = (now() - t0) / (reps * k);
        t0 = now();
        for (r = 0; r < reps; ++r) {
            %(prefix)s_rhs_batch(k, &t, 0, x, %(N)s%(pbatch)s, out, status);
        }
        batch[j] = (now() - t0) / (reps * k);
    }
    qsort(single, 7, sizeof(double), cmp);
    qsort(batch, 7, sizeof(double), cmp);
    printf("%%.6g %%.6g\n", single[3] * 1e9, batch[3] * 1e9);
    free(x);
    free(out);
    free(status);
    return 0;
}
"""


def batch_rhs(scene_name: str = "disc_pendulum", ks=(1, 100, 10000)) -> list[dict]:
    scene = load_scene(scene_name)
    result = run(scene)
    model, rendered = result.compiled, result.rendered
    p = scene.p(model.layout)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name, text in rendered.files.items():
            (folder / name).write_text(text)
        src = C_TIMER % dict(prefix=rendered.prefix, batch=rendered.extension, N=model.n_x,
                             NP=max(model.n_p, 1), p=", ".join(repr(float(v)) for v in p) or "0.0",
                             parg=", p" if model.n_p else "",
                             pbatch=", p, 0" if model.n_p else "")
        (folder / "timer.c").write_text(src)
        cc = shutil.which("gcc") or shutil.which("cc")
        subprocess.run([cc, "-std=c99", "-O2", "-ffp-contract=off", "-o", "timer", "timer.c",
                        f"{rendered.prefix}.c", "-lm"], cwd=folder, check=True)
        for k in ks:
            reps = max(1, 200000 // k)
            single_ns, batch_ns = map(float, subprocess.run(
                [str(folder / "timer"), str(k), str(reps)], capture_output=True, text=True,
                check=True).stdout.split())
            X = np.random.default_rng(0).uniform(0.5, 0.8, (k, model.n_x))
            loops = max(1, 20000 // k)
            py_loop, py_batch = [], []
            for _ in range(5):
                t0 = time.perf_counter()
                for _ in range(loops):
                    for xi in X:
                        model.rhs(0.0, xi, p)
                py_loop.append((time.perf_counter() - t0) / (loops * k) * 1e9)
                t0 = time.perf_counter()
                for _ in range(loops):
                    model.rhs(0.0, X, p)
                py_batch.append((time.perf_counter() - t0) / (loops * k) * 1e9)
            rows.append(dict(k=k, c_single_ns=single_ns, c_batch_ns=batch_ns,
                             ratio=batch_ns / single_ns,
                             py_loop_ns=statistics.median(py_loop),
                             py_batch_ns=statistics.median(py_batch)))
    return rows


def ensembles(k: int = 10000) -> list[dict]:
    from dask.distributed import Client, LocalCluster

    rows = []
    studies = {"disc_pendulum": dict(samples={"l": ("uniform", 2.0, 6.0),
                                              "q2": ("normal", 1.0, 0.2)}),
               "stiff_chain": dict(samples={"k": ("uniform", 5e3, 2e4),
                                            "x1": ("normal", 1.5, 0.1)})}
    for name, study in studies.items():
        scene = load_scene(name)
        serial = ensemble(scene, n=k, serial=True, progress=False, **study)
        t0 = time.perf_counter()
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        startup = time.perf_counter() - t0
        try:
            cold = ensemble(scene, n=k, client=client, progress=False, **study)  # first use
            warm = ensemble(scene, n=k, client=client, progress=False, **study)
            # the same members over a vanishing time span: what Dask costs per member
            # when the integration costs (almost) nothing
            tiny = dict(study, t_end=1e-9)
            bare = ensemble(scene, n=k, serial=True, progress=False, **tiny)
            bare_dask = ensemble(scene, n=k, client=client, progress=False, **tiny)
        finally:
            client.close()
            cluster.close()
        same = all(np.array_equal(serial.table[f], warm.table[f],
                                  equal_nan=serial.table[f].dtype.kind == "f")
                   for f in serial.table.dtype.names)
        per_serial = serial.wall_time / k * 1e6
        rows.append(dict(scene=name, members=k, serial_s=serial.wall_time,
                         cluster_start_s=startup, dask_cold_s=cold.wall_time,
                         dask_warm_s=warm.wall_time, serial_us=per_serial,
                         warm_us=warm.wall_time / k * 1e6,
                         overhead_warm_us=(warm.wall_time - serial.wall_time / 2) / k * 1e6,
                         tasks=warm.tasks, failed=serial.n_failed, identical=same,
                         bare_serial_us=bare.wall_time / k * 1e6,
                         bare_dask_us=bare_dask.wall_time / k * 1e6))
    return rows


def fmu_round_trip() -> list[dict]:
    from fmpy import simulate_fmu

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, opts in (("disc_pendulum", {}), ("stiff_chain", {}), ("n_link_cart", {"n": 2})):
            scene = load_scene(name, **opts)
            path = export_fmu(scene, tmp)
            model = compile_(scene)
            method = [o.value for o in model.outputs if o.is_integrator][0]
            for kind in ("CoSimulation", "ModelExchange"):
                signal = None
                if model.n_r:
                    signal = np.array([(0.0, 2.0), (5.0, 2.0)], dtype=[("time", "f8"),
                                                                     ("F", "f8")])
                res = simulate_fmu(str(path), fmi_type=kind, stop_time=5.0,
                                   output_interval=0.05, relative_tolerance=1e-9, input=signal,
                                   output=list(model.state_names))
                ref = model.integrate(method, res["time"], scene.x0(model.layout),
                                      r=[2.0] * model.n_r or None, rtol=1e-11, atol=1e-13)
                x = np.stack([res[s] for s in model.state_names], axis=1)
                rows.append(dict(scene=name, kind=kind, max_diff=float(np.abs(x - ref.x).max())))
    return rows


def main() -> None:
    for what in sys.argv[1:] or ["batch", "fmu", "ensemble"]:
        fn = {"batch": batch_rhs, "fmu": fmu_round_trip, "ensemble": ensembles}[what]
        for row in fn():
            print(what, row, flush=True)


if __name__ == "__main__":
    main()
