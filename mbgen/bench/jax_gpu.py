r"""mbgen's JAX function against MuJoCo MJX on whatever JAX device is present (a GPU).

Two steps, because the GPU machine has JAX but none of mbgen's own dependencies
(symengine, cffi):

``prepare`` (here, with mbgen, ``mujoco`` and example-robot-data installed)
    writes into a folder, per robot, the module that mbgen's ``jax`` target prints
    (``<robot>_jax.py``: it imports ``jax.numpy`` alone), MuJoCo's compiled model of the
    same robot (``<robot>.mjb``, binary and exact, with what mbgen does not model switched
    off: :data:`mbgen.bench.robot_peers.SWITCHED_OFF`, damping and armature zeroed; the
    file MuJoCo read beside it: the cleaned URDF, the arm's MJCF), and seeded reference
    states with the compiled C's right-hand side and analytic Jacobian
    (``<robot>_ref.npz``), plus ``robots.json`` naming them.  Before it writes, MuJoCo's
    own ``mj_forward`` (float64, C) must give the C's accelerations at every reference
    state to :data:`PREPARE_RTOL`: the two models are one robot.  Robots
    (:data:`ROBOTS`): UR5 (its URDF from example-robot-data, read by both) and the
    spatial arm of :func:`mbgen.bench.interop.actuated_arm` (``n = 8`` by default; its
    MJCF is written from :func:`mbgen.bench.arm_pinocchio.link_rows`).

``run`` (anywhere; imports only numpy, jax and, for MJX, mujoco and mujoco-mjx)
    loads that folder and, per robot, dtype, kind and batch size ``k``, times
    ``jax.jit(jax.vmap(f))`` over ``k`` seeded random states and torques, with ``f`` the
    state's derivative ``x -> dxdt`` (``kind = rhs``, shape ``(n_x,)``) or its Jacobian
    ``jax.jacfwd(f)`` (``kind = jacobian``, ``(n_x, n_x)``), and ``f`` either

    ``mbgen``
        ``rhs(0, x, None, r)`` of the printed module;
    ``mjx``
        ``mjx.forward`` (``impl="jax"``) on one ``mjx.Data`` with ``qpos``, ``qvel`` and
        ``qfrc_applied`` replaced, returning ``[qvel, qacc]``.

    float64 runs with ``jax_enable_x64`` on, float32 with it off (JAX's default, a
    learner's usual setting; the MuJoCo model is put on the device in that precision).
    Every batch begins with the reference states (as many as fit), so that each cell's
    first call is also its check: its largest error relative to the C's
    (``max|out - ref| / max(1, max|ref|)``) is in its row, and a float64 error above
    :data:`RTOL` makes the run fail after it has written its table.
    Per cell: the AOT phases are timed apart (``lower``: tracing and lowering to
    StableHLO; ``compile``: XLA), then one warm-up call, then calls each timed to
    ``block_until_ready`` until at least ``repeats`` of them and ``min_time`` seconds;
    reported: the median, as ns per state and states per second.  A cell that runs out
    of device memory, or any after ``budget_s`` has passed, is a row with a note.

The CSV holds one row per cell (:class:`Row`'s fields) and ``<csv>.json`` the device and
versions.  Run on a machine without mbgen's dependencies as a plain file that does not
put its own folder on ``sys.path``::

    python -m mbgen.bench.jax_gpu prepare .gpubench           # here
    python -P mbgen/bench/jax_gpu.py run .gpubench --csv out.csv   # there
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import statistics
import sys
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

try:
    from ..errors import BenchmarkError
except ImportError:      # a plain file on a machine without mbgen: the same name, standalone
    class BenchmarkError(RuntimeError):
        """A benchmark could not run or its ways disagree."""

#: float64 agreement with the C: prepare (MuJoCo's C), run (rhs; Jacobian of forward AD).
PREPARE_RTOL = 1e-9
RTOL = {"rhs": 1e-9, "jacobian": 1e-8}
BATCHES = (1, 1000, 10_000, 100_000, 1_000_000)
JACOBIAN_BATCHES = (1, 1000, 10_000, 100_000)
DTYPES = ("float64", "float32")
#: Sampling ranges of the reference and timed states: q, v (rad, rad/s), torques (N m).
Q_RANGE, V_RANGE, TAU_RANGE = np.pi, 2.0, 5.0
MANIFEST = "robots.json"


# ----------------------------------------------------------------------------- prepare
def _ur5(folder: Path, arm_n: int):
    """UR5 both ways: mbgen's URDF scene (``g`` baked in) and MuJoCo's model of the file."""
    from ..model.scene import Scene, urdf_scene
    from .robot_peers import clean_urdf, mujoco_of_urdf, robot_file

    path = clean_urdf(robot_file("ur5")[0], folder)
    scene = urdf_scene(path)
    scene = Scene(name=scene.name, model=scene.model, fixed={"g": 9.81})
    return "ur5", scene, mujoco_of_urdf(path, False), path.name


def arm_mjcf(n: int) -> str:
    """The spatial arm of ``n`` links as MJCF: nested bodies at ``(a_{i-1}, 0, 0)``, a hinge
    about z (odd links) or y (even), the centre of mass at ``(b_i, 0, 0)`` with the inertia
    about it, gravity ``-g`` along z (the same robot as
    :func:`mbgen.bench.arm_pinocchio.pinocchio_arm`)."""
    from ..scenes.spatial_arm import link_parameters
    from .arm_pinocchio import link_rows

    g = link_parameters(n)["g"]
    head = (f'<mujoco model="arm{n}">\n  <compiler angle="radian"/>\n'
            f'  <option gravity="0 0 {-g!r}"/>\n  <worldbody>\n')
    body, tail = "", ""
    for i, (ax, a, b, m, ixx, iyy, izz, ixy, iyz, izx) in enumerate(link_rows(n), start=1):
        pad = "    " + "  " * i
        axis = "0 0 1" if ax == 3 else "0 1 0"
        body += (f'{pad}<body name="L{i}" pos="{a!r} 0 0">\n'
                 f'{pad}  <joint name="j{i}" type="hinge" axis="{axis}"/>\n'
                 f'{pad}  <inertial pos="{b!r} 0 0" mass="{m!r}" '
                 f'fullinertia="{ixx!r} {iyy!r} {izz!r} {ixy!r} {izx!r} {iyz!r}"/>\n')
        tail = f"{pad}</body>\n" + tail
    return head + body + tail + "  </worldbody>\n</mujoco>\n"


def _arm(folder: Path, arm_n: int):
    """The actuated spatial arm both ways (:func:`arm_mjcf` for MuJoCo)."""
    import mujoco

    from .interop import actuated_arm

    xml = arm_mjcf(arm_n)
    (folder / f"arm{arm_n}.xml").write_text(xml, encoding="utf-8")
    return f"arm{arm_n}", actuated_arm(arm_n), mujoco.MjModel.from_xml_string(xml), \
        f"arm{arm_n}.xml"


#: Robots by name: ``builder(folder, arm_n) -> (name, Scene, MjModel, the file in folder
#: that MuJoCo read)``.
ROBOTS = {"ur5": _ur5, "arm": _arm}


def _states(rng, k: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(X (k, 2n), R (k, n))`` drawn from the ranges above."""
    X = np.concatenate([rng.uniform(-Q_RANGE, Q_RANGE, (k, n)),
                        rng.uniform(-V_RANGE, V_RANGE, (k, n))], axis=1)
    return X, rng.uniform(-TAU_RANGE, TAU_RANGE, (k, n))


