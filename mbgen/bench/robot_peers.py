"""The peers of ``mbgen bench robot``: Pinocchio's ``aba`` and MuJoCo's ``mj_forward``.

:func:`robot_file` finds a robot by name in ``example-robot-data`` (``panda``, ``ur5``,
``solo12``, ``g1``) or takes a path; :func:`clean_urdf` writes the copy every tool reads
(visuals, collisions and ``<mimic>`` removed: meshes are never needed, and a mimic joint
is made independent, as Pinocchio reads it by default).  :func:`mujoco_of_urdf` has MuJoCo
compile that copy (a free joint on the root link for a floating base; URDF damping zeroed,
since Pinocchio's ``aba`` has none) and :func:`switch_off` turns off in MuJoCo what mbgen
does not model (contacts, limits, equality constraints, friction loss, actuation).

The C++ loop (``templates/bench/robot_aba.cpp.j2``) loads the Pinocchio model that Python's
``pinocchio`` built from the file (``Model.saveToBinary``: the wheel ships no urdfdom
headers to parse it in C++) and is compiled like
:func:`mbgen.bench.arm_pinocchio.build_aba_driver`, also linking boost serialization;
the C loop (``templates/bench/mj_forward.c.j2``) loads a binary ``.mjb`` saved from
Python with the switches above and is compiled against the ``mujoco`` wheel's
``include`` folder and library.  Both print medians of loops timed like
:func:`mbgen.bench.timing.c_rhs_ns`.
"""

from __future__ import annotations

import re
import shutil
import statistics
import subprocess
from pathlib import Path

import numpy as np

from ..build.extension import compiler
from ..codegen.templating import environment
from ..errors import BenchmarkError
from ..model.robots import ROBOTS, robot_path
from .arm_pinocchio import PINOCCHIO_DEFINES, cmeel_prefix, import_pinocchio
from .timing import DRIVER_FLAGS, MIN_LOOP_S

#: What mbgen does not model, switched off in MuJoCo (``mjtDisableBit`` names).
SWITCHED_OFF = ("mjDSBL_CONTACT", "mjDSBL_LIMIT", "mjDSBL_EQUALITY", "mjDSBL_FRICTIONLOSS",
                "mjDSBL_ACTUATION")


def robot_file(name_or_path: str) -> tuple[Path, bool | None]:
    """``(path, floating)`` of a robot named in :data:`ROBOTS` (None: a path's, not known)."""
    if name_or_path in ROBOTS:
        import_pinocchio()
        found = robot_path(name_or_path)
        if found is not None:
            return found, ROBOTS[name_or_path][1]
        raise BenchmarkError(f"robot {name_or_path!r} needs example-robot-data: pip install "
                             f"example-robot-data")
    path = Path(name_or_path)
    if not path.is_file():
        raise BenchmarkError(f"no robot file {name_or_path!r}; give a .urdf or MJCF .xml file "
                             f"or one of {', '.join(ROBOTS)}")
    return path, None


def clean_urdf(path: Path, folder: Path) -> Path:
    """A copy of the URDF file without visuals, collisions and ``<mimic>`` elements."""
    text = Path(path).read_text(encoding="utf-8")
    text = re.sub(r"<(visual|collision)\b.*?</\1>|<(visual|collision)\b[^>]*/>", "", text,
                  flags=re.S)
    text = re.sub(r"<mimic\b[^>]*/>", "", text)
    out = Path(folder) / Path(path).name
    out.write_text(text, encoding="utf-8")
    return out


def import_mujoco():
    try:
        import mujoco
    except ImportError:
        return None
    return mujoco


def switch_off(mj, actuation: bool = False) -> None:
    """Switch off in ``mj`` what mbgen does not model (:data:`SWITCHED_OFF`); with
    ``actuation`` the actuators stay on (an MJCF file's, which mbgen reads)."""
    mujoco = import_mujoco()
    for flag in SWITCHED_OFF:
        if not (actuation and flag == "mjDSBL_ACTUATION"):
            mj.opt.disableflags |= int(getattr(mujoco.mjtDisableBit, flag))


def mujoco_spec_of_urdf(path: Path, floating: bool):
    """MuJoCo's ``MjSpec`` of a URDF file (cleaned), a free joint on its root if floating."""
    mujoco = import_mujoco()
    text = re.sub(r"<(visual|collision)\b.*?</\1>", "", Path(path).read_text(encoding="utf-8"),
                  flags=re.S)
    text = re.sub(r"<mimic\b[^>]*/>", "", text)
    spec = mujoco.MjSpec.from_string(text)
    if floating:
        spec.worldbody.first_body().add_freejoint()
    return spec


