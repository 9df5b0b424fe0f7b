"""Constraint benchmark (``mbgen bench constraints``): a four-body rolling vehicle, mbgen vs sympy,
and the four-bar's constraint residual against run time.

Vehicle: the Whipple bicycle of :mod:`mbgen.scenes.whipple` (rear frame, front frame, two
wheels; the front contact's height a configuration constraint, both wheels' rolling four
motion constraints; 8 coordinates, 3 independent speeds).  Both sides run in one call, each
in its own child process with a wall-clock budget (a side that runs past it is stopped
and reported as such, with the stage it was in):

mbgen (child ``mbgen``)
    *derive* (Kane, constraints kept as blocks), *bake* (the benchmark's numbers), *CSE*
    (the RHS: dependent speeds by LU in C, reduced equations by L D L^T), *render*,
    *compile* (an empty cache: the C compiler really runs), the operation count after CSE,
    and one RHS call timed inside C by a C driver loop (``templates/bench/rhs.c.j2``, no
    Python; median of ``repeats`` loops).  Then *linearise*: generate and compile the
    Jacobians (``jacobian``, ``holonomic_jacobian``) and call :func:`mbgen.linearize` at the
    steady upright run at 5 m/s (the call alone is reported too).
sympy (children ``sympy-rhs`` and ``sympy-lin``)
    The same bicycle in ``sympy.physics.mechanics``: ``KanesMethod`` with ``q_dependent``,
    ``configuration_constraints``, ``u_dependent`` and ``velocity_constraints`` and
    ``kanes_equations`` (*derive*); lambdify of the reduced ``mass_matrix`` and ``forcing``
    and a numerical solve, compared with mbgen's RHS at the same state (the check that
    both sides state the same model); then ``rhs()`` (the explicit RHS, ``M_full^-1 F_full``
    inverted symbolically) and ``lambdify(rhs, cse=True)``, one call timed from Python.
    ``sympy-lin`` derives again and times ``KanesMethod.linearize(A_and_B=True,
    op_point=..., simplify=False)`` at the same operating point; its A's nonzero
    eigenvalues are printed under mbgen's (when A is finite there: measured, it is not --
    see the table in docs/performance.md).

Four-bar (in this process): :mod:`mbgen.scenes.four_bar` from its start over 10 times its
span (50 s) with the C ``dopri5``, projection on and off, at a sweep of tolerances: the
largest residual ``max|f_h|`` met after a step (before projecting), the residual at the end,
the energy drift and the median wall time of ``repeats`` runs.

Wall time by ``time.perf_counter``; BLAS pinned to one thread in every child.  Symbolic
stages are measured once.  Timings on a shared machine are noisy: compare within one run.
"""

from __future__ import annotations

import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import sympy as sm
from sympy.physics import mechanics as me
from threadpoolctl import threadpool_limits

from ..abi import Output
from ..derivation import Method
from ..model.scene import load_scene
from ..pipeline import compile as compile_
from ..pipeline import run
from ..runtime.linearize import linearize
from ..scenes.whipple import PARAMETERS, upright_state
from . import children
from .timing import c_rhs_ns, per_call_ns, pipeline_timer, staged

#: Speed (m/s) of the steady upright run where both sides linearise and evaluate.
SPEED = 5.0
#: Tolerances of the four-bar residual table.
FOUR_BAR_RTOLS = (1e-4, 1e-6, 1e-8, 1e-10)


# ------------------------------------------------------------------------ the operating point
def operating_point() -> dict:
    """The state at which both sides are evaluated: upright at :data:`SPEED` with some roll,
    steer and their rates (so nothing vanishes by symmetry), completed by mbgen; plus all
    eight speeds (``q' = u``, so the RHS's first eight entries) and mbgen's ``u_s'``."""
    scn = load_scene("whipple")
    c = compile_(scn, ("rhs", "holonomic", "holonomic_jacobian"), name="whipple_conbench")
    x = np.zeros(c.n_x)
    named = dict(upright_state(SPEED), roll=0.05, steer=-0.03, w_roll=0.2, w_steer=-0.1)
    for k, v in named.items():
        x[c.state_names.index(k)] = v
    x = c.consistent(x)
    f = c.rhs(0.0, x)
    steady = np.zeros(c.n_x)
    for k, v in upright_state(SPEED).items():
        steady[c.state_names.index(k)] = v
    steady = c.consistent(steady)
    fs = c.rhs(0.0, steady)
    return dict(x=x.tolist(), speeds=f[:8].tolist(), accelerations=f[8:].tolist(),
                steady=steady.tolist(), steady_speeds=fs[:8].tolist())


