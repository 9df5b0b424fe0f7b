"""The arm benchmark's Jacobian and CasADi columns (``mbgen bench arm --jacobian``, CasADi).

mbgen's Jacobian (a child process per ``n``, ``python -m mbgen.bench.arm_jacobian``,
under the same budget and memory cap as the RHS side)
    *derive*, *bake*, *CSE* (``optimize`` of ``Output.JACOBIAN`` alone), *render*,
    *compile*: the Jacobian's own generation from the scene by :func:`mbgen.pipeline.run`,
    each stage timed once; its
    operations after CSE (the header's count: the ``L D L^T`` solve excluded); and
    ``<prefix>_jacobian`` (``df/dx`` of the first-order RHS, row-major ``n_x x n_x``)
    timed inside C by :func:`mbgen.bench.timing.c_function_ns`, twice: its source compiled
    with the driver's flags (``jac_c_ns``) and with those of the user's module
    (``jac_own_ns``, :func:`mbgen.build.extension.model_flags`: -O2, -O1 where a function
    is longer than :data:`~mbgen.build.extension.LARGE_FUNCTION_CHARS`).  Its lower ``n`` rows,
    ``[du'/dq, du'/du]`` at the timed state, go back to the parent.
Pinocchio
    ``pinocchio::computeABADerivatives`` in the C++ loop of
    :func:`~mbgen.bench.arm_pinocchio.run_aba_derivatives_driver` (the executable, flags
    and state of the ``aba`` loop); its ``[ddq_dq, ddq_dv]`` is compared with mbgen's
    block: :func:`relative_difference`, the largest difference over the largest entry.
CasADi (:mod:`mbgen.bench.arm_casadi`, when ``casadi`` imports)
    the arm's ABA traced on SX, generated, compiled and timed in a C loop; with the
    Jacobian, ``casadi.jacobian`` of it too.  Its accelerations are compared with
    Pinocchio's ``aba`` (or mbgen's), its Jacobian with mbgen's block.

:func:`format_extra` prints two tables below the main one: the Jacobian against
``computeABADerivatives``, and generation time, size and speed against CasADi.
"""

from __future__ import annotations

import json
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ..abi import Output
from ..build.extension import model_flags
from ..derivation import Method
from ..pipeline import run
from ..scenes.spatial_arm import scene as arm_scene
from . import children
from .arm_casadi import have_casadi
from .timing import c_function_ns, pipeline_timer

JAC_STAGES = ("jac_derive_s", "jac_bake_s", "jac_cse_s", "jac_render_s", "jac_compile_s",
              "jac_c_ns", "jac_own_ns")
CAS_STAGES = ("cas_trace_s", "cas_generate_s", "cas_compile_s", "cas_c_ns")
CASJAC_STAGES = ("casjac_trace_s", "casjac_generate_s", "casjac_compile_s", "casjac_c_ns")


def relative_difference(ours, theirs) -> float:
    """``max |ours - theirs| / max(1e-300, max |theirs|)``: the largest difference, scaled."""
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)
    return float(np.max(np.abs(ours - theirs)) / max(1e-300, float(np.max(np.abs(theirs)))))


# ----------------------------------------------------------------------------- mbgen (child)
def _jacobian_child(n: int, repeats: int, method: str, x: np.ndarray, emit) -> None:
    scene = replace(arm_scene(n), outputs=(Output.JACOBIAN,))
    result = run(scene, method=Method(method),
                 timer=pipeline_timer(emit, "jac_", counts={"ops_after": "jac_ops"}))
    rendered, model = result.rendered, result.compiled
    layout = rendered.layout
    p = np.array([rendered.defaults[k] for k in layout.parameter_names])
    r = np.zeros(layout.n_r)
    emit("jac_block", np.asarray(model.jacobian(0.0, x, p, r))[n:].tolist())
    for key, flags in (("jac_c_ns", None), ("jac_own_ns", model_flags(rendered))):
        with tempfile.TemporaryDirectory(prefix="mbgen-arm-jac-driver-") as tmp:
            emit(key, c_function_ns(rendered, "jacobian", layout.n_x ** 2, x, p, r, repeats,
                                    Path(tmp), model_flags=flags))


def _child_main(argv: Sequence[str]) -> int:
    """``python -m mbgen.bench.arm_jacobian N REPEATS METHOD`` (x as JSON on stdin)."""
    n, repeats, method = int(argv[0]), int(argv[1]), argv[2]
    x = np.array(json.loads(sys.stdin.read()))

    def emit(key, value):
        print(json.dumps({key: value}), flush=True)

    with threadpool_limits(limits=1):
        _jacobian_child(n, repeats, method, x, emit)
    return 0


