"""Scaling benchmark on the spatial arm (``mbgen bench arm``): mbgen, sympy and Pinocchio.

For every number of links ``n`` the same arm (:mod:`mbgen.scenes.spatial_arm`:
revolute joints about z and y alternating, full link inertias, gravity) is
run through three tools, side by side in one run:

mbgen (a child process per ``n``, under a time budget and a memory cap)
    the stages of :func:`mbgen.pipeline.run` with the method asked for, each timed
    once (:func:`mbgen.bench.timing.pipeline_timer`): *derive*, *bake* (the scene's
    fixed parameters), *CSE* (``optimize``, RHS output), *render*, *compile* (a plain
    library, into a cache that holds only what it holds once per install: the crossing and
    the compiled templates, :func:`mbgen.bench.children.run_json_child`'s ``seeded``); the
    operations after CSE; the RHS time **inside C** -- a small C
    driver (``templates/bench/rhs.c.j2``) calls ``<prefix>_rhs`` in a loop timed
    with ``clock_gettime``, compiled with ``cc`` and the same flags as Pinocchio's
    driver and run as a subprocess; and the time of one ``model.rhs`` call from
    Python (the crossing included).
sympy (a child process per ``n``, under its own budget)
    ``KanesMethod`` on the same arm with symbolic parameters (*derive*:
    ``kanes_equations`` + ``mass_matrix_full``/``forcing_full``), ``sympy.cse``
    of both (*CSE*), ``lambdify(cse=True)`` (*lambdify*) and one RHS call
    (``numpy.linalg.solve``) from Python.  Where the budget runs out, the row
    says in which stage it stopped.
Pinocchio (PyPI ``pin``, the ``bench`` extra)
    The arm as a ``pinocchio.Model`` (``JointModelRZ``/``RY``, placements
    ``(I, [a, 0, 0])``, inertias at lever ``[b, 0, 0]``): ``pin.aba`` per call from
    Python, and ``pinocchio::aba`` in a C++ loop (``templates/bench/aba.cpp.j2``,
    compiled once per run with ``g++`` against the wheel's ``include``/``lib``
    folders and the Eigen headers of ``cmeel-eigen``).  Its accelerations are
    compared with mbgen's RHS at the timed state.

With ``jacobian=True`` mbgen's Jacobian is generated and timed against Pinocchio's
``computeABADerivatives`` in the same C++ loop; where ``casadi`` imports, the arm's ABA
traced on ``casadi.SX`` is generated, compiled and timed too (the RHS, and the Jacobian
with ``jacobian``): :mod:`mbgen.bench.arm_jacobian` and :mod:`mbgen.bench.arm_casadi`.

Timings are medians of ``repeats`` loops, each at least
:data:`mbgen.bench.timing.MIN_LOOP_S` long.
Growth exponents are least-squares slopes of log(value) against log(n) over
the ``n`` that finished.  Nothing is built into the repository: the drivers
are compiled in temporary folders.
"""

from __future__ import annotations

import csv
import json
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
import sympy as sm
from sympy.physics import mechanics as me
from threadpoolctl import threadpool_limits

from ..abi import Output
from ..derivation import Method
from ..errors import BenchmarkError
from ..pipeline import run
from ..scenes.spatial_arm import axis, link_parameters
from ..scenes.spatial_arm import scene as arm_scene
from ..symbolic.graph import count_ops_dag
from ..viz.plots import require_matplotlib
from . import children
from .arm_casadi import have_casadi
from .arm_jacobian import format_extra, relative_difference, run_casadi, run_jacobian
from .arm_pinocchio import (
    build_aba_driver,
    import_pinocchio,
    pinocchio_aba_derivatives,
    pinocchio_arm,
    run_aba_derivatives_driver,
    run_aba_driver,
)
from .timing import DRIVER_FLAGS, c_rhs_ns, per_call_ns, pipeline_timer