# ------------------------------------------------------------------------------ mbgen (child)
def _mbgen_child(point: dict, repeats: int, emit) -> None:
    stage = staged(emit)

    scene = load_scene("whipple")
    counts = {"ops_before": "ops_before", "ops_after": "ops_after"}
    result = run(scene, (Output.RHS,), method=Method.KANE,
                 timer=pipeline_timer(emit, counts=counts))
    rendered, model = result.rendered, result.compiled
    layout = rendered.layout
    x = np.array(point["x"])
    p = model.default_parameters if layout.n_p else np.zeros(0)
    emit("accelerations", model.rhs(0.0, x, p)[8:].tolist())
    with tempfile.TemporaryDirectory(prefix="mbgen-conbench-driver-") as tmp:
        emit("rhs_c_ns", c_rhs_ns(rendered, x, p, np.zeros(0), repeats, Path(tmp)))
    t0 = time.perf_counter()
    lin_model = compile_(scene, ("rhs", "jacobian", "holonomic", "holonomic_jacobian"),
                         name="whipple_lin")
    emit("jacobians_s", time.perf_counter() - t0)
    steady = np.array(point["steady"])
    lin = stage("linearize_call_s", linearize, lin_model, steady)
    emit("linearize_s", time.perf_counter() - t0)
    ev = lin.eigenvalues[np.abs(lin.eigenvalues) > 1e-6]
    emit("eigenvalues", [[float(e.real), float(e.imag)] for e in np.sort_complex(ev)])


# ------------------------------------------------------------------------------ sympy (children)
def sympy_whipple():
    """The Whipple bicycle of :mod:`mbgen.scenes.whipple` in ``sympy.physics.mechanics``:
    ``(KanesMethod after kanes_equations, q, u, {constant symbol: value})``."""
    q = me.dynamicsymbols("x y yaw roll pitch steer theta_r theta_f")
    u = me.dynamicsymbols("vx vy w_yaw w_roll w_pitch w_steer w_r w_f")
    x, y, yaw, roll, pitch, steer, th_r, th_f = q
    vx, vy, w_yaw, w_roll, w_pitch, w_steer, w_r, w_f = u
    names = ("d1 d2 d3 rR rF g mB mH mR mF IRxx IRyy IFxx IFyy xB zB xH zH "
             "IBxx IByy IBzz IBxz IHxx IHyy IHzz IHxz")
    c = dict(zip(names.split(), sm.symbols(names)))
    N = me.ReferenceFrame("N")
    Y = N.orientnew("Y", "Axis", [yaw, N.z])
    L = Y.orientnew("L", "Axis", [roll, Y.x])
    R = L.orientnew("R", "Axis", [pitch, L.y])
    RW = R.orientnew("RW", "Axis", [th_r, R.y])
    F = R.orientnew("F", "Axis", [steer, R.z])
    FW = F.orientnew("FW", "Axis", [th_f, F.y])
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, x.diff() * N.x + y.diff() * N.y)
    CR = P.locatenew("CR", c["rR"] * L.z)
    CR.v2pt_theory(P, N, L)
    S = CR.locatenew("S", c["d1"] * R.x + c["d2"] * R.z)
    S.v2pt_theory(CR, N, R)
    CF = S.locatenew("CF", c["d3"] * F.x)
    CF.v2pt_theory(S, N, F)
    tilt = F.y.dot(N.z)
    k = (N.z - tilt * F.y) / sm.sqrt(1 - tilt**2)
    Q = CF.locatenew("Q", -c["rF"] * k)
    GB = CR.locatenew("GB", c["xB"] * R.x + c["zB"] * R.z)
    GB.v2pt_theory(CR, N, R)
    GH = CF.locatenew("GH", c["xH"] * F.x + c["zH"] * F.z)
    GH.v2pt_theory(CF, N, F)
    rear = CR.vel(N) + me.cross(RW.ang_vel_in(N), P.pos_from(CR))
    front = CF.vel(N) + me.cross(FW.ang_vel_in(N), Q.pos_from(CF))
    kd = [qi.diff() - ui for qi, ui in zip(q, u)]
    height = Q.pos_from(O).dot(N.z)
    vc = [rear.dot(N.x), rear.dot(N.y), front.dot(N.x), front.dot(N.y), front.dot(N.z)]
    bodies = [
        me.RigidBody("rear_frame", GB, R, c["mB"],
                     (me.inertia(R, c["IBxx"], c["IByy"], c["IBzz"], 0, 0, c["IBxz"]), GB)),
        me.RigidBody("front_frame", GH, F, c["mH"],
                     (me.inertia(F, c["IHxx"], c["IHyy"], c["IHzz"], 0, 0, c["IHxz"]), GH)),
        me.RigidBody("rear_wheel", CR, RW, c["mR"],
                     (me.inertia(RW, c["IRxx"], c["IRyy"], c["IRxx"]), CR)),
        me.RigidBody("front_wheel", CF, FW, c["mF"],
                     (me.inertia(FW, c["IFxx"], c["IFyy"], c["IFxx"]), CF))]
    loads = [(b.masscenter, -b.mass * c["g"] * N.z) for b in bodies]
    kane = me.KanesMethod(N, q_ind=[x, y, yaw, roll, steer, th_r, th_f], u_ind=[w_roll, w_steer,
                                                                                  w_r],
                          kd_eqs=kd, q_dependent=[pitch], configuration_constraints=[height],
                          u_dependent=[vx, vy, w_yaw, w_f, w_pitch], velocity_constraints=vc)
    kane.kanes_equations(bodies, loads)
    values = {c[k]: PARAMETERS[k] for k in c}
    return kane, list(q), list(u), values


