"""``python -m mbgen.bench.contacts [ROBOT [FRAME ...]]``: a legged robot's contact dynamics,
mbgen's generated C against Pinocchio's, each in a compiled loop.

ROBOT is a robot of :data:`~mbgen.bench.robot_peers.ROBOTS` or a URDF path (default
``solo12`` on its four feet); the FRAMEs are its contact links (default: Solo-12's
``FL_FOOT FR_FOOT HL_FOOT HR_FOOT``).  In one run, at one seeded state:

mbgen
    ``from_urdf(path, floating=True, contacts=FRAMEs)`` compiled with ``rhs``,
    ``constraint_forces`` and ``contact_jacobian`` (:func:`mbgen.pipeline.run`, cold cache:
    the stages' times are reported), then ``<prefix>_rhs`` (u' and, inside it, lambda) and
    ``<prefix>_contact_jacobian`` (the RHS's and the forces' state Jacobian) each in a C
    loop (:func:`mbgen.bench.timing.c_function_ns`, ``-O3 -march=native``).
Pinocchio (``pin``)
    ``constraintDynamics`` with ``RigidConstraintModel(CONTACT_3D, ..., LOCAL_WORLD_ALIGNED)``
    at the same frames (``mu = 0``: the exact solve) and ``constraintDynamics`` followed by
    ``computeConstraintDynamicsDerivatives``, in a C++ loop with the same flags
    (``templates/bench/contact_dynamics.cpp.j2``), and ``aba`` for scale.

Each loop is timed as the benchmarks' are (the median of repeats of a calibrated loop); the
pair is run ``rounds`` times, alternating, and the smallest median of each is reported (the
machine may be shared).  The accelerations and forces are compared with Pinocchio's.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..abi import Output
from ..codegen.templating import environment
from ..errors import BenchmarkError
from ..model.urdf import from_urdf
from ..pipeline import run
from .arm_pinocchio import PINOCCHIO_DEFINES, cmeel_prefix, import_pinocchio
from .robot_peers import clean_urdf, robot_file
from .timing import DRIVER_FLAGS, MIN_LOOP_S, c_function_ns, run_driver

#: Solo-12's feet, the default contacts.
FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
#: Pinocchio's derivatives instantiate a joint visitor of 11 arguments (Boost.Fusion's
#: default arity is 6).
FUSION = ("-DBOOST_FUSION_INVOKE_MAX_ARITY=12",)


def build_driver(folder: Path, repeats: int) -> Path:
    """Compile Pinocchio's contact-dynamics loop against the ``pin`` wheel (about a minute)."""
    prefix = cmeel_prefix()
    cxx = shutil.which("g++") or shutil.which("c++")
    source = folder / "bench_contact_dynamics.cpp"
    source.write_text(environment().get_template("bench/contact_dynamics.cpp.j2").render(
        min_loop_s=MIN_LOOP_S, repeats=repeats), encoding="utf-8")
    exe = folder / "bench_contact_dynamics"
    proc = subprocess.run([cxx, "-std=c++17", *DRIVER_FLAGS, *PINOCCHIO_DEFINES, *FUSION,
                           f"-I{prefix / 'include'}", f"-I{prefix / 'include' / 'eigen3'}",
                           str(source), "-o", str(exe), f"-L{prefix / 'lib'}",
                           "-lpinocchio_default", "-lboost_serialization",
                           f"-Wl,-rpath,{prefix / 'lib'}"], capture_output=True, text=True)
    if proc.returncode != 0:
        raise BenchmarkError(f"compiling Pinocchio's contact-dynamics loop failed:\n"
                             f"{proc.stderr[-3000:]}")
    return exe


def _pinocchio(path: Path, frames, folder: Path):
    """Pinocchio's model (saved for the C++ loop) and the driver's contact lines."""
    pin = import_pinocchio()
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    model.saveToBinary(str(folder / "model.bin"))
    lines = []
    for name in frames:
        frame = model.frames[model.getFrameId(name)]
        lines.append(" ".join([str(frame.parentJoint)] + [repr(float(v)) for v in np.concatenate(
            [frame.placement.translation, frame.placement.rotation.ravel()])]))
    return model, lines