@dataclass
class ArmRow:
    """One ``n``: stage times (s), operations, per-call times (ns); None where not reached."""

    n: int
    derive_s: float | None = None
    bake_s: float | None = None
    cse_s: float | None = None
    render_s: float | None = None
    compile_s: float | None = None
    ops_after: int | None = None
    rhs_c_ns: float | None = None
    rhs_py_ns: float | None = None
    status: str = "not run"
    sympy_derive_s: float | None = None
    sympy_cse_s: float | None = None
    sympy_lambdify_s: float | None = None
    sympy_ops_after: int | None = None
    sympy_rhs_py_ns: float | None = None
    sympy_status: str = "not run"
    pin_py_ns: float | None = None
    pin_cxx_ns: float | None = None
    max_abs_diff_pin: float | None = None
    max_abs_diff_sympy: float | None = None
    # the Jacobian (jacobian=True) and CasADi: mbgen.bench.arm_jacobian
    jac_derive_s: float | None = None
    jac_bake_s: float | None = None
    jac_cse_s: float | None = None
    jac_render_s: float | None = None
    jac_compile_s: float | None = None
    jac_ops: int | None = None
    jac_c_ns: float | None = None
    jac_own_ns: float | None = None
    pin_daba_ns: float | None = None
    jac_rel_diff_pin: float | None = None
    jac_status: str = "not run"
    cas_trace_s: float | None = None
    cas_generate_s: float | None = None
    cas_compile_s: float | None = None
    cas_compile_o1_s: float | None = None
    cas_ops: int | None = None
    cas_c_ns: float | None = None
    max_abs_diff_cas: float | None = None
    casjac_trace_s: float | None = None
    casjac_generate_s: float | None = None
    casjac_compile_s: float | None = None
    casjac_compile_o1_s: float | None = None
    casjac_ops: int | None = None
    casjac_c_ns: float | None = None
    casjac_rel_diff: float | None = None
    cas_status: str = "not run"