def _sympy_rhs_child(point: dict, repeats: int, emit) -> None:
    t0 = time.perf_counter()
    kane, q, u, values = sympy_whipple()
    emit("sympy_derive_s", time.perf_counter() - t0)
    consts = list(values)
    args = [q + u, consts]
    t0 = time.perf_counter()
    M_fn = sm.lambdify(args, kane.mass_matrix, modules="numpy", cse=True)
    F_fn = sm.lambdify(args, kane.forcing, modules="numpy", cse=True)
    emit("sympy_lambdify_mf_s", time.perf_counter() - t0)
    state = np.array(point["x"][:8] + point["speeds"])
    p = np.array([values[s] for s in consts])
    acc = np.linalg.solve(M_fn(state, p), F_fn(state, p)).ravel()
    emit("sympy_accelerations", acc.tolist())
    t0 = time.perf_counter()
    rhs = kane.rhs()
    emit("sympy_rhs_s", time.perf_counter() - t0)
    t0 = time.perf_counter()
    rhs_fn = sm.lambdify(args, rhs, modules="numpy", cse=True)
    emit("sympy_lambdify_s", time.perf_counter() - t0)
    emit("sympy_rhs_py_ns", per_call_ns(lambda: rhs_fn(state, p), repeats))


def _sympy_lin_child(point: dict, repeats: int, emit) -> None:
    t0 = time.perf_counter()
    kane, q, u, values = sympy_whipple()
    emit("sympy_derive_s", time.perf_counter() - t0)
    steady, speeds = point["steady"], point["steady_speeds"]
    op = dict(zip(q, steady[:8])) | dict(zip(u, speeds))
    op |= {qi.diff(): v for qi, v in zip(q, speeds)}
    op |= {ui.diff(): 0.0 for ui in u}                      # a steady motion
    op |= values
    t0 = time.perf_counter()
    A = kane.linearize(A_and_B=True, op_point=op, simplify=False)[0]
    emit("sympy_linearize_s", time.perf_counter() - t0)
    A = np.array(A.subs(values).evalf(), dtype=float)
    ev = np.linalg.eigvals(A)
    ev = ev[np.abs(ev) > 1e-6]
    emit("sympy_eigenvalues", [[float(e.real), float(e.imag)] for e in np.sort_complex(ev)])


CHILDREN = {"mbgen": _mbgen_child, "sympy-rhs": _sympy_rhs_child, "sympy-lin": _sympy_lin_child}
#: Stages of each child in order (the first one missing is where a stopped child was).
STAGES = {"mbgen": ["derive_s", "bake_s", "cse_s", "render_s", "compile_s", "rhs_c_ns",
                    "jacobians_s", "linearize_s"],
          "sympy-rhs": ["sympy_derive_s", "sympy_lambdify_mf_s", "sympy_rhs_s",
                        "sympy_lambdify_s", "sympy_rhs_py_ns"],
          "sympy-lin": ["sympy_derive_s", "sympy_linearize_s"]}


