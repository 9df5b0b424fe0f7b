"""Fuzz worker: hostile calls into compiled C and generated Python, run in a child process.

Run by ``tests/runtime/test_fuzz.py`` as
``python tests/support/fuzz_worker.py EXAMPLES SEED SKIP PROGRESS``.
Hypothesis draws each call (function, ``t``, ``x``, ``p``, ``r``, or the arguments of
``integrate``); the same call goes to the compiled model and, for evaluations, to the
generated Python module.  Every outcome is classified:

``ok``        an ndarray of the documented shape, every entry finite
``named``     an :class:`mbgen.errors.MbgenError` (the class name is the outcome)
``unnamed``   any other exception (a bug: a raw ``ZeroDivisionError``, a cffi
              ``OverflowError``, a builtin ``TypeError`` ...)
``nonfinite`` a result holding NaN or infinity, or of the wrong shape, returned silently

and C is compared with Python on outcome (same class) and value.  A crash kills this
process: before each call its index is written to ``PROGRESS`` so the parent can
count the crash, name the call and restart after it (``SKIP``).  The census is printed
as one JSON line on stdout at the end.
"""

from __future__ import annotations

import json
import sys
import warnings
from fractions import Fraction

import numpy as np
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st

import mbgen
from mbgen.errors import MbgenError
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.python import python_model
from models import four_bar_model

SPECIAL = [np.nan, np.inf, -np.inf, 1e308, -1e308, 5e-324, -5e-324, 0.0, -0.0, 1e154, 1e-154,
           1e200, -1e200]
EVALS = ("rhs", "mass_matrix", "forcing", "energy", "jacobian", "input_jacobian",
         "constraint_forces", "holonomic", "reactions", "velocities")
INTEGRATORS = ("dopri5", "rk4", "rosenbrock")


def four_bar() -> mbgen.Scene:
    """A four-bar linkage: a loop-closing constraint (a singular Jacobian at dead points)."""
    m = four_bar_model("fuzz_fourbar")
    return mbgen.Scene("fuzz_fourbar", m, parameters=dict(la=1.0, lb=2.0, lc=2.0, ld=2.0, g=9.81),
                       points=("GA", "GB", "GC"))


def build_models():
    """Three small models: a spring pendulum (sqrt, division), a 2-link cart (an input) and
    a four-bar linkage (a constraint)."""
    out = []
    for scene, outputs in ((load_scene("spring_pendulum"),
                            ("rhs", "mass_matrix", "forcing", "energy", "jacobian", "dopri5", "rk4",
                             "rosenbrock")),
                           (load_scene("n_link_cart", n=2),
                            ("rhs", "mass_matrix", "forcing", "input_jacobian", "dopri5")),
                           (four_bar(), ("rhs", "jacobian", "energy", "reactions",
                                         "constraint_forces", "holonomic", "velocities",
                                         "dopri5"))):
        result = run(scene, outputs)
        out.append((result.compiled, python_model(result.rendered)))
    return out


# ------------------------------------------------------------------ strategies
finite = st.floats(-3.0, 3.0, allow_nan=False)
anyfloat = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(SPECIAL))


@st.composite
def vector(draw, n: int, allow_none: bool):  # noqa: C901 - one flat case per kind of bad vector
    """A value passed where a float64 vector of length ``n`` is expected."""
    kinds = ["good"] * 6 + ["special", "wrong_len", "batch", "dtype", "noncontig", "readonly",
                            "bigendian", "list", "scalar", "complex", "object", "string", "ragged",
                            "float32", "int"]
    if allow_none:
        kinds += ["none"] * 4
    kind = draw(st.sampled_from(kinds))
    good = np.array(draw(st.lists(finite, min_size=n, max_size=n)), dtype=np.float64)
    if kind == "good":
        return kind, good
    if kind == "special":
        v = good.copy()
        for i in draw(st.lists(st.integers(0, max(n - 1, 0)), min_size=1, max_size=2)):
            if n:
                v[i] = draw(anyfloat)
        return kind, v
    if kind == "wrong_len":
        m = draw(st.integers(0, n + 3).filter(lambda m: m != n))
        return kind, np.zeros(m)
    if kind == "batch":
        k = draw(st.integers(0, 3))
        cols = draw(st.sampled_from([n, n, n + 1]))
        return kind, np.array(draw(st.lists(st.lists(finite, min_size=cols, max_size=cols),
                                            min_size=k, max_size=k)),
                              dtype=np.float64).reshape(k, cols)
    if kind == "dtype":
        return kind, good.astype(draw(st.sampled_from([np.bool_, np.float16, np.longdouble,
                                                       np.int8, np.uint64])))
    if kind == "noncontig":
        big = np.repeat(good, 2)
        return kind, big[::2]
    if kind == "readonly":
        good.flags.writeable = False
        return kind, good
    if kind == "bigendian":
        return kind, good.astype(">f8")
    if kind == "list":
        return kind, good.tolist()
    if kind == "scalar":
        return kind, draw(anyfloat)
    if kind == "complex":
        return kind, good.astype(np.complex128) + draw(st.sampled_from([0j, 1j]))
    if kind == "object":
        return kind, good.astype(object)
    if kind == "string":
        return kind, draw(st.sampled_from(["1,2,3", "", "abc"]))
    if kind == "ragged":
        return kind, [[1.0], [1.0, 2.0]]
    if kind == "float32":
        return kind, good.astype(np.float32)
    if kind == "int":
        return kind, np.arange(n)
    return kind, None