def state(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The timed state: joint angles and rates, seeded and the same for every tool."""
    rng = np.random.default_rng(1000 + n)
    return rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n)


# ----------------------------------------------------------------------------- mbgen (child)
def _mbgen_child(n: int, repeats: int, method: str, emit) -> None:
    """mbgen's side for one ``n``; ``emit(key, value)`` reports each result as it is known."""
    result = run(arm_scene(n), (Output.RHS,), method=Method(method),
                 timer=pipeline_timer(emit, counts={"ops_after": "ops_after"}))
    rendered, model = result.rendered, result.compiled
    layout = rendered.layout
    q, v = state(n)
    x = np.concatenate([q, v])
    p = np.array([rendered.defaults[k] for k in layout.parameter_names])
    r = np.zeros(layout.n_r)
    emit("accelerations", model.rhs(0.0, x, p, r)[n:].tolist())
    with tempfile.TemporaryDirectory(prefix="mbgen-arm-driver-") as tmp:
        emit("rhs_c_ns", c_rhs_ns(rendered, x, p, r, repeats, Path(tmp)))
    emit("rhs_py_ns", per_call_ns(lambda: model.rhs(0.0, x, p, r), repeats))


# ----------------------------------------------------------------------------- sympy (child)
def sympy_arm(n: int):
    """The arm in ``sympy.physics.mechanics`` with symbolic parameters:
    ``(KanesMethod, values)``."""
    q, u = me.dynamicsymbols(f"q1:{n + 1}"), me.dynamicsymbols(f"u1:{n + 1}")
    g = sm.Symbol("g")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    bodies, loads, values = [], [], {"g": link_parameters(n)["g"]}
    parent, joint, previous_joint = N, O, O
    for i in range(1, n + 1):
        names = [f"{k}{i}" for k in ("b", "m", "Ixx", "Iyy", "Izz", "Ixy", "Iyz", "Izx")]
        b, m, ixx, iyy, izz, ixy, iyz, izx = sm.symbols(names)
        L = parent.orientnew(f"L{i}", "Axis", [q[i - 1], parent.z if axis(i) == 3 else parent.y])
        L.set_ang_vel(parent, u[i - 1] * (parent.z if axis(i) == 3 else parent.y))
        if i > 1:
            a = sm.Symbol(f"a{i - 1}")
            joint = joint.locatenew(f"J{i}", a * parent.x)
            joint.v2pt_theory(previous_joint, N, parent)
        G = joint.locatenew(f"G{i}", b * L.x)
        G.v2pt_theory(joint, N, L)
        body = me.RigidBody(f"link{i}", G, L, m, (me.inertia(L, ixx, iyy, izz, ixy, iyz, izx), G))
        bodies.append(body)
        loads.append((G, -m * g * N.z))
        parent, previous_joint = L, joint
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(bodies, loads)
    values.update({k: val for k, val in link_parameters(n).items() if k != f"a{n}"})
    return kane, values


def _sympy_child(n: int, repeats: int, method: str, emit) -> None:
    t0 = time.perf_counter()
    kane, values = sympy_arm(n)
    M, F = kane.mass_matrix_full, kane.forcing_full
    emit("sympy_derive_s", time.perf_counter() - t0)
    exprs = list(M) + list(F)
    t0 = time.perf_counter()
    reps, reduced = sm.cse(exprs)
    emit("sympy_cse_s", time.perf_counter() - t0)
    emit("sympy_ops_after", count_ops_dag([e for _, e in reps])
         + sum(count_ops_dag([e]) for e in reduced))
    states = list(kane.q) + list(kane.u)
    params = sorted((s for s in sm.Matrix(exprs).free_symbols if s.name in values),
                    key=lambda s: s.name)
    t0 = time.perf_counter()
    M_fn = sm.lambdify([states, params], M, modules="numpy", cse=True)
    F_fn = sm.lambdify([states, params], F, modules="numpy", cse=True)
    emit("sympy_lambdify_s", time.perf_counter() - t0)
    q, v = state(n)
    x = np.concatenate([q, v])
    p = np.array([values[s.name] for s in params])

    def rhs():
        return np.linalg.solve(M_fn(x, p), F_fn(x, p)).ravel()

    emit("sympy_accelerations", rhs()[n:].tolist())
    emit("sympy_rhs_py_ns", per_call_ns(rhs, repeats))


def _child_main(argv: Sequence[str]) -> int:
    """``python -m mbgen.bench.arm SIDE N REPEATS METHOD``: JSON lines on stdout, one per result."""
    side, n, repeats, method = argv[0], int(argv[1]), int(argv[2]), argv[3]

    def emit(key, value):
        print(json.dumps({key: value}), flush=True)

    with threadpool_limits(limits=1):
        (_mbgen_child if side == "mbgen" else _sympy_child)(n, repeats, method, emit)
    return 0


def _run_child(side: str, n: int, repeats: int, method: str, budget_s: float,
               memory_gb: float) -> tuple[dict, str]:
    """Run one side in a child process; ``(results so far, status)``."""
    stages = (["derive_s", "bake_s", "cse_s", "render_s", "compile_s", "rhs_c_ns", "rhs_py_ns"]
              if side == "mbgen" else
              ["sympy_derive_s", "sympy_cse_s", "sympy_lambdify_s", "sympy_rhs_py_ns"])
    results, rc, error = children.run_json_child(
        ["-m", "mbgen.bench.arm", side, str(n), str(repeats), method], budget_s=budget_s,
        memory_gb=memory_gb, prefix="mbgen-arm-", seeded=side == "mbgen")
    return results, children.status(results, stages, rc, error, budget_s, width=120)


# ----------------------------------------------------------------------------- the benchmark
def arm_scaling(ns: Sequence[int] = (2, 4, 8, 16, 32), *, repeats: int = 7,
                budget_s: float = 300.0, sympy_budget_s: float = 120.0,
                memory_gb: float = 12.0, pinocchio: bool = True, cxx: bool = True,
                method: str = "newton_euler", jacobian: bool = False, casadi: bool = True,
                jacobian_method: str = "newton_euler",
                progress: Callable[[str], None] | None = None) -> list[ArmRow]:
    """Run the benchmark; one :class:`ArmRow` per ``n`` (see the module docstring).

    Parameters
    ----------
    budget_s, sympy_budget_s : float
        Wall-time budget of mbgen's and sympy's child process for one ``n``
        (0 skips that side; ``math.inf`` sets none, as the tests do: their verdicts must
        not depend on the machine's speed).  Once a side ran over its budget (or
        memory), larger ``n`` are not tried for it.
    memory_gb : float
        Address-space cap of each child process.
    pinocchio, cxx : bool
        Time Pinocchio from Python, and in a C++ loop (needs the ``bench`` extra).
    method : str
        mbgen's derivation method (``mbgen.Method`` value).
    jacobian : bool
        Also generate and time mbgen's Jacobian (a child under ``budget_s`` of its own,
        stopped for larger ``n`` like the RHS) against ``computeABADerivatives``
        (:mod:`mbgen.bench.arm_jacobian`), derived by ``jacobian_method`` (default the
        scene's Newton-Euler, whose Jacobian differentiates inverse dynamics: at n = 8,
        Kane's gave 67,363 operations after CSE against Newton-Euler's 10,272).
    casadi : bool
        Trace, generate, compile and time the arm's ABA with CasADi (its Jacobian too with
        ``jacobian``) under ``budget_s``, when ``casadi`` imports; else a note in the rows.
    """
    if method not in {m.value for m in Method}:
        raise BenchmarkError(f"unknown derivation method {method!r}; methods: "
                             f"{', '.join(m.value for m in Method)}")
    say = progress or (lambda message: None)
    rows = []
    with tempfile.TemporaryDirectory(prefix="mbgen-arm-aba-") as tmp:
        aba_exe = None
        if pinocchio and cxx:
            say("compiling Pinocchio's C++ aba loop")
            aba_exe = build_aba_driver(Path(tmp), repeats)
        mbgen_stopped = budget_s <= 0
        sympy_stopped = sympy_budget_s <= 0
        jac_stopped = budget_s <= 0 or not jacobian
        cas_stopped = budget_s <= 0 or not casadi or not have_casadi()
        if casadi and not have_casadi():
            say("casadi is not installed: the CasADi columns are skipped (pip install casadi)")
        for n in ns:
            row = ArmRow(n=n)
            q, v = state(n)
            ours = theirs = None
            if not mbgen_stopped:
                say(f"n={n}: mbgen")
                res, row.status = _run_child("mbgen", n, repeats, method, budget_s, memory_gb)
                ours = res.pop("accelerations", None)
                _fill(row, res)
                mbgen_stopped = row.status != "ok"
            else:
                row.status = _not_run(budget_s)
            block = None
            if not jac_stopped:
                say(f"n={n}: mbgen Jacobian")
                block = run_jacobian(row, np.concatenate([q, v]), repeats, jacobian_method,
                                     budget_s, memory_gb)
                jac_stopped = row.jac_status != "ok"
            elif jacobian and budget_s > 0:
                row.jac_status = "not run (stopped at a smaller n)"
            if not sympy_stopped:
                say(f"n={n}: sympy KanesMethod")
                res, row.sympy_status = _run_child("sympy", n, repeats, method, sympy_budget_s,
                                                   memory_gb)
                theirs = res.pop("sympy_accelerations", None)
                _fill(row, res)
                sympy_stopped = row.sympy_status != "ok"
            else:
                row.sympy_status = _not_run(sympy_budget_s)
            ddq = None
            if pinocchio:
                say(f"n={n}: Pinocchio")
                ddq = _pinocchio_columns(row, q, v, repeats, aba_exe, ours, block)
            if not cas_stopped:
                say(f"n={n}: CasADi")
                _casadi_columns(row, q, v, repeats, jacobian, budget_s, memory_gb,
                                ddq if ddq is not None else ours, block)
                cas_stopped = row.cas_status != "ok"
            else:
                _casadi_not_run(row, casadi, budget_s)
            if ours is not None and theirs is not None:
                row.max_abs_diff_sympy = float(np.max(np.abs(np.array(ours) - np.array(theirs))))
            rows.append(row)
    return rows


def _not_run(budget_s: float) -> str:
    """Status of a side not run for this ``n``: stopped at a smaller one, or off (budget 0)."""
    return "not run (stopped at a smaller n)" if budget_s > 0 else "not run"


def _casadi_not_run(row: ArmRow, casadi: bool, budget_s: float) -> None:
    """Status of the CasADi side when it is not run for ``row``."""
    if casadi and budget_s > 0 and have_casadi():
        row.cas_status = "not run (stopped at a smaller n)"
    elif casadi and not have_casadi():
        row.cas_status = "not run: casadi is not installed"


def _pinocchio_columns(row: ArmRow, q: np.ndarray, v: np.ndarray, repeats: int,
                       aba_exe: Path | None, ours, block) -> np.ndarray:
    """Time Pinocchio's ``aba`` for ``row`` (from Python, and in the C++ loop ``aba_exe``
    when built), compare it with mbgen's accelerations ``ours`` and Jacobian ``block``
    (either may be None); return Pinocchio's accelerations."""
    n = row.n
    pin = import_pinocchio()
    model = pinocchio_arm(n)
    data, tau = model.createData(), np.zeros(n)
    row.pin_py_ns = per_call_ns(lambda: pin.aba(model, data, q, v, tau), repeats)
    ddq = np.array(pin.aba(model, data, q, v, tau))
    if aba_exe is not None:
        row.pin_cxx_ns, ddq_cxx = run_aba_driver(aba_exe, n, q, v)
        if not np.allclose(ddq_cxx, ddq, rtol=1e-9, atol=1e-9):
            raise BenchmarkError(f"n={n}: Pinocchio's C++ loop and pin.aba disagree")
    if ours is not None:
        row.max_abs_diff_pin = float(np.max(np.abs(np.array(ours) - ddq)))
    if block is not None:
        if aba_exe is not None:
            row.pin_daba_ns, theirs_jac = run_aba_derivatives_driver(aba_exe, n, q, v)
        else:
            theirs_jac = pinocchio_aba_derivatives(n, q, v)
        row.jac_rel_diff_pin = relative_difference(block, theirs_jac)
    return ddq


def _casadi_columns(row: ArmRow, q: np.ndarray, v: np.ndarray, repeats: int, jacobian: bool,
                    budget_s: float, memory_gb: float, reference, block) -> None:
    """Run the CasADi child for ``row`` and compare its accelerations with ``reference``
    (Pinocchio's, else mbgen's) and its Jacobian with mbgen's ``block`` (either may be None)."""
    cas_ddq, cas_block = run_casadi(row, np.concatenate([q, v]), repeats, jacobian,
                                    budget_s, memory_gb)
    if cas_ddq is not None and reference is not None:
        row.max_abs_diff_cas = float(np.max(np.abs(cas_ddq - np.array(reference))))
    if cas_block is not None and block is not None:
        row.casjac_rel_diff = relative_difference(cas_block, block)


def _fill(row: ArmRow, results: dict) -> None:
    names = {f.name for f in fields(ArmRow)}
    for key, value in results.items():
        if key in names:
            setattr(row, key, value)


def growth_exponents(rows: Sequence[ArmRow]) -> dict[str, float]:
    """Least-squares slope of log(value) on log(n) per numeric column (two or more values)."""
    out = {}
    for f in fields(ArmRow):
        if f.name in ("n", "max_abs_diff_pin", "max_abs_diff_sympy", "max_abs_diff_cas",
                      "jac_rel_diff_pin", "casjac_rel_diff"):
            continue
        pts = [(r.n, getattr(r, f.name)) for r in rows
               if isinstance(getattr(r, f.name), (int, float))
               and not isinstance(getattr(r, f.name), bool)
               and getattr(r, f.name) > 0]
        if len(pts) >= 2 and len({n for n, _ in pts}) >= 2:
            x = np.log([n for n, _ in pts])
            y = np.log([v for _, v in pts])
            out[f.name] = float(np.polyfit(x, y, 1)[0])
    return out


_COLUMNS = (  # header, width, value
    ("n", 3, lambda r: f"{r.n}"),
    ("derive", 7, lambda r: _f(r.derive_s, ".2f")),
    ("bake", 6, lambda r: _f(r.bake_s, ".2f")),
    ("CSE", 7, lambda r: _f(r.cse_s, ".2f")),
    ("render", 6, lambda r: _f(r.render_s, ".2f")),
    ("compile", 7, lambda r: _f(r.compile_s, ".2f")),
    ("ops", 7, lambda r: _f(r.ops_after, "d")),
    ("ops/n", 6, lambda r: _f(None if r.ops_after is None else r.ops_after / r.n, ".0f")),
    ("C ns", 8, lambda r: _f(r.rhs_c_ns, ".0f")),
    ("py ns", 7, lambda r: _f(r.rhs_py_ns, ".0f")),
    ("pin C++", 7, lambda r: _f(r.pin_cxx_ns, ".0f")),
    ("pin py", 7, lambda r: _f(r.pin_py_ns, ".0f")),
    ("sp derive", 9, lambda r: _f(r.sympy_derive_s, ".2f")),
    ("sp CSE", 7, lambda r: _f(r.sympy_cse_s, ".2f")),
    ("sp lamb", 7, lambda r: _f(r.sympy_lambdify_s, ".2f")),
    ("sp py ns", 8, lambda r: _f(r.sympy_rhs_py_ns, ".0f")),
    ("|mb-pin|", 8, lambda r: _f(r.max_abs_diff_pin, ".0e")),
)

_EXPONENT_KEYS = {"derive": "derive_s", "bake": "bake_s", "CSE": "cse_s", "render": "render_s",
                  "compile": "compile_s", "ops": "ops_after", "C ns": "rhs_c_ns",
                  "py ns": "rhs_py_ns", "pin C++": "pin_cxx_ns", "pin py": "pin_py_ns",
                  "sp derive": "sympy_derive_s", "sp CSE": "sympy_cse_s",
                  "sp lamb": "sympy_lambdify_s", "sp py ns": "sympy_rhs_py_ns"}

LEGEND = """\
Stage times in s (each measured once); per-call times in ns (median of loops).
C ns: mbgen's <prefix>_rhs in a C loop; py ns: model.rhs from Python (crossing included);
pin C++ / pin py: Pinocchio's aba in a C++ loop / pin.aba from Python; sp: sympy KanesMethod
(derive, sympy.cse, lambdify, RHS = lambdified M, F + numpy.linalg.solve); '-': not reached.
|mb-pin|: largest difference of the joint accelerations, mbgen vs Pinocchio, at the timed state.
slope: least-squares growth exponent d log(value) / d log(n) over the n that finished."""


def _f(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def format_arm(rows: Sequence[ArmRow]) -> str:
    """Fixed-width table, growth exponents, each row's status, and the legend."""
    def line(cells):
        return "  ".join(f"{c:>{w}}" for c, (_, w, _) in zip(cells, _COLUMNS)).rstrip()

    header = line(h for h, _, _ in _COLUMNS)
    body = [line(fmt(r) for _, _, fmt in _COLUMNS) for r in rows]
    slopes = growth_exponents(rows)
    slope_cells = ["slope"] + [_f(slopes.get(_EXPONENT_KEYS.get(h, "")), ".2f")
                               for h, _, _ in _COLUMNS[1:]]
    slope_cells = [c if h in _EXPONENT_KEYS or h == "n" else "" for c, (h, _, _) in
                   zip(slope_cells, _COLUMNS)]
    status = [f"n={r.n}: mbgen {r.status}; sympy {r.sympy_status}" for r in rows]
    extra = format_extra(rows)
    return "\n".join([header, "-" * len(header), *body, line(slope_cells), "", *status, "",
                      LEGEND, f"Driver flags: {' '.join(DRIVER_FLAGS)}; BLAS threads pinned to 1."]
                     + (["", extra] if extra else []))


def write_csv(rows: Sequence[ArmRow], path: Path) -> Path:
    """One line per ``n`` with every :class:`ArmRow` field, then a ``slope`` line."""
    path = Path(path)
    names = [f.name for f in fields(ArmRow)]
    slopes = growth_exponents(rows)
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for r in rows:
            w.writerow(["" if v is None else v for v in asdict(r).values()])
        w.writerow(["slope"] + [("" if k not in slopes else f"{slopes[k]:.3f}") for k in names[1:]])
    return path


def plot(rows: Sequence[ArmRow], path: Path) -> Path:
    """Log-log plot: per-call RHS times (left) and operations after CSE (right) against n."""
    require_matplotlib()   # a named error when the bench extra is not installed
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    series = (("rhs_c_ns", "mbgen RHS in C"), ("rhs_py_ns", "mbgen RHS from Python"),
              ("pin_cxx_ns", "Pinocchio aba in C++"), ("pin_py_ns", "Pinocchio aba from Python"),
              ("sympy_rhs_py_ns", "sympy lambdify + solve"))
    for key, label in series:
        pts = [(r.n, getattr(r, key)) for r in rows if getattr(r, key) is not None]
        if pts:
            left.loglog(*zip(*pts), "o-", label=label)
    left.set(xlabel="links n", ylabel="ns per call", title="forward dynamics, one call")
    left.legend(fontsize=8)
    for key, label in (("ops_after", "mbgen"), ("sympy_ops_after", "sympy.cse")):
        pts = [(r.n, getattr(r, key)) for r in rows if getattr(r, key) is not None]
        if pts:
            right.loglog(*zip(*pts), "s-", label=label)
    right.set(xlabel="links n", ylabel="operations after CSE", title="RHS size")
    right.legend(fontsize=8)
    ns = [r.n for r in rows]
    for ax in (left, right):        # plain link counts on the x axis, no minor labels
        ax.set_xticks(ns, [str(n) for n in ns])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


if __name__ == "__main__":  # the child processes
    sys.exit(_child_main(sys.argv[1:]))
