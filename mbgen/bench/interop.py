r"""``mbgen bench interop``: mbgen's dynamics inside CasADi and JAX, against the peers' own.

*NLP* (:func:`nlp_rows`): one direct multiple-shooting problem per robot -- the arm of
:mod:`mbgen.scenes.spatial_arm` with a torque at every joint (``n = 7``), and UR5 (its
URDF, torques as inputs) -- from a bent pose at rest to a goal pose at rest in ``T = 1 s``,
``N`` RK4 intervals, least ``sum |tau|^2 h``, ``|tau| <= 50``, solved by IPOPT
(limited-memory Hessian, the same options both ways) with the dynamics given twice:

``mbgen``
    :func:`mbgen.casadi_function`: the generated C as an ``External``, with its analytic
    Jacobian (``jac_``);
``CasADi SX``
    the articulated-body algorithm traced on ``casadi.SX`` from the robot's Pinocchio
    model (:func:`aba_sx`: the ``pin`` wheel has no ``pinocchio.casadi``, so the three
    passes are written out, as :mod:`mbgen.bench.arm_casadi` does for the arm), checked
    against ``pin.aba`` before it is used; CasADi differentiates it by its own AD and
    evaluates it in its virtual machine.

Reported: setup seconds (mbgen: generation and compilation; SX: the trace), IPOPT's
iterations, its total wall time and the time per iteration.

*Throughput* (:func:`throughput_rows`): the right-hand side of UR5 over a batch of random
states (and torques), in ns per state, at ``k = 1,000`` and ``10,000``:
``jax.jit(jax.vmap(rhs))`` of :func:`mbgen.jax_function` on the CPU, mbgen's C batch loop
(``model.rhs(t, X, p, R)``), and ``mujoco.mjx``'s ``forward`` vmapped over the same states
where MJX loads the robot.  JAX's compile time is split into tracing
(``jax.make_jaxpr``), lowering to StableHLO (``.lower``) and XLA's compilation
(``.compile``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import BenchmarkError
from ..model.scene import Scene, urdf_scene
from ..scenes import spatial_arm
from .arm_pinocchio import import_pinocchio, pinocchio_arm
from .robot_peers import clean_urdf, mujoco_of_urdf, robot_file, switch_off

#: Shooting intervals, horizon (s), torque bound (N m).
N_INTERVALS, HORIZON, TAU_MAX = 20, 1.0, 50.0


@dataclass
class NlpRow:
    """One robot's NLP solved with one kind of dynamics."""

    robot: str
    dynamics: str
    setup_s: float = float("nan")
    iterations: int = 0
    total_s: float = float("nan")
    status: str = "not run"

    @property
    def per_iteration_ms(self) -> float:
        return 1e3 * self.total_s / self.iterations if self.iterations else float("nan")


@dataclass
class ThroughputRow:
    """ns per state of one way of evaluating a batch."""

    way: str
    batch: int
    ns_per_state: float = float("nan")
    note: str = ""


@dataclass
class InteropReport:
    intervals: int = N_INTERVALS
    nlp: list = field(default_factory=list)
    throughput: list = field(default_factory=list)
    jax_compile: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


# ----------------------------------------------------------------------------- robots
def actuated_arm(n: int) -> Scene:
    """The spatial arm with a torque ``tau{i}`` at every joint (on link ``i`` about its joint
    axis, the reaction on its parent), every parameter baked in."""
    m = spatial_arm.build_model(n)
    taus = m.inputs(" ".join(f"tau{i}" for i in range(1, n + 1)))
    parent = m.frame("N")
    for i in range(1, n + 1):
        link = m.frame(f"L{i}")
        axis = link.z if spatial_arm.axis(i) == 3 else link.y
        m.torque(link, taus[i - 1] * axis, reaction=parent)
        parent = link
    values = spatial_arm.link_parameters(n)
    values.pop(f"a{n}")
    return Scene(name=f"arm{n}", model=m, fixed=values, method=spatial_arm.scene(1).method)


