"""CasADi's side of the arm benchmark: the arm's ABA traced on ``casadi.SX``, generated
and compiled.

The ``pin`` wheel has no ``pinocchio.casadi``, so :func:`aba_sx` writes the
articulated-body algorithm out here, from the textbook's three passes (velocities and
bias terms outward, articulated inertias and bias forces inward, accelerations
outward), on spatial vectors ``(angular, linear)`` in each link's frame, for the arm of
:mod:`mbgen.scenes.spatial_arm` (the numbers of :func:`~mbgen.bench.arm_pinocchio.link_rows`).
As in mbgen's code, every value is a constant but the last mass ``m{n}`` and ``g``: the
inputs are ``x = [q, u]`` and ``p = [m{n}, g]``.

:func:`casadi_side` measures, for one ``n``:

*trace*
    building the SX graph and the ``casadi.Function`` (option ``cse``: common
    subexpressions merged), for the RHS ``u'`` (``n`` outputs) and, with ``jacobian``,
    for ``casadi.jacobian(u', [q; u])`` (``n x 2n``, dense);
*generate*
    ``Function.generate`` (C with a header);
*compile*
    ``cc -c`` of that C with :data:`~mbgen.bench.timing.DRIVER_FLAGS` (``-O3
    -march=native``), the object the timed loop links; and once more at ``-O1`` (reported
    apart: gcc's time at ``-O3`` grows fast with one long function);
*ops*
    the Function's instructions less its inputs, outputs and constants
    (``n_instructions`` and ``instruction_id``);
*C loop*
    ns per call of the generated function in a C driver (``templates/bench/casadi.c.j2``)
    timed like :func:`mbgen.bench.timing.c_rhs_ns`, and its output at the timed state.

It runs in a child process (``python -m mbgen.bench.arm_casadi``) under the benchmark's
budget; ``casadi`` is optional (the ``bench`` extra): :func:`have_casadi` says whether
it imports.
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..build.extension import compiler
from ..codegen.templating import environment
from ..errors import BenchmarkError
from ..scenes.spatial_arm import link_parameters
from .arm_pinocchio import link_rows
from .timing import DRIVER_FLAGS, MIN_LOOP_S, median_ns, run_driver


def have_casadi() -> bool:
    """Whether ``casadi`` is importable (the optional CasADi column)."""
    return importlib.util.find_spec("casadi") is not None


def _skew(ca, r):
    return ca.vertcat(ca.horzcat(0, -r[2], r[1]), ca.horzcat(r[2], 0, -r[0]),
                      ca.horzcat(-r[1], r[0], 0))


def _rotation(ca, axis: int, angle):
    """The child's axes in the parent's frame: a turn by ``angle`` about z (3) or y (2)."""
    c, s = ca.cos(angle), ca.sin(angle)
    if axis == 3:
        return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def _cross_motion(ca, v):
    """The 6x6 matrix of ``v x`` acting on motion vectors ``(angular, linear)``."""
    w, lin, zero = _skew(ca, v[:3]), _skew(ca, v[3:]), ca.SX.zeros(3, 3)
    return ca.vertcat(ca.horzcat(w, zero), ca.horzcat(lin, w))


def aba_sx(n: int, x, p):
    """Joint accelerations ``u'`` (SX, ``n``) of the unactuated arm at ``x = [q, u]``.

    ``p = [m{n}, g]``.  Link ``i``'s frame sits at its joint; the parent-to-child motion
    transform is ``X = [[E', 0], [-E' [r]x, E']]`` with ``E`` the joint's rotation and ``r``
    the joint's offset in the parent's frame; forces go back by ``X'``.  Gravity enters as
    the base's acceleration ``(0, 0, 0, 0, 0, g)``.
    """
    import casadi as ca

    q, u = x[:n], x[n:]
    X, S, v, c, IA, pA = [], [], [], [], [], []
    for i, (ax, a, b, m, ixx, iyy, izz, ixy, iyz, izx) in enumerate(link_rows(n)):
        m = p[0] if i == n - 1 else m
        Et = _rotation(ca, ax, q[i]).T
        r = ca.vertcat(a, 0, 0)
        X.append(ca.vertcat(ca.horzcat(Et, ca.SX.zeros(3, 3)),
                            ca.horzcat(-ca.mtimes(Et, _skew(ca, r)), Et)))
        s = ca.SX.zeros(6, 1)
        s[2 if ax == 3 else 1] = 1               # the joint axis, z or y
        S.append(s)
        v_parent = v[i - 1] if i else ca.SX.zeros(6, 1)
        v.append(ca.mtimes(X[i], v_parent) + s * u[i])
        c.append(ca.mtimes(_cross_motion(ca, v[i]), s * u[i]))
        cx = _skew(ca, ca.vertcat(b, 0, 0))
        inertia = ca.SX(np.array([[ixx, ixy, izx], [ixy, iyy, iyz], [izx, iyz, izz]]))
        IA.append(ca.vertcat(ca.horzcat(inertia + m * ca.mtimes(cx, cx.T), m * cx),
                             ca.horzcat(m * cx.T, m * ca.SX.eye(3))))
        pA.append(-ca.mtimes(_cross_motion(ca, v[i]).T, ca.mtimes(IA[i], v[i])))
    U, D, w = [None] * n, [None] * n, [None] * n
    for i in reversed(range(n)):
        U[i] = ca.mtimes(IA[i], S[i])
        D[i] = ca.mtimes(S[i].T, U[i])
        w[i] = -ca.mtimes(S[i].T, pA[i])                 # tau = 0
        if i:
            Ia = IA[i] - ca.mtimes(U[i], U[i].T) / D[i]
            pa = pA[i] + ca.mtimes(Ia, c[i]) + U[i] * w[i] / D[i]
            IA[i - 1] = IA[i - 1] + ca.mtimes(X[i].T, ca.mtimes(Ia, X[i]))
            pA[i - 1] = pA[i - 1] + ca.mtimes(X[i].T, pa)
    acc, udot = ca.vertcat(0, 0, 0, 0, 0, p[1]), []
    for i in range(n):
        a_i = ca.mtimes(X[i], acc) + c[i]
        udot.append((w[i] - ca.mtimes(U[i].T, a_i)) / D[i])
        acc = a_i + S[i] * udot[i]
    return ca.vertcat(*udot)


def count_ops(f) -> int:
    """Arithmetic instructions of an SX ``casadi.Function``: all but inputs, outputs, constants."""
    import casadi as ca

    skip = {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST, ca.OP_PARAMETER}
    return sum(f.instruction_id(k) not in skip for k in range(f.n_instructions()))


def _compile(source: Path, obj: Path, level: tuple[str, ...]) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run([compiler(), "-std=c99", *level, "-fPIC", "-c", str(source), "-o",
                           str(obj)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise BenchmarkError(f"compiling CasADi's C failed:\n{proc.stderr[-3000:]}")
    return time.perf_counter() - t0


def time_function(ca, name: str, inputs, output, traced_s: float, x, p, repeats: int,
                  folder: Path, emit, key: str) -> np.ndarray:
    """Make, generate, compile and time one Function; emits ``{key}_*``; its output at x.

    ``traced_s``: the seconds the SX graph of ``output`` took; the trace time reported
    adds the Function's construction (its CSE) to it.
    """
    t0 = time.perf_counter()
    f = ca.Function(name, inputs, [ca.densify(output)], {"cse": True})
    emit(f"{key}_trace_s", traced_s + time.perf_counter() - t0)
    emit(f"{key}_ops", count_ops(f))
    t0 = time.perf_counter()
    generator = ca.CodeGenerator(f"{name}.c", {"with_header": True})
    generator.add(f)
    generator.generate(f"{folder}/")
    emit(f"{key}_generate_s", time.perf_counter() - t0)
    source = folder / f"{name}.c"
    emit(f"{key}_compile_s", _compile(source, folder / f"{name}.o", DRIVER_FLAGS))
    n_out = output.numel()
    driver = environment().get_template("bench/casadi.c.j2").render(
        name=name, n_x=len(x), n_p=len(p), n_out=n_out, x=[repr(float(v)) for v in x],
        p=[repr(float(v)) for v in p], min_loop_s=MIN_LOOP_S, repeats=repeats,
        flags=" ".join(DRIVER_FLAGS))
    (folder / "bench_casadi.c").write_text(driver, encoding="utf-8")
    exe = folder / f"bench_{name}"
    proc = subprocess.run([compiler(), "-std=c99", *DRIVER_FLAGS, "-o", str(exe),
                           "bench_casadi.c", f"{name}.o", "-lm"], cwd=folder,
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise BenchmarkError(f"compiling CasADi's driver failed:\n{proc.stderr[-3000:]}")
    out = run_driver([str(exe)], "CasADi's C loop")
    emit(f"{key}_c_ns", median_ns(out))
    values = next(s for s in out.splitlines() if s.startswith("out ")).split()[1:]
    emit(f"{key}_compile_o1_s", _compile(source, folder / f"{name}_O1.o", ("-O1",)))
    # CasADi writes dense matrices column by column
    return np.array([float(s) for s in values]).reshape(output.shape, order="F")


def casadi_side(n: int, x: np.ndarray, repeats: int, jacobian: bool, emit) -> None:
    """CasADi's RHS (and Jacobian) for one ``n``; ``emit(key, value)`` as each is known."""
    import casadi as ca

    p = np.array([link_parameters(n)[f"m{n}"], link_parameters(n)["g"]])
    with tempfile.TemporaryDirectory(prefix="mbgen-arm-casadi-") as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        xs, ps = ca.SX.sym("x", 2 * n), ca.SX.sym("p", 2)
        udot = aba_sx(n, xs, ps)
        rhs = time_function(ca, "arm_aba", [xs, ps], udot, time.perf_counter() - t0, x, p,
                            repeats, folder, emit, "cas")
        emit("cas_accelerations", rhs.ravel().tolist())
        if jacobian:
            t0 = time.perf_counter()
            jac = ca.jacobian(udot, xs)
            J = time_function(ca, "arm_aba_jac", [xs, ps], jac, time.perf_counter() - t0, x, p,
                              repeats, folder, emit, "casjac")
            emit("casjac_block", J.tolist())


def _child_main(argv) -> int:
    """``python -m mbgen.bench.arm_casadi N REPEATS JACOBIAN`` (x as JSON on stdin)."""
    n, repeats, jacobian = int(argv[0]), int(argv[1]), argv[2] == "1"
    x = np.array(json.loads(sys.stdin.read()))

    def emit(key, value):
        print(json.dumps({key: value}), flush=True)

    casadi_side(n, x, repeats, jacobian, emit)
    return 0


if __name__ == "__main__":  # the child process
    sys.exit(_child_main(sys.argv[1:]))