def _mujoco_accelerations(mj, X, R) -> np.ndarray:
    """``qacc`` of MuJoCo's C ``mj_forward`` at each state (hinge joints: qpos = q)."""
    import mujoco

    data, n = mujoco.MjData(mj), mj.nv
    out = np.empty((len(X), n))
    for i, (x, r) in enumerate(zip(X, R)):
        data.qpos[:], data.qvel[:], data.qfrc_applied[:] = x[:n], x[n:], r
        mujoco.mj_forward(mj, data)
        out[i] = data.qacc
    return out


def prepare(folder, robots=("ur5", "arm"), arm_n: int = 8, samples: int = 8,
            seed: int = 0) -> list[dict]:
    """Write the files of ``run`` for ``robots`` into ``folder`` (see the module docstring);
    returns the manifest's entries.  Raises :class:`BenchmarkError` where a robot is not
    known, MuJoCo or JAX is missing, or MuJoCo's C disagrees with mbgen's."""
    from .. import compile as compile_model
    from ..codegen.targets.jax import jax_module_text
    from ..pipeline import run
    from .robot_peers import import_mujoco, switch_off

    unknown = [r for r in robots if r not in ROBOTS]
    if unknown:
        raise BenchmarkError(f"no robot {unknown[0]!r} for the JAX benchmark; choose from "
                             f"{', '.join(ROBOTS)}")
    mujoco = import_mujoco()
    if mujoco is None:
        raise BenchmarkError("the JAX benchmark's MJX side needs mujoco: pip install mujoco")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for robot in robots:
        name, scene, mj, source = ROBOTS[robot](folder, arm_n)
        switch_off(mj)
        result = run(scene, ["rhs"], build=False)
        model = compile_model(scene, ["rhs", "jacobian"])
        n = model.layout.n_u
        if (mj.nq, mj.nv) != (n, n) or model.layout.n_q != n or model.n_r != n:
            raise BenchmarkError(f"{name}: MuJoCo has nq={mj.nq}, nv={mj.nv}, mbgen n_q="
                                 f"{model.layout.n_q}, n_u={n}, n_r={model.n_r}; the benchmark "
                                 f"takes one torque per hinge joint")
        X, R = _states(np.random.default_rng(seed), samples, n)
        dxdt = model.rhs(0.0, X, None, R)
        jac = model.jacobian(0.0, X, None, R)
        err = _relative(_mujoco_accelerations(mj, X, R), dxdt[:, n:])
        if not err <= PREPARE_RTOL:
            raise BenchmarkError(f"{name}: MuJoCo's mj_forward and mbgen's C differ by {err:.1e}"
                                 f" (relative; at most {PREPARE_RTOL:.0e}): not the same robot")
        files = {"module": f"{name}_jax.py", "mjb": f"{name}.mjb", "source": source,
                 "ref": f"{name}_ref.npz"}
        (folder / files["module"]).write_text(
            jax_module_text(result.kernel, result.rendered.prefix), encoding="utf-8")
        mujoco.mj_saveModel(mj, str(folder / files["mjb"]), None)
        np.savez(folder / files["ref"], X=X, R=R, dxdt=dxdt, jacobian=jac)
        entries.append({"name": name, "n": n, "mujoco_vs_c": err, **files})
    (folder / MANIFEST).write_text(json.dumps(entries, indent=1), encoding="utf-8")
    return entries