def robots(folder: Path, arm_n: int = 7) -> list[tuple[str, Scene, object]]:
    """``(name, mbgen scene, Pinocchio model)`` of the arm and UR5."""
    pin = import_pinocchio()
    out = [(f"arm n={arm_n}", actuated_arm(arm_n), pinocchio_arm(arm_n))]
    path = clean_urdf(robot_file("ur5")[0], folder)
    scene = urdf_scene(path)
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    out.append(("UR5", Scene(name=scene.name, model=scene.model, fixed={"g": 9.81}), model))
    return out


# ----------------------------------------------------------------------------- CasADi SX
def _skew(ca, r):
    return ca.vertcat(ca.horzcat(0, -r[2], r[1]), ca.horzcat(r[2], 0, -r[0]),
                      ca.horzcat(-r[1], r[0], 0))


def _cross(ca, v):
    """``v x`` on motion vectors ``(angular, linear)``."""
    w, lin = _skew(ca, v[:3]), _skew(ca, v[3:])
    return ca.vertcat(ca.horzcat(w, ca.SX.zeros(3, 3)), ca.horzcat(lin, w))


def _rotation(ca, axis, angle):
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    K = ca.SX(np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]],
                        [-axis[1], axis[0], 0]], dtype=float))
    return ca.SX.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * ca.mtimes(K, K)


def _joint_axis(joint) -> np.ndarray:
    kind = joint.shortname()
    fixed = {"JointModelRX": (1, 0, 0), "JointModelRY": (0, 1, 0), "JointModelRZ": (0, 0, 1)}
    if kind in fixed:
        return np.array(fixed[kind], dtype=float)
    if kind == "JointModelRevoluteUnaligned":
        return np.array(joint.extract().axis, dtype=float)
    raise BenchmarkError(f"the SX articulated-body algorithm takes revolute joints, not {kind}")


def aba_sx(model, q, v, tau):
    """Joint accelerations (SX) of a Pinocchio ``model`` of revolute joints: the
    articulated-body algorithm's three passes on spatial vectors in each joint's frame
    (velocities and bias accelerations outward, articulated inertias and bias forces
    inward, accelerations outward); gravity as the base's acceleration."""
    import casadi as ca

    n = model.nv
    X, S, vel, c, IA, pA = [], [], [], [], [], []
    for i in range(1, n + 1):
        place = model.jointPlacements[i]
        axis = _joint_axis(model.joints[i])
        E = ca.mtimes(ca.SX(place.rotation), _rotation(ca, axis, q[i - 1]))
        Et = E.T
        X.append(ca.vertcat(ca.horzcat(Et, ca.SX.zeros(3, 3)),
                            ca.horzcat(-ca.mtimes(Et, _skew(ca, ca.SX(place.translation))), Et)))
        s = ca.SX(np.concatenate([axis, np.zeros(3)]))
        S.append(s)
        parent = model.parents[i]
        vp = vel[parent - 1] if parent else ca.SX.zeros(6, 1)
        vel.append(ca.mtimes(X[-1], vp) + s * v[i - 1])
        c.append(ca.mtimes(_cross(ca, vel[-1]), s * v[i - 1]))
        inertia = model.inertias[i]
        m, cx = inertia.mass, _skew(ca, ca.SX(inertia.lever))
        Ic = ca.SX(np.array(inertia.inertia))
        IA.append(ca.vertcat(ca.horzcat(Ic + m * ca.mtimes(cx, cx.T), m * cx),
                             ca.horzcat(m * cx.T, m * ca.SX.eye(3))))
        pA.append(-ca.mtimes(_cross(ca, vel[-1]).T, ca.mtimes(IA[-1], vel[-1])))
    U, D, u = [None] * n, [None] * n, [None] * n
    for k in reversed(range(n)):
        U[k] = ca.mtimes(IA[k], S[k])
        D[k] = ca.mtimes(S[k].T, U[k])
        u[k] = tau[k] - ca.mtimes(S[k].T, pA[k])
        parent = model.parents[k + 1]
        if parent:
            Ia = IA[k] - ca.mtimes(U[k], U[k].T) / D[k]
            pa = pA[k] + ca.mtimes(Ia, c[k]) + U[k] * u[k] / D[k]
            IA[parent - 1] = IA[parent - 1] + ca.mtimes(X[k].T, ca.mtimes(Ia, X[k]))
            pA[parent - 1] = pA[parent - 1] + ca.mtimes(X[k].T, pa)
    g = np.asarray(model.gravity.linear)
    acc, qdd = [None] * n, [None] * n
    for k in range(n):
        parent = model.parents[k + 1]
        ap = acc[parent - 1] if parent else ca.SX(np.concatenate([np.zeros(3), -g]))
        a = ca.mtimes(X[k], ap) + c[k]
        qdd[k] = (u[k] - ca.mtimes(U[k].T, a)) / D[k]
        acc[k] = a + S[k] * qdd[k]
    return ca.vertcat(*qdd)


