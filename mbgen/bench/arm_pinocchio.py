"""Pinocchio's side of the arm benchmark: the arm as a ``pinocchio.Model`` and its C++ loop.

:func:`pinocchio_arm` builds :mod:`mbgen.scenes.spatial_arm` in Pinocchio: joints
``JointModelRZ``/``JointModelRY`` alternating, placements ``(I, [a, 0, 0])``, inertias
at lever ``[b, 0, 0]``, gravity ``-g`` along z; :func:`pinocchio_aba` gives its joint
accelerations from ``pin.aba``.  :func:`build_aba_driver` compiles the C++ loop
(``templates/bench/aba.cpp.j2``: ``pinocchio::aba`` timed like
:func:`mbgen.bench.timing.c_rhs_ns`) with ``g++`` against the ``pin`` wheel's
``include``/``lib`` folders and the Eigen headers of ``cmeel-eigen``;
:func:`run_aba_driver` feeds it the arm's values and a state and reads back
``(median ns per call, accelerations)``; :func:`run_aba_derivatives_driver` times
``pinocchio::computeABADerivatives`` with the same executable and reads back
``[ddq_dq, ddq_dv]`` (:func:`pinocchio_aba_derivatives`: the same from Python).

Pinocchio (PyPI ``pin``, the ``bench`` extra) is imported when first needed.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np

from ..codegen.templating import environment
from ..errors import BenchmarkError
from ..scenes.spatial_arm import axis, link_parameters
from .timing import DRIVER_FLAGS, MIN_LOOP_S, median_ns, run_driver

#: Defines Pinocchio's CMake config exports (boost::variant with its 25 joint types).
PINOCCHIO_DEFINES = ("-DBOOST_MPL_LIMIT_LIST_SIZE=30", "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
                     "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS")


def import_pinocchio():
    """The ``pinocchio`` module, or :class:`BenchmarkError` naming the extra that has it."""
    try:
        import pinocchio
    except ImportError:
        raise BenchmarkError("Pinocchio is not installed: pip install -e '.[bench]' (PyPI 'pin')") \
            from None
    return pinocchio


def link_rows(n: int) -> list[tuple]:
    """Per link ``(axis, a_prev, b, m, Ixx, Iyy, Izz, Ixy, Iyz, Izx)`` from the scene's values."""
    v = link_parameters(n)
    return [(axis(i), v[f"a{i - 1}"] if i > 1 else 0.0, v[f"b{i}"], v[f"m{i}"],
             *(v[f"{k}{i}"] for k in ("Ixx", "Iyy", "Izz", "Ixy", "Iyz", "Izx")))
            for i in range(1, n + 1)]


def pinocchio_arm(n: int):
    """The arm as a ``pinocchio.Model`` (gravity ``-g`` along z) with its values."""
    pin = import_pinocchio()
    model = pin.Model()
    parent = 0
    for i, (ax, a, b, m, ixx, iyy, izz, ixy, iyz, izx) in enumerate(link_rows(n), start=1):
        joint = pin.JointModelRZ() if ax == 3 else pin.JointModelRY()
        place = pin.SE3(np.eye(3), np.array([a, 0.0, 0.0]))
        parent = model.addJoint(parent, joint, place, f"joint{i}")
        inertia = np.array([[ixx, ixy, izx], [ixy, iyy, iyz], [izx, iyz, izz]])
        model.appendBodyToJoint(parent, pin.Inertia(m, np.array([b, 0.0, 0.0]), inertia),
                                pin.SE3.Identity())
    model.gravity.linear = np.array([0.0, 0.0, -link_parameters(n)["g"]])
    return model