def _child_main(argv: Sequence[str]) -> int:
    """``python -m mbgen.bench.constraints SIDE REPEATS``, the operating point as JSON on
    stdin."""
    side, repeats = argv[0], int(argv[1])
    point = json.loads(sys.stdin.read())

    def emit(key, value):
        print(json.dumps({key: value}), flush=True)

    with threadpool_limits(limits=1):
        CHILDREN[side](point, repeats, emit)
    return 0


def _run_child(side: str, point: dict, repeats: int, budget_s: float,
               memory_gb: float) -> tuple[dict, str, float]:
    """One side in a child process: ``(results so far, status, seconds)``."""
    start = time.perf_counter()
    results, rc, error = children.run_json_child(
        ["-m", "mbgen.bench.constraints", side, str(repeats)], budget_s=budget_s,
        memory_gb=memory_gb, stdin=json.dumps(point), prefix="mbgen-conbench-")
    seconds = time.perf_counter() - start
    return results, children.status(results, STAGES[side], rc, error, budget_s), seconds


# ------------------------------------------------------------------------------ four-bar
@dataclass(frozen=True)
class ResidualRow:
    """One four-bar run: tolerance, projection, residuals, energy drift, wall time."""

    rtol: float
    project: bool
    max_residual: float        # largest max|f_h| after a step, before projecting
    final_residual: float      # max|f_h| at the end
    energy_drift: float        # max |E - E0| over the output times
    time_s: float              # median wall time of one run
    n_rhs: int


def four_bar_residuals(rtols: Sequence[float] = FOUR_BAR_RTOLS, *, repeats: int = 5,
                       span_factor: float = 10.0) -> list[ResidualRow]:
    """The four-bar from its start over ``span_factor`` times its span, projection on and off."""
    scn = load_scene("four_bar")
    c = compile_(scn, ("rhs", "energy", "dopri5"), name="four_bar_conbench")
    x0 = c.consistent(scn.x0(c.layout))
    t = np.linspace(scn.t_span[0], scn.t_span[0] + span_factor * (scn.t_span[1] - scn.t_span[0]),
                    201)
    rows = []
    for rtol in rtols:
        for project in (True, False):
            kw = dict(rtol=rtol, atol=rtol * 1e-2, project=project)
            run = c.integrate("dopri5", t, x0, **kw)
            times = []
            for _ in range(repeats):
                times.append(c.integrate("dopri5", t, x0, **kw).wall_time)
            energy = np.array([sum(c.energy(0.0, x)) for x in run.x])
            rows.append(ResidualRow(rtol, project, run.max_residual,
                                    float(np.max(np.abs(c.holonomic(t[-1], run.x[-1])))),
                                    float(np.max(np.abs(energy - energy[0]))),
                                    statistics.median(times), run.n_rhs))
    return rows


# ------------------------------------------------------------------------------ the benchmark
@dataclass
class ConstraintBench:
    """Everything :func:`constraint_bench` measured (``sides``: results, status, seconds)."""

    point: dict
    sides: dict = field(default_factory=dict)
    four_bar: list = field(default_factory=list)
    budget_s: float = 0.0

    def to_json(self) -> str:
        """Every raw result (per side: results, status, seconds; the four-bar rows)."""
        return json.dumps(dict(point=self.point, sides={
            k: dict(results=r, status=s, seconds=sec) for k, (r, s, sec) in self.sides.items()},
            four_bar=[asdict(r) for r in self.four_bar]), indent=1) + "\n"