def measure(robot: str = "solo12", frames=FEET, repeats: int = 7, rounds: int = 3,
            seed: int = 0) -> dict:
    """Every figure of the benchmark (module docstring), nanoseconds and seconds."""
    pin = import_pinocchio()
    out: dict = dict(robot=robot, frames=list(frames))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = clean_urdf(robot_file(robot)[0], folder)
        res = run(from_urdf(path, floating=True, contacts=frames),
                  (Output.RHS, Output.CONSTRAINT_FORCES, Output.CONTACT_JACOBIAN))
        out["stages_s"] = {k: round(v, 2) for k, v in res.timings.items()}
        out["ops"] = {f.output.value: f.ops_after for f in res.kernel.functions}
        compiled, layout = res.compiled, res.kernel.layout
        model, lines = _pinocchio(path, frames, folder)
        rng = np.random.default_rng(seed)
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v, tau = rng.uniform(-1, 1, model.nv), rng.uniform(-1, 1, model.nv - 6)
        x = np.concatenate([q, v])
        p = np.array([{"g": 9.81}.get(n, 0.0) for n in layout.parameter_names])
        text = "\n".join(["0 0 -9.81", str(len(frames)), *lines, *(
            " ".join(repr(float(a)) for a in row)
            for row in (q, v, np.concatenate([np.zeros(6), tau])))]) + "\n"
        exe = build_driver(folder, repeats)
        n_x, m = layout.n_x, 3 * len(frames)
        best: dict = {}
        for _ in range(rounds):
            mine = {"mbgen_rhs": c_function_ns(res.rendered, "rhs", n_x, x, p, tau, repeats,
                                               folder),
                    "mbgen_contact_jacobian": c_function_ns(
                        res.rendered, "contact_jacobian", (n_x + m) * n_x, x, p, tau, repeats,
                        folder)}
            lines_out = run_driver([str(exe), str(folder / "model.bin")], "Pinocchio's loop",
                                   text).splitlines()
            for key in ("aba", "cd", "cdd"):
                mine[f"pin_{key}"] = float(np.median([float(s.split()[1]) for s in lines_out
                                                      if s.startswith(key + " ")]))
            for key, value in mine.items():
                best[key] = min(best.get(key, np.inf), value)
        values = {s.split()[0]: np.array([float(a) for a in s.split()[1:]]) for s in lines_out
                  if s.startswith(("ddq", "lambda"))}
        out["ns"] = {k: round(v) for k, v in best.items()}
        ddq = compiled.rhs(0.0, x, p, tau)[layout.n_q:]
        lam = compiled.constraint_forces(0.0, x, p, tau)
        out["diff_ddq"] = float(np.abs(ddq - values["ddq"]).max() / np.abs(values["ddq"]).max())
        out["diff_lambda"] = float(np.abs(lam - values["lambda"]).max()
                                   / np.abs(values["lambda"]).max())
    return out


def format_report(r: dict) -> str:
    ns = r["ns"]
    rows = [f"{r['robot']} on {', '.join(r['frames'])}: mbgen's C against Pinocchio's C++, "
            f"ns per call (smallest median of the rounds)",
            f"  forward dynamics with contacts: mbgen rhs {ns['mbgen_rhs']:>8}   "
            f"pin constraintDynamics {ns['pin_cd']:>8}   ({ns['pin_cd'] / ns['mbgen_rhs']:.2f}x)",
            f"  and its derivatives:            mbgen contact_jacobian "
            f"{ns['mbgen_contact_jacobian']:>8}   pin cd + derivatives {ns['pin_cdd']:>8}   "
            f"({ns['pin_cdd'] / ns['mbgen_contact_jacobian']:.2f}x)",
            f"  pin aba (no contact, for scale) {ns['pin_aba']}",
            f"  agreement with Pinocchio: u' {r['diff_ddq']:.1e}, lambda {r['diff_lambda']:.1e} "
            f"(relative)",
            f"  generation: {r['stages_s']}; operations {r['ops']}"]
    return "\n".join(rows)


if __name__ == "__main__":
    args = sys.argv[1:]
    print(format_report(measure(args[0], tuple(args[1:]) or FEET) if args else measure()))