# ----------------------------------------------------------------------------- the parent
def _set(row, results: dict) -> None:
    for key, value in results.items():
        if hasattr(row, key) and not isinstance(value, list):
            setattr(row, key, value)


def run_jacobian(row, x: np.ndarray, repeats: int, method: str, budget_s: float,
                 memory_gb: float) -> np.ndarray | None:
    """mbgen's Jacobian side for ``row.n``: fills ``row.jac_*``; its ``n x 2n`` block or None."""
    results, rc, error = children.run_json_child(
        ["-m", "mbgen.bench.arm_jacobian", str(row.n), str(repeats), method],
        budget_s=budget_s, memory_gb=memory_gb, stdin=json.dumps(x.tolist()),
        prefix="mbgen-arm-jac-", seeded=True)
    _set(row, results)
    row.jac_status = children.status(results, JAC_STAGES, rc, error, budget_s, width=120)
    block = results.get("jac_block")
    return None if block is None else np.array(block)


def run_casadi(row, x: np.ndarray, repeats: int, jacobian: bool, budget_s: float,
               memory_gb: float) -> tuple[np.ndarray | None, np.ndarray | None]:
    """CasADi's side for ``row.n``: fills ``row.cas*``; ``(accelerations, Jacobian block)``."""
    if not have_casadi():
        row.cas_status = "not run: casadi is not installed (pip install casadi)"
        return None, None
    results, rc, error = children.run_json_child(
        ["-m", "mbgen.bench.arm_casadi", str(row.n), str(repeats), "1" if jacobian else "0"],
        budget_s=budget_s, memory_gb=memory_gb, stdin=json.dumps(x.tolist()),
        prefix="mbgen-arm-casadi-")
    _set(row, results)
    stages = CAS_STAGES + (CASJAC_STAGES if jacobian else ())
    row.cas_status = children.status(results, stages, rc, error, budget_s, width=120)
    ddq, block = results.get("cas_accelerations"), results.get("casjac_block")
    return (None if ddq is None else np.array(ddq)), (None if block is None else np.array(block))