times = st.one_of(finite, finite, finite, anyfloat,
                  st.sampled_from([10**400, -10**400, 2**63, 2**1100, True, np.float32(1.5),
                                   np.float64(np.nan), np.int64(3), np.complex128(1 + 5j),
                                   np.complex128(1 + 0j), 1j, "0.5", None, b"1", Fraction(1, 3),
                                   Fraction(10**400, 3), [0.0], np.array(0.5), np.array([0.5])]))
tolerances = st.one_of(st.sampled_from([1e-6, 1e-9, 1e-3]), anyfloat,
                       st.sampled_from([None, "1e-6", -1.0, 0.0, 1e-300, 1e300, 10**400, 1j,
                                        np.float32(1e-6), [1e-6]]))
steps = st.one_of(st.none(), st.floats(1e-3, 0.5), anyfloat,
                  st.sampled_from([1e-300, 1e300, -0.1, 0.0, "0.1", 1j, 10**400]))
max_steps = st.sampled_from([0, 0, 0, 1, 2, 10, 1000, -1, 2**31 - 1, 2**31, 2**63, 2**64, -2**63,
                             1.5, 2.0, None, "10", np.int64(100), np.float64(100.0), True,
                             10**400])
spans = st.one_of(
    st.lists(finite.map(abs), min_size=1, max_size=4).map(lambda v: np.cumsum(np.array(v) + 0.01)),
    st.sampled_from([[0.0, 1.0], [0.0, 1e300], [0.0, 5e-324], [0.0, 1e-300], [1e300, 1.7e308],
                     [0.0, np.inf], [np.nan, 1.0], [1.0, 0.0], [0.0, 0.0], [], [[0.0, 1.0]],
                     [0.0, 1j], "0 1", None, [0.0, 10**400], [-1e308, 1e308],
                     [0.0, 1.0, 1.0 + 2.2e-16]]))