def sx_dynamics(model):
    """``(casadi.Function f(x, tau) -> x', seconds to trace it)``, checked against
    ``pin.aba`` at a random state."""
    import casadi as ca

    pin = import_pinocchio()
    t0 = time.perf_counter()
    n = model.nv
    x, tau = ca.SX.sym("x", 2 * n), ca.SX.sym("tau", n)
    f = ca.Function("aba_sx", [x, tau], [ca.vertcat(x[n:], aba_sx(model, x[:n], x[n:], tau))])
    traced = time.perf_counter() - t0
    rng = np.random.default_rng(2)
    q, v, t = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-5, 5, n)
    ref = pin.aba(model, model.createData(), q, v, t)
    got = np.array(f(np.concatenate([q, v]), t)).ravel()[n:]
    if np.abs(got - ref).max() > 1e-9 * max(1.0, np.abs(ref).max()):
        raise BenchmarkError("the SX articulated-body algorithm disagrees with pin.aba")
    return f, traced


# ----------------------------------------------------------------------------- the NLP
def solve_shooting(dynamics, n: int, N: int = N_INTERVALS, T: float = HORIZON):
    """IPOPT on the multiple-shooting problem of a robot of ``n`` joints whose dynamics
    ``dynamics(x, tau)`` (MX in, MX out) gives ``x'``; ``(iterations, seconds, status)``."""
    import casadi as ca

    h = T / N
    x, tau = ca.MX.sym("x", 2 * n), ca.MX.sym("tau", n)
    k1 = dynamics(x, tau)
    k2 = dynamics(x + h / 2 * k1, tau)
    k3 = dynamics(x + h / 2 * k2, tau)
    k4 = dynamics(x + h * k3, tau)
    step = ca.Function("step", [x, tau], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
    X, U = ca.MX.sym("X", 2 * n, N + 1), ca.MX.sym("U", n, N)
    start = np.concatenate([0.3 * (-1.0) ** np.arange(n), np.zeros(n)])
    goal = np.concatenate([0.5 * np.ones(n), np.zeros(n)])
    nlp = {"x": ca.veccat(X, U), "f": h * ca.sumsqr(U),
           "g": ca.veccat(step.map(N)(X[:, :-1], U) - X[:, 1:], X[:, 0] - start,
                          X[:, -1] - goal)}
    bound = np.concatenate([np.full(2 * n * (N + 1), np.inf), np.full(n * N, TAU_MAX)])
    guess = np.concatenate([np.linspace(start, goal, N + 1).ravel(), np.zeros(n * N)])
    solver = ca.nlpsol("shooting", "ipopt", nlp, {
        "ipopt.hessian_approximation": "limited-memory", "ipopt.print_level": 0,
        "ipopt.max_iter": 500, "ipopt.tol": 1e-8, "print_time": False})
    t0 = time.perf_counter()
    solver(x0=guess, lbx=-bound, ubx=bound, lbg=0, ubg=0)
    seconds = time.perf_counter() - t0
    stats = solver.stats()
    return stats["iter_count"], seconds, stats["return_status"]


def nlp_rows(folder: Path, arm_n: int = 7, N: int = N_INTERVALS, progress=None) -> list[NlpRow]:
    """The NLP of every robot of :func:`robots`, with mbgen's external and with SX."""
    import casadi as ca

    from ..interop import casadi_function

    rows = []
    empty = ca.DM(0, 1)
    for name, scene, pin_model in robots(folder, arm_n):
        n = pin_model.nv
        if progress:
            progress(f"{name}: mbgen's external")
        t0 = time.perf_counter()
        f = casadi_function(scene)
        setup = time.perf_counter() - t0
        iters, seconds, status = solve_shooting(lambda x, u, f=f: f(0, x, empty, u), n, N)
        rows.append(NlpRow(name, "mbgen external", setup, iters, seconds, status))
        if progress:
            progress(f"{name}: CasADi SX")
        g, traced = sx_dynamics(pin_model)
        iters, seconds, status = solve_shooting(lambda x, u, g=g: g(x, u), n, N)
        rows.append(NlpRow(name, "CasADi SX (ABA)", traced, iters, seconds, status))
    return rows


# ----------------------------------------------------------------------------- throughput
def _median_seconds(fn, repeats: int, *args) -> float:
    """Median seconds of ``fn(*args)`` over ``repeats`` calls after a first one."""
    fn(*args)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(*args)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def throughput_rows(folder: Path, batches=(1000, 10000), repeats: int = 5,
                    progress=None) -> tuple[list, dict, list]:
    """UR5's right-hand side over batches: JAX, mbgen's C batch, MJX; ``(rows, JAX's
    compile seconds by phase, notes)``."""
    import jax
    import jax.numpy as jnp

    from .. import compile as compile_model
    from ..interop import jax_function

    jax.config.update("jax_enable_x64", True)
    path = clean_urdf(robot_file("ur5")[0], folder)
    scene = urdf_scene(path)
    scene = Scene(name=scene.name, model=scene.model, fixed={"g": 9.81})
    model = compile_model(scene)
    f = jax_function(scene)
    n = model.layout.n_u
    rows, notes = [], []
    batched = jax.vmap(f, in_axes=(None, 0, None, 0))
    rng = np.random.default_rng(1)
    compile_s: dict = {}
    for k in batches:
        X = rng.uniform(-1, 1, (k, 2 * n))
        R = rng.uniform(-5, 5, (k, n))
        if progress:
            progress(f"UR5 batch {k}: JAX")
        Xj, Rj = jnp.asarray(X), jnp.asarray(R)
        t0 = time.perf_counter()
        jax.make_jaxpr(batched)(0.0, Xj, None, Rj)
        t1 = time.perf_counter()
        lowered = jax.jit(batched).lower(0.0, Xj, None, Rj)
        t2 = time.perf_counter()
        compiled = lowered.compile()
        t3 = time.perf_counter()
        if not compile_s:
            compile_s = {"trace": t1 - t0, "lower": t2 - t1, "compile": t3 - t2}
        out = compiled(0.0, Xj, None, Rj)
        ref = model.rhs(0.0, X, None, R)
        if np.abs(np.asarray(out) - ref).max() > 1e-9 * max(1.0, np.abs(ref).max()):
            raise BenchmarkError("JAX's batch disagrees with mbgen's C")
        s = _median_seconds(lambda c, x, r: c(0.0, x, None, r).block_until_ready(), repeats,
                            compiled, Xj, Rj)
        rows.append(ThroughputRow("jax.jit(jax.vmap(rhs)), CPU", k, 1e9 * s / k))
        if progress:
            progress(f"UR5 batch {k}: mbgen C batch")
        s = _median_seconds(model.rhs, repeats, 0.0, X, None, R)
        rows.append(ThroughputRow("mbgen C batch (model.rhs on (k, n_x))", k, 1e9 * s / k))
        if progress:
            progress(f"UR5 batch {k}: MJX")
        rows.append(_mjx_row(path, X, R, ref, notes))
    return rows, compile_s, notes


def _mjx_row(path, X, R, ref, notes) -> ThroughputRow:
    """``mjx.forward`` vmapped over the batch (torques as ``qfrc_applied``), timed once after
    a first call."""
    k, n = R.shape
    row = ThroughputRow("mujoco.mjx forward (vmap, jit), CPU", k)
    try:
        import jax
        from mujoco import mjx
    except ImportError:
        row.note = "mujoco-mjx is not installed"
        return row
    mj = mujoco_of_urdf(path, False)
    switch_off(mj)
    try:
        mx = mjx.put_model(mj)
        d0 = mjx.make_data(mx)
    except Exception as exc:     # a feature MJX does not take: the row says which
        row.note = f"MJX does not load it: {exc}"[:120]
        if row.note not in notes:
            notes.append(row.note)
        return row

    def forward(q, v, tau):
        return mjx.forward(mx, d0.replace(qpos=q, qvel=v, qfrc_applied=tau)).qacc

    fn = jax.jit(jax.vmap(forward))
    qacc = np.asarray(fn(X[:, :n], X[:, n:], R))
    err = np.abs(qacc - ref[:, n:]).max() / max(1.0, np.abs(ref[:, n:]).max())
    if err > 1e-6:
        row.note = f"disagrees with mbgen by {err:.1e} (relative)"
    t0 = time.perf_counter()     # once more, timed (a call of 10,000 states takes seconds)
    fn(X[:, :n], X[:, n:], R).block_until_ready()
    row.ns_per_state = 1e9 * (time.perf_counter() - t0) / k
    return row


# ----------------------------------------------------------------------------- report
def interop_bench(folder: Path, arm_n: int = 7, N: int = N_INTERVALS,
                  batches=(1000, 10000), repeats: int = 5, progress=None) -> InteropReport:
    """Both measurements (see the module docstring); ``folder`` holds the robot's copy."""
    for extra in ("casadi", "jax"):
        try:
            __import__(extra)
        except ImportError:
            raise BenchmarkError(f"mbgen bench interop needs {extra}: pip install "
                                 f"'mbgen[{extra}]'") from None
    Path(folder).mkdir(parents=True, exist_ok=True)
    report = InteropReport(intervals=N)
    report.nlp = nlp_rows(Path(folder), arm_n, N, progress)
    report.throughput, report.jax_compile, report.notes = throughput_rows(
        Path(folder), batches, repeats, progress)
    return report


def format_interop(report: InteropReport) -> str:
    """The two tables and where JAX's compile time went."""
    lines = ["NLP: direct multiple shooting, IPOPT (limited-memory Hessian), "
             f"{report.intervals} RK4 intervals",
             f"{'robot':<10} {'dynamics':<18} {'setup s':>8} {'iter':>5} {'total s':>8} "
             f"{'ms/iter':>8}  status"]
    for r in report.nlp:
        lines.append(f"{r.robot:<10} {r.dynamics:<18} {r.setup_s:8.2f} {r.iterations:5d} "
                     f"{r.total_s:8.3f} {r.per_iteration_ms:8.2f}  {r.status}")
    lines += ["", "UR5 right-hand side over a batch (ns per state)",
              f"{'way':<40} {'batch':>6} {'ns/state':>9}  note"]
    for r in report.throughput:
        lines.append(f"{r.way:<40} {r.batch:6d} {r.ns_per_state:9.1f}  {r.note}")
    c = report.jax_compile
    if c:
        lines += ["", f"JAX's compile of jit(vmap(rhs)), UR5: trace {c['trace']:.2f} s, lower "
                      f"to StableHLO {c['lower']:.2f} s, XLA compile {c['compile']:.2f} s"]
    lines += [f"note: {n}" for n in report.notes]
    return "\n".join(lines)


__all__ = ["interop_bench", "format_interop", "nlp_rows", "throughput_rows", "aba_sx",
           "sx_dynamics", "solve_shooting", "actuated_arm", "InteropReport", "NlpRow",
           "ThroughputRow"]