# ----------------------------------------------------------------------------- the tables
def _f(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def _sum(*values):
    return None if any(v is None for v in values) else sum(values)


def _ratio(a, b):
    return None if a is None or b is None else a / b


def mbgen_generation_s(row) -> float | None:
    """mbgen's RHS generation, derive through compile (s)."""
    return _sum(row.derive_s, row.bake_s, row.cse_s, row.render_s, row.compile_s)


def jacobian_generation_s(row) -> float | None:
    """mbgen's Jacobian generation from the scene, derive through compile (s)."""
    return _sum(row.jac_derive_s, row.jac_bake_s, row.jac_cse_s, row.jac_render_s,
                row.jac_compile_s)


_JAC_COLUMNS = (
    ("n", 3, lambda r: f"{r.n}"),
    ("derive", 7, lambda r: _f(r.jac_derive_s, ".2f")),
    ("bake", 6, lambda r: _f(r.jac_bake_s, ".2f")),
    ("CSE", 7, lambda r: _f(r.jac_cse_s, ".2f")),
    ("render", 6, lambda r: _f(r.jac_render_s, ".2f")),
    ("compile", 7, lambda r: _f(r.jac_compile_s, ".2f")),
    ("gen s", 7, lambda r: _f(jacobian_generation_s(r), ".2f")),
    ("ops", 8, lambda r: _f(r.jac_ops, "d")),
    ("jac C ns", 9, lambda r: _f(r.jac_c_ns, ".0f")),
    ("module ns", 9, lambda r: _f(r.jac_own_ns, ".0f")),
    ("dABA C++", 9, lambda r: _f(r.pin_daba_ns, ".0f")),
    ("mb/pin", 6, lambda r: _f(_ratio(r.jac_c_ns, r.pin_daba_ns), ".2f")),
    ("mod/pin", 7, lambda r: _f(_ratio(r.jac_own_ns, r.pin_daba_ns), ".2f")),
    ("rel diff", 8, lambda r: _f(r.jac_rel_diff_pin, ".0e")),
)

_CAS_COLUMNS = (
    ("n", 3, lambda r: f"{r.n}"),
    ("mb gen s", 8, lambda r: _f(mbgen_generation_s(r), ".2f")),
    ("cas trace", 9, lambda r: _f(r.cas_trace_s, ".3f")),
    ("generate", 8, lambda r: _f(r.cas_generate_s, ".3f")),
    ("cc -O3", 7, lambda r: _f(r.cas_compile_s, ".2f")),
    ("cc -O1", 7, lambda r: _f(r.cas_compile_o1_s, ".2f")),
    ("cas gen s", 9, lambda r: _f(_sum(r.cas_trace_s, r.cas_generate_s, r.cas_compile_s),
                                  ".2f")),
    ("mb ops", 7, lambda r: _f(r.ops_after, "d")),
    ("cas ops", 7, lambda r: _f(r.cas_ops, "d")),
    ("mb C ns", 8, lambda r: _f(r.rhs_c_ns, ".0f")),
    ("cas C ns", 8, lambda r: _f(r.cas_c_ns, ".0f")),
    ("|cas-pin|", 9, lambda r: _f(r.max_abs_diff_cas, ".0e")),
)

_CASJAC_COLUMNS = (
    ("n", 3, lambda r: f"{r.n}"),
    ("mb gen s", 8, lambda r: _f(jacobian_generation_s(r), ".2f")),
    ("cas trace", 9, lambda r: _f(r.casjac_trace_s, ".3f")),
    ("generate", 8, lambda r: _f(r.casjac_generate_s, ".3f")),
    ("cc -O3", 7, lambda r: _f(r.casjac_compile_s, ".2f")),
    ("cc -O1", 7, lambda r: _f(r.casjac_compile_o1_s, ".2f")),
    ("cas gen s", 9, lambda r: _f(_sum(r.casjac_trace_s, r.casjac_generate_s,
                                       r.casjac_compile_s), ".2f")),
    ("mb ops", 8, lambda r: _f(r.jac_ops, "d")),
    ("cas ops", 8, lambda r: _f(r.casjac_ops, "d")),
    ("mb C ns", 8, lambda r: _f(r.jac_c_ns, ".0f")),
    ("cas C ns", 8, lambda r: _f(r.casjac_c_ns, ".0f")),
    ("rel diff", 8, lambda r: _f(r.casjac_rel_diff, ".0e")),
)

LEGEND = """\
Jacobian: mbgen's <prefix>_jacobian (df/dx, n_x x n_x) generated alone from the scene by
Newton-Euler (gen s: derive..compile) and timed in a C loop, its source compiled with the
driver flags (jac C ns) and with the flags of the user's module (module ns: -O2, -O1 for a
function too long); dABA C++: pinocchio::computeABADerivatives in the C++ loop; mb/pin,
mod/pin: the ratios of the two to it; rel diff: max |mbgen - Pinocchio| / max |Pinocchio| over
[ddq_dq, ddq_dv] and mbgen's lower n rows, at the timed state.
CasADi: the arm's ABA traced on casadi.SX (Function option cse), Function.generate, cc -c with
the driver flags (cc -O3; cc -O1 apart), timed in a C loop; cas gen s = trace + generate +
cc -O3; mb gen s = mbgen's derive..compile (a plain library, -O2; long functions in parts;
a new process, its cache holding what it holds once per install: the crossing, compiled
templates).  ops: mbgen's after CSE; CasADi's instructions less inputs, outputs and
constants.  |cas-pin|: largest difference of the accelerations from Pinocchio's aba (mbgen's
where Pinocchio is out)."""


def _table(title: str, columns, rows) -> list[str]:
    def line(cells):
        return "  ".join(f"{c:>{w}}" for c, (_, w, _) in zip(cells, columns)).rstrip()

    header = line(h for h, _, _ in columns)
    return [title, header, "-" * len(header), *(line(fmt(r) for _, _, fmt in columns)
                                               for r in rows), ""]


def format_extra(rows) -> str:
    """The Jacobian and CasADi tables, each only where one of its sides ran; '' if none."""
    out = []
    if any(r.jac_status != "not run" for r in rows):
        out += _table("Jacobian: mbgen vs Pinocchio's computeABADerivatives", _JAC_COLUMNS, rows)
    if any(r.cas_status != "not run" for r in rows):
        out += _table("Generation vs CasADi: RHS", _CAS_COLUMNS, rows)
        if any(r.casjac_trace_s is not None for r in rows):
            out += _table("Generation vs CasADi: Jacobian", _CASJAC_COLUMNS, rows)
    if not out:
        return ""
    status = [f"n={r.n}: jacobian {r.jac_status}; casadi {r.cas_status}" for r in rows]
    return "\n".join(out + status + ["", LEGEND])


if __name__ == "__main__":  # the child processes
    sys.exit(_child_main(sys.argv[1:]))