def pinocchio_aba(n: int, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Joint accelerations of the unactuated arm from ``pin.aba``."""
    pin = import_pinocchio()
    model = pinocchio_arm(n)
    return np.array(pin.aba(model, model.createData(), q, v, np.zeros(n)))


def cmeel_prefix() -> Path:
    """The folder the ``pin`` wheel installed into (it holds ``include/`` and ``lib/``)."""
    pin = import_pinocchio()
    prefix = next((p for p in Path(pin.__file__).resolve().parents
                   if (p / "include" / "pinocchio").is_dir()), None)
    if prefix is None:
        raise BenchmarkError(f"no Pinocchio headers above {pin.__file__}; the C++ loop needs the "
                             f"'pin' wheel's include and lib folders")
    if not (prefix / "include" / "eigen3").is_dir():
        raise BenchmarkError("no Eigen headers for the C++ loop: pip install -e '.[bench]' "
                             "(PyPI 'cmeel-eigen')")
    return prefix


def build_aba_driver(folder: Path, repeats: int) -> Path:
    """Compile the C++ ``aba`` loop against the wheel; returns the executable (about a minute)."""
    prefix = cmeel_prefix()
    cxx = shutil.which("g++") or shutil.which("c++")
    if cxx is None:
        raise BenchmarkError("no C++ compiler (g++) for Pinocchio's C++ loop")
    source = folder / "bench_aba.cpp"
    source.write_text(environment().get_template("bench/aba.cpp.j2").render(
        min_loop_s=MIN_LOOP_S, repeats=repeats), encoding="utf-8")
    exe = folder / "bench_aba"
    cmd = [cxx, "-std=c++17", *DRIVER_FLAGS, *PINOCCHIO_DEFINES, f"-I{prefix / 'include'}",
           f"-I{prefix / 'include' / 'eigen3'}", str(source), "-o", str(exe),
           f"-L{prefix / 'lib'}", "-lpinocchio_default", f"-Wl,-rpath,{prefix / 'lib'}"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise BenchmarkError(f"compiling Pinocchio's C++ loop failed:\n{proc.stderr[-3000:]}")
    return exe


def _driver_input(n: int, q: np.ndarray, v: np.ndarray) -> str:
    lines = [str(n)] + [" ".join(repr(float(x)) if k else str(x) for k, x in enumerate(row))
                        for row in link_rows(n)]
    lines += [repr(link_parameters(n)["g"]), " ".join(map(repr, map(float, q))),
              " ".join(map(repr, map(float, v)))]
    return "\n".join(lines) + "\n"


def _values(out: list[str], key: str) -> np.ndarray:
    return np.array([float(x) for x in next(s for s in out if s.startswith(key + " ")).split()[1:]])


def run_aba_driver(exe: Path, n: int, q: np.ndarray, v: np.ndarray) -> tuple[float, np.ndarray]:
    """``(median ns per aba call, accelerations)`` from the C++ loop."""
    out = run_driver([str(exe)], "Pinocchio's C++ loop", _driver_input(n, q, v)).splitlines()
    return median_ns("\n".join(out)), _values(out, "ddq")


def run_aba_derivatives_driver(exe: Path, n: int, q: np.ndarray, v: np.ndarray
                               ) -> tuple[float, np.ndarray]:
    """``(median ns per computeABADerivatives call, [ddq_dq, ddq_dv])`` from the C++ loop.

    The same executable as :func:`run_aba_driver`, run with the argument ``derivatives``;
    the derivatives come back as one ``n x 2n`` array, the layout of the lower ``n`` rows
    of mbgen's Jacobian (``[du'/dq, du'/du]``).
    """
    out = run_driver([str(exe), "derivatives"], "Pinocchio's C++ computeABADerivatives loop",
                     _driver_input(n, q, v)).splitlines()
    return median_ns("\n".join(out)), np.hstack([_values(out, "ddq_dq").reshape(n, n),
                                                 _values(out, "ddq_dv").reshape(n, n)])


def pinocchio_aba_derivatives(n: int, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``[ddq_dq, ddq_dv]`` (``n x 2n``) of the unactuated arm from
    ``pin.computeABADerivatives``."""
    pin = import_pinocchio()
    model = pinocchio_arm(n)
    data = model.createData()      # the arrays returned are views into data: keep it alive
    pin.computeABADerivatives(model, data, q, v, np.zeros(n))
    return np.hstack([np.array(data.ddq_dq, copy=True), np.array(data.ddq_dv, copy=True)])