# ----------------------------------------------------------------------------- the ways
def _relative(out, ref) -> float:
    out, ref = np.asarray(out, dtype=float), np.asarray(ref, dtype=float)
    return float(np.abs(out - ref).max() / max(1.0, np.abs(ref).max()))


def _mbgen_way(folder: Path, entry: dict):
    """``x, r -> dxdt`` of the printed module (loaded from its file, not imported by name)."""
    path = folder / entry["module"]
    spec = importlib.util.spec_from_file_location(f"mbgen_jax_{entry['name']}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    rhs = module.rhs
    return lambda x, r: rhs(0.0, x, None, r)


def _mjx_way(folder: Path, entry: dict):
    """``x, r -> [qvel, qacc]`` of ``mjx.forward`` on the model put on the default device."""
    import jax.numpy as jnp
    import mujoco
    from mujoco import mjx

    mj = mujoco.MjModel.from_binary_path(str(folder / entry["mjb"]))
    mx = mjx.put_model(mj, impl="jax")
    d0 = mjx.make_data(mx, impl="jax")
    n = entry["n"]

    def forward(x, r):
        d = mjx.forward(mx, d0.replace(qpos=x[:n], qvel=x[n:], qfrc_applied=r))
        return jnp.concatenate([d.qvel, d.qacc])
    return forward


#: The ways, in the order timed: ``name -> builder(folder, entry) -> f(x, r)``.
WAYS = {"mbgen": _mbgen_way, "mjx": _mjx_way}


def _kind(kind: str, f):
    import jax

    return {"rhs": lambda: f, "jacobian": lambda: jax.jacfwd(f, argnums=0)}[kind]()


# ----------------------------------------------------------------------------- timing
@dataclass
class Row:
    """One cell: robot, way, kind, dtype and batch, with its times (s) and its error."""

    robot: str
    way: str
    kind: str
    dtype: str
    batch: int
    lower_s: float = float("nan")
    compile_s: float = float("nan")
    first_call_s: float = float("nan")
    median_s: float = float("nan")
    repeats: int = 0
    fusions: int = -1
    ns_per_state: float = float("nan")
    states_per_s: float = float("nan")
    max_rel_err: float = float("nan")
    device: str = ""
    note: str = ""


def _time_cell(row: Row, fn, args, repeats: int, min_time: float, max_repeats: int = 200):
    """Fill ``row`` with the AOT phases, the first call and the median of timed calls;
    returns the first call's output."""
    import jax

    t0 = time.perf_counter()
    lowered = jax.jit(fn).lower(*args)
    t1 = time.perf_counter()
    compiled = lowered.compile()
    t2 = time.perf_counter()
    row.fusions = _fusions(compiled)
    out = jax.block_until_ready(compiled(*args))
    t3 = time.perf_counter()
    times: list[float] = []
    while len(times) < repeats or (sum(times) < min_time and len(times) < max_repeats):
        s = time.perf_counter()
        jax.block_until_ready(compiled(*args))
        times.append(time.perf_counter() - s)
    row.lower_s, row.compile_s, row.first_call_s = t1 - t0, t2 - t1, t3 - t2
    row.median_s, row.repeats = statistics.median(times), len(times)
    row.ns_per_state = 1e9 * row.median_s / row.batch
    row.states_per_s = row.batch / row.median_s
    return out


def _fusions(compiled) -> int:
    """XLA's fusion instructions in the optimised program (on a GPU about one kernel
    launch each per call); -1 where the text is not available."""
    try:
        return compiled.as_text().count(" fusion(")
    except Exception:     # a backend without the text: unknown, not an error
        return -1


def _failure(exc: Exception) -> str:
    text = str(exc)
    if "RESOURCE_EXHAUSTED" in text or "out of memory" in text.lower():
        return "out of device memory"
    return f"failed: {type(exc).__name__}: {text.splitlines()[0] if text else ''}"[:160]


def _device() -> str:
    import jax

    d = jax.devices()[0]
    return f"{d.platform}:{getattr(d, 'device_kind', '')}"


def environment() -> dict:
    """The device and the versions of what the run used."""
    from importlib import metadata

    import jax

    versions = {}
    for dist in ("jax", "jaxlib", "numpy", "mujoco", "mujoco-mjx"):
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = None
    return {"device": _device(), "devices": [str(d) for d in jax.devices()],
            "python": sys.version.split()[0], "versions": versions}


def _batch(ref, k: int, n: int, dtype: str):
    """``k`` states and torques on the device, the reference states first (as many as fit)
    and seeded random ones after them."""
    import jax

    X, R = _states(np.random.default_rng(k), k, n)
    s = min(k, len(ref["X"]))
    X[:s], R[:s] = ref["X"][:s], ref["R"][:s]
    return jax.device_put(X.astype(dtype)), jax.device_put(R.astype(dtype))


def _group_rows(folder, entry, kind, dtype, ways, batches, settings, failures) -> list[Row]:
    """The cells of one robot, kind and dtype (x64 already set for it): per batch, per way.
    Each row's error is its own first call's, at the reference states in its batch."""
    import jax

    ref = np.load(folder / entry["ref"])
    expected = ref["dxdt" if kind == "rhs" else "jacobian"]
    dev, rows, built, broken = _device(), [], {}, {}
    for way in ways:
        try:
            built[way] = _kind(kind, WAYS[way](folder, entry))
        except Exception as exc:     # a peer that does not load: its rows say why
            broken[way] = _failure(exc)
    for k in batches:
        args = None
        for way in ways:
            row = Row(entry["name"], way, kind, dtype, k, device=dev, note=broken.get(way, ""))
            rows.append(row)
            if way in built and time.perf_counter() > settings["deadline"]:
                row.note = "skipped: time budget"
            elif way in built:
                try:
                    args = args or _batch(ref, k, entry["n"], dtype)
                    out = _time_cell(row, jax.vmap(built[way]), args, settings["repeats"],
                                     settings["min_time"])
                    s = min(k, len(expected))
                    row.max_rel_err = _relative(out[:s], expected[:s])
                    del out
                except Exception as exc:     # out of memory at a large batch: noted, go on
                    row.note = _failure(exc)
                if dtype == "float64" and not row.max_rel_err <= RTOL[kind] and not row.note:
                    failures.append(f"{entry['name']} {way} {kind} k={k}: {row.max_rel_err:.1e}"
                                    f" from the C (at most {RTOL[kind]:.0e})")
            if settings["progress"]:
                settings["progress"](row)
        del args
    return rows


def bench(folder, dtypes=DTYPES, kinds=("rhs", "jacobian"), batches=BATCHES,
          jacobian_batches=JACOBIAN_BATCHES, ways=tuple(WAYS), robots=None, repeats: int = 5,
          min_time: float = 0.2, budget_s: float = float("inf"), progress=None) -> list[Row]:
    """Time every cell of the prepared ``folder`` (see the module docstring), robot by
    robot (in the manifest's order), then kind by kind, then dtype by dtype, so that a
    budget cuts the least wanted cells; ``progress(row)`` is called after each.

    Raises :class:`BenchmarkError` where the folder was not prepared, and after all rows,
    where a float64 way disagrees with the C (``rows`` then on the exception)."""
    import jax

    folder = Path(folder)
    if not (folder / MANIFEST).is_file():
        raise BenchmarkError(f"{folder} holds no {MANIFEST}: run "
                             f"'python -m mbgen.bench.jax_gpu prepare {folder}' first")
    entries = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    if robots:
        entries = [e for e in entries if e["name"] in robots]
    unknown = [w for w in ways if w not in WAYS]
    if unknown:
        raise BenchmarkError(f"no way {unknown[0]!r}; choose from {', '.join(WAYS)}")
    sizes = {"rhs": tuple(batches), "jacobian": tuple(jacobian_batches)}
    settings = {"deadline": time.perf_counter() + budget_s, "repeats": repeats,
                "min_time": min_time, "progress": progress}
    was = jax.config.jax_enable_x64
    rows: list[Row] = []
    failures: list[str] = []
    try:
        for entry in entries:
            for kind in kinds:
                for dtype in dtypes:
                    jax.config.update("jax_enable_x64", dtype == "float64")
                    rows += _group_rows(folder, entry, kind, dtype, ways, sizes[kind],
                                        settings, failures)
    finally:
        jax.config.update("jax_enable_x64", was)
    if failures:
        exc = BenchmarkError("the ways disagree with mbgen's C: " + "; ".join(failures))
        exc.rows = rows
        raise exc
    return rows


# ----------------------------------------------------------------------------- output
HEADER = (f"{'robot':<6} {'way':<6} {'kind':<8} {'dtype':<7} {'batch':>8} {'lower s':>8} "
          f"{'XLA s':>7} {'fus':>4} {'ns/state':>10} {'states/s':>10} {'reps':>4} {'rel err':>8}"
          f"  note")


def format_row(r: Row) -> str:
    return (f"{r.robot:<6} {r.way:<6} {r.kind:<8} {r.dtype:<7} {r.batch:8d} {r.lower_s:8.2f} "
            f"{r.compile_s:7.2f} {r.fusions:4d} {r.ns_per_state:10.1f} {r.states_per_s:10.3g} "
            f"{r.repeats:4d} {r.max_rel_err:8.1e}  {r.note}")


def format_table(rows, env: dict | None = None) -> str:
    lines = [f"device {env['device']}; " + ", ".join(f"{k} {v}" for k, v in
                                                     env["versions"].items())] if env else []
    return "\n".join(lines + [HEADER] + [format_row(r) for r in rows])


def write_csv(rows, path, env: dict | None = None) -> None:
    """``rows`` as CSV at ``path``; ``env`` as JSON beside it (``<path>.json``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, [f.name for f in fields(Row)])
        writer.writeheader()
        for r in rows:
            writer.writerow(asdict(r))
    if env is not None:
        Path(f"{path}.json").write_text(json.dumps(env, indent=1), encoding="utf-8")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="jax_gpu", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    prep = sub.add_parser("prepare", help="write the generated modules, MuJoCo models and "
                                          "references (needs mbgen)")
    prep.add_argument("folder")
    prep.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=list(ROBOTS))
    prep.add_argument("--arm-n", type=int, default=8)
    go = sub.add_parser("run", help="time the prepared robots on the default JAX device")
    go.add_argument("folder")
    go.add_argument("--csv", required=True)
    go.add_argument("--dtypes", nargs="+", default=list(DTYPES), choices=list(DTYPES))
    go.add_argument("--kinds", nargs="+", default=["rhs", "jacobian"],
                    choices=["rhs", "jacobian"])
    go.add_argument("--ways", nargs="+", default=list(WAYS), choices=list(WAYS))
    go.add_argument("--robots", nargs="+", default=None, help="names in robots.json")
    go.add_argument("--batches", nargs="+", type=int, default=list(BATCHES))
    go.add_argument("--jacobian-batches", nargs="+", type=int, default=list(JACOBIAN_BATCHES))
    go.add_argument("--repeats", type=int, default=5)
    go.add_argument("--min-time", type=float, default=0.2)
    go.add_argument("--budget-s", type=float, default=float("inf"))
    args = parser.parse_args(argv)
    if args.command == "prepare":
        for e in prepare(args.folder, args.robots, args.arm_n):
            print(f"{e['name']}: n = {e['n']}, MuJoCo's C vs mbgen's C {e['mujoco_vs_c']:.1e}")
        return 0
    env = environment()
    print(format_table([], env), flush=True)
    status, done = 0, []

    def progress(row):      # the CSV so far after every cell: a run cut short keeps its rows
        done.append(row)
        write_csv(done, args.csv, env)
        print(format_row(row), flush=True)

    try:
        rows = bench(args.folder, args.dtypes, args.kinds, args.batches, args.jacobian_batches,
                     args.ways, args.robots, args.repeats, args.min_time, args.budget_s,
                     progress)
    except BenchmarkError as exc:
        rows = getattr(exc, "rows", None)
        print(f"error: {exc}", file=sys.stderr)
        if rows is None:
            return 2
        status = 1
    write_csv(rows, args.csv, env)
    print("\n" + format_table(rows, env))
    return status


if __name__ == "__main__":
    sys.exit(main())