def classify(fn):
    """``(outcome, value)`` of calling ``fn()``: see the module docstring."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a warning is noise a user would see: count it
            value = fn()
    except MbgenError as exc:
        return type(exc).__name__, None, "named"
    except Exception as exc:  # everything else is counted, by class
        return f"{type(exc).__name__}: {str(exc)[:120]}", None, "unnamed"
    return "ok", value, None


def shape_ok(value, shape) -> bool:
    return isinstance(value, np.ndarray) and value.shape == tuple(shape)


def main(examples: int, seed_: int, skip: int, progress: str) -> None:
    models = build_models()
    census = {"calls": 0, "examples": 0, "named": 0, "ok": 0, "unnamed": 0, "nonfinite": 0,
              "disagree_outcome": 0, "disagree_value": 0, "by_class": {}, "samples": []}
    counter = {"i": -1}

    def note(kind: str, text: str):
        census[kind] += 1
        key = f"{kind}: {text.split(' <- ')[0]}"[:90]
        census["by_class"][key] = census["by_class"].get(key, 0) + 1
        if kind != "named" and len(census["samples"]) < 40:
            census["samples"].append(f"{kind}: {text}")

    @settings(max_examples=examples, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @seed(seed_)
    @given(st.data())
    def fuzz(data):
        counter["i"] += 1
        if counter["i"] < skip:
            return
        with open(progress, "w") as f:
            f.write(str(counter["i"]))
        census["examples"] += 1
        which = data.draw(st.integers(0, len(models) - 1))
        c, py = models[which]
        names = [o.value for o in c.outputs]
        func = data.draw(st.sampled_from([n for n in names if n in EVALS + INTEGRATORS]))
        if func in INTEGRATORS:
            integrate_case(data, c, func, note, census)
        else:
            evaluate_case(data, c, py, func, note, census)

    fuzz()
    print(json.dumps(census))


def evaluate_case(data, c, py, func, note, census):
    t = data.draw(times)
    _, x = data.draw(vector(c.n_x, False))
    _, p = data.draw(vector(c.n_p, True))
    _, r = data.draw(vector(c.n_r, True))
    label = f"{c.name}.{func}(t={t!r}, x={x!r}, p={p!r}, r={r!r})"[:400]
    outs = {}
    for backend, model in (("c", c), ("python", py)):
        census["calls"] += 1
        outcome, value, kind = classify(lambda model=model: getattr(model, func)(t, x, p, r))
        if kind:
            note(kind, f"{backend} {outcome}" + ("" if kind == "named" else f" <- {label}"))
        else:
            if not isinstance(value, np.ndarray) or not np.all(np.isfinite(value)):
                note("nonfinite", f"{backend} {func} returned {value!r} <- {label}")
                outcome = "nonfinite"
            else:
                census["ok"] += 1
        outs[backend] = (outcome, value)
    (oc, vc), (op, vp) = outs["c"], outs["python"]
    if oc.split(":")[0] != op.split(":")[0]:
        note("disagree_outcome", f"c {oc} vs python {op} <- {label}")
    elif oc == "ok" and vc.shape != np.shape(vp) or oc == "ok" and vc.ndim == 2 and c.n_x == 0:
        note("disagree_value", f"shapes {vc.shape} vs {np.shape(vp)} <- {label}")
    elif oc == "ok":
        scale = max(1.0, float(np.max(np.abs(vc), initial=0.0)))
        err = float(np.max(np.abs(vc - vp), initial=0.0))
        if not err <= 1e-9 * scale:
            note("disagree_value", f"|c - python| = {err:.3g} (scale {scale:.3g}) <- {label}")


def integrate_case(data, c, method, note, census):
    t_eval = data.draw(spans)
    _, x0 = data.draw(vector(c.n_x, False))
    _, p = data.draw(vector(c.n_p, True))
    kw = {}
    for name, strat in (("rtol", tolerances), ("atol", tolerances), ("h", steps),
                        ("h_max", steps), ("max_steps", max_steps)):
        if (data.draw(st.booleans())
                or (name == "h" and method == "rk4" and data.draw(st.booleans()))):
            kw[name] = data.draw(strat)
    # bound the work: a valid huge step budget only with a sensible fixed step
    if method == "rk4" and isinstance(kw.get("max_steps"), int) and kw["max_steps"] > 10**6:
        kw["h"] = 0.01
    if isinstance(kw.get("h_max"), float) and 0 < kw["h_max"] < 1e-6:
        kw["h_max"] = 1e-6
    label = f"{c.name}.integrate({method!r}, t_eval={t_eval!r}, x0={x0!r}, p={p!r}, {kw})"[:400]
    census["calls"] += 1
    outcome, value, kind = classify(lambda: c.integrate(method, t_eval, x0, p, **kw))
    if kind:
        note(kind, f"c {outcome}" + ("" if kind == "named" else f" <- {label}"))
    elif not np.all(np.isfinite(value.x)):
        note("nonfinite", f"integrate returned non-finite states <- {label}")
    else:
        census["ok"] += 1


def threads(calls: int, seed_: int, n_threads: int = 8) -> None:
    """The same seeded calls from ``n_threads`` threads at once: every answer (value or error
    class) must equal the one-thread answer.  Prints a JSON census."""
    import threading

    jobs = thread_jobs(build_models(), calls, np.random.default_rng(seed_))
    serial = [thread_answer(j) for j in jobs]
    mismatches, unnamed = [], []

    def worker(k):
        for i in range(k, len(jobs), 1):  # every thread runs every job, from its own start
            got = thread_answer(jobs[i])
            if got != serial[i]:
                mismatches.append((k, i, got[0], serial[i][0]))
            if got[0].startswith("unnamed"):
                unnamed.append(got[0])
        for i in range(0, k):
            got = thread_answer(jobs[i])
            if got != serial[i]:
                mismatches.append((k, i, got[0], serial[i][0]))

    pool = [threading.Thread(target=worker, args=(k * len(jobs) // n_threads,))
            for k in range(n_threads)]
    for th in pool:
        th.start()
    for th in pool:
        th.join()
    print(json.dumps({"calls": n_threads * len(jobs), "threads": n_threads,
                      "mismatches": len(mismatches), "unnamed": len(unnamed),
                      "samples": [str(m) for m in mismatches[:10]] + unnamed[:10]}))


def thread_jobs(models, calls: int, rng) -> list:
    """``calls`` seeded calls ``(function, t, x, p)``, each of the C and the Python model."""
    jobs = []
    for i in range(calls):
        c, py = models[i % len(models)]
        func = [o.value for o in c.outputs if not o.is_integrator][i % 3]
        x = rng.uniform(-2, 2, c.n_x)
        if i % 7 == 0:
            x[i % c.n_x] = [np.nan, np.inf, 0.0][i % 3]
        p = None if i % 5 else rng.uniform(-1, 2, c.n_p)
        for model in (c, py):
            jobs.append((getattr(model, func), 0.1 * i, x, p))
    return jobs


def thread_answer(job):
    """``(outcome, bytes of the value or None)`` of one job of :func:`thread_jobs`."""
    f, t, x, p = job
    try:
        return "ok", f(t, x, p).tobytes()
    except MbgenError as exc:
        return type(exc).__name__, None
    except Exception as exc:
        return f"unnamed {type(exc).__name__}", None


if __name__ == "__main__":
    if sys.argv[1] == "threads":
        threads(int(sys.argv[2]), int(sys.argv[3]))
    else:
        main(int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4])