def mujoco_of_urdf(path: Path, floating: bool):
    """MuJoCo's compiled model of a URDF file, its damping, armature and springs zeroed."""
    mj = mujoco_spec_of_urdf(path, floating).compile()
    mj.dof_damping[:] = 0.0
    mj.dof_armature[:] = 0.0
    mj.jnt_stiffness[:] = 0.0
    return mj


def _run(cmd, what: str, **kw) -> subprocess.CompletedProcess:
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if proc.returncode != 0:
        raise BenchmarkError(f"{what} failed:\n{(proc.stderr or proc.stdout)[-3000:]}")
    return proc


def _times_and(out: str, key: str) -> tuple[float, np.ndarray]:
    lines = out.splitlines()
    times = [float(s) for s in lines if s[:1].isdigit()]
    values = next(s for s in lines if s.startswith(key)).split()[1:]
    return statistics.median(times), np.array([float(x) for x in values])


def build_aba_driver(folder: Path, repeats: int) -> Path:
    """Compile Pinocchio's C++ loop over a robot file (about a minute)."""
    prefix = cmeel_prefix()
    cxx = shutil.which("g++") or shutil.which("c++")
    if cxx is None:
        raise BenchmarkError("no C++ compiler (g++) for Pinocchio's C++ loop")
    source = Path(folder) / "bench_robot_aba.cpp"
    source.write_text(environment().get_template("bench/robot_aba.cpp.j2").render(
        min_loop_s=MIN_LOOP_S, repeats=repeats), encoding="utf-8")
    exe = Path(folder) / "bench_robot_aba"
    _run([cxx, "-std=c++17", *DRIVER_FLAGS, *PINOCCHIO_DEFINES, f"-I{prefix / 'include'}",
          f"-I{prefix / 'include' / 'eigen3'}", str(source), "-o", str(exe),
          f"-L{prefix / 'lib'}", "-lpinocchio_default", "-lboost_serialization",
          f"-Wl,-rpath,{prefix / 'lib'}"], "compiling Pinocchio's C++ loop")
    return exe


def run_aba_driver(exe: Path, model, folder: Path, q, v, tau) -> tuple[float, np.ndarray]:
    """``(median ns per aba call, accelerations)`` of ``model`` (a ``pinocchio.Model``)
    from the C++ loop."""
    path = Path(folder) / "model.bin"
    model.saveToBinary(str(path))
    text = "\n".join(" ".join(repr(float(x)) for x in row)
                     for row in (model.gravity.linear, q, v, tau))
    proc = _run([str(exe), str(path)],
                "Pinocchio's C++ loop", input=text + "\n")
    return _times_and(proc.stdout, "ddq")


def build_mj_driver(folder: Path, repeats: int) -> Path:
    """Compile MuJoCo's C loop against the ``mujoco`` wheel (headers and library)."""
    mujoco = import_mujoco()
    root = Path(mujoco.__file__).resolve().parent
    libs = sorted(root.glob("libmujoco.so*"))
    if not (root / "include" / "mujoco" / "mujoco.h").is_file() or not libs:
        raise BenchmarkError(f"the mujoco wheel at {root} has no include/mujoco or libmujoco")
    source = Path(folder) / "bench_mj_forward.c"
    source.write_text(environment().get_template("bench/mj_forward.c.j2").render(
        min_loop_s=MIN_LOOP_S, repeats=repeats), encoding="utf-8")
    exe = Path(folder) / "bench_mj_forward"
    _run([compiler(), "-std=c99", *DRIVER_FLAGS, f"-I{root / 'include'}", str(source), "-o",
          str(exe), str(libs[0]), f"-Wl,-rpath,{root}", "-lm"], "compiling MuJoCo's C loop")
    return exe


def run_mj_driver(exe: Path, mjb: Path, qpos, qvel, qfrc) -> tuple[float, np.ndarray]:
    """``(median ns per mj_forward call, qacc)`` from the C loop."""
    text = "\n".join(" ".join(repr(float(x)) for x in row) for row in (qpos, qvel, qfrc))
    proc = _run([str(exe), str(mjb)], "MuJoCo's C loop", input=text + "\n")
    return _times_and(proc.stdout, "qacc")


__all__ = ["ROBOTS", "SWITCHED_OFF", "build_aba_driver", "build_mj_driver", "clean_urdf",
           "mujoco_of_urdf", "mujoco_spec_of_urdf", "robot_file", "run_aba_driver", "run_mj_driver",
           "switch_off"]