def constraint_bench(*, repeats: int = 7, budget_s: float = 300.0, sympy_budget_s: float = 300.0,
                     memory_gb: float = 12.0,
                     progress: Callable[[str], None] | None = None) -> ConstraintBench:
    """Run the vehicle (mbgen, sympy rhs, sympy linearize) and the four-bar table; see the module
    docstring.  ``sympy_budget_s = 0`` leaves sympy out."""
    say = progress or (lambda message: None)
    say("operating point (mbgen)")
    point = operating_point()
    out = ConstraintBench(point, budget_s=sympy_budget_s)
    sides = [("mbgen", budget_s)] + ([("sympy-rhs", sympy_budget_s), ("sympy-lin", sympy_budget_s)]
                                     if sympy_budget_s > 0 else [])
    for side, budget in sides:
        say(f"{side} (budget {budget:g} s)")
        out.sides[side] = _run_child(side, point, repeats, budget, memory_gb)
    say("four-bar residual against run time")
    out.four_bar = four_bar_residuals(repeats=max(3, repeats // 2))
    return out


def _s(results: dict, key: str, scale: float = 1.0, spec: str = ".2f") -> str:
    value = results.get(key)
    return "-" if value is None else format(value * scale, spec)


def format_bench(b: ConstraintBench) -> str:
    """The closing-note tables: the vehicle side by side, then the four-bar residuals."""
    mb, mb_status, mb_s = b.sides.get("mbgen", ({}, "not run", 0.0))
    sr, sr_status, sr_s = b.sides.get("sympy-rhs", ({}, "not run", 0.0))
    sl, sl_status, sl_s = b.sides.get("sympy-lin", ({}, "not run", 0.0))
    lines = ["Whipple bicycle (4 bodies, 2 rolling contacts: 1 configuration + 4 motion "
             "constraints, 3 dof)", ""]
    rows = [("derive (s)", _s(mb, "derive_s"), _s(sr, "sympy_derive_s")),
            ("bake (s)", _s(mb, "bake_s"), ""),
            ("CSE (s)", _s(mb, "cse_s"), ""),
            ("render (s)", _s(mb, "render_s"), ""),
            ("compile (s)", _s(mb, "compile_s"), ""),
            ("ops before -> after CSE",
             f"{mb.get('ops_before', '-')} -> {mb.get('ops_after', '-')}", ""),
            ("lambdify reduced M, F (s)", "", _s(sr, "sympy_lambdify_mf_s")),
            ("explicit RHS: rhs() (s)", "", _s(sr, "sympy_rhs_s")),
            ("lambdify(rhs) (s)", "", _s(sr, "sympy_lambdify_s")),
            ("RHS call (us)", _s(mb, "rhs_c_ns", 1e-3, ".2f") + " (in C)",
             _s(sr, "sympy_rhs_py_ns", 1e-3, ".1f") + " (Python)"),
            ("linearise: Jacobians generated+compiled (s)", _s(mb, "jacobians_s"), ""),
            ("linearise: call (ms)", _s(mb, "linearize_call_s", 1e3, ".2f"), ""),
            ("linearise: total (s)", _s(mb, "linearize_s"), _s(sl, "sympy_linearize_s"))]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows + [("", "mbgen", "")])
    lines.append(f"{'':<{w0}}  {'mbgen':>{w1}}  sympy.physics.mechanics")
    lines += [f"{a:<{w0}}  {b_:>{w1}}  {c}" for a, b_, c in rows]
    lines += ["", f"mbgen: {mb_status} ({mb_s:.1f} s)",
              f"sympy rhs: {sr_status} ({sr_s:.1f} s)",
              f"sympy linearize: {sl_status} ({sl_s:.1f} s)"]
    ours = np.array(b.point["accelerations"])
    if "sympy_accelerations" in sr:
        theirs = np.array(sr["sympy_accelerations"])[:ours.size]     # u_ind come first
        diff = np.max(np.abs(theirs - ours))
        lines.append(f"check: u_s' of the two sides at the same state differ by {diff:.1e} "
                     f"(|u_s'| = {np.max(np.abs(ours)):.3g})")
    if "eigenvalues" in mb:
        lines.append("mbgen eigenvalues at the steady run, 5 m/s: " + ", ".join(
            f"{re:.6f}{im:+.6f}i" for re, im in mb["eigenvalues"]))
    if "sympy_eigenvalues" in sl:
        lines.append("sympy eigenvalues at the same point:         " + ", ".join(
            f"{re:.6f}{im:+.6f}i" for re, im in sl["sympy_eigenvalues"]))
    lines += ["", "Four-bar, C dopri5 over 50 s (10x the scene's span): constraint residual "
                  "against run time",
              f"{'rtol':>7}  {'projection':>10}  {'max |f_h| per step':>18}  {'|f_h| at end':>12}"
              f"  {'energy drift':>12}  {'RHS calls':>9}  {'time (ms)':>9}"]
    for r in b.four_bar:
        lines.append(f"{r.rtol:>7.0e}  {'on' if r.project else 'off':>10}  {r.max_residual:>18.2e}"
                     f"  {r.final_residual:>12.2e}  {r.energy_drift:>12.2e}  {r.n_rhs:>9d}"
                     f"  {r.time_s * 1e3:>9.3f}")
    lines.append("BLAS threads pinned to 1 in every child; times: perf_counter, symbolic stages "
                 "once, RHS and runs medians.")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(_child_main(sys.argv[1:]))
