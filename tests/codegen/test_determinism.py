"""Generated text depends on nothing but the model: not the hash seed, not the CPU.

A fresh clone on another machine must produce ``generated/`` byte for byte.  Three
things could make the text follow the machine: an ordering that follows ``hash()``
(``PYTHONHASHSEED``), numpy's CPU-dispatched loops (``NPY_DISABLE_CPU_FEATURES``),
and BLAS kernels, whose summation order and fused multiply-adds differ by CPU
(``OPENBLAS_CORETYPE``): the Whipple bicycle's constants were once turned with a BLAS
product and its CSE gave 7196 operations on one CPU and 7186 on another.  A child
process regenerates a few scenes with all three changed and must give the checked-in
bytes.
"""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

GENERATED = Path(__file__).resolve().parents[2] / "generated"
#: the scene that once followed the CPU, one with Newton–Euler and reactions, one with
#: constraints, and the smallest
SCENES = ("whipple", "spatial_arm", "four_bar", "disc_pendulum")

CHILD = """
import hashlib, json, sys
from mbgen.verify.golden import scene_files
print(json.dumps({name: {f: hashlib.sha256(t.encode()).hexdigest() for f, t in
                         scene_files(name).items()} for name in sys.argv[1:]}))
"""


def _dispatched_features() -> str:
    """Every CPU feature numpy dispatches on this machine (all may be disabled)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__
    except ImportError:  # numpy 1.x
        from numpy.core._multiarray_umath import __cpu_dispatch__
    return " ".join(__cpu_dispatch__)


def _checked_in(name: str) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted((GENERATED / name).iterdir()) if p.is_file()}


@pytest.mark.parametrize("env", [
    {"PYTHONHASHSEED": "12345", "OPENBLAS_CORETYPE": "Prescott"},
    pytest.param({"PYTHONHASHSEED": "0", "OPENBLAS_CORETYPE": "Haswell",
                  "NPY_DISABLE_CPU_FEATURES": None},
                 marks=pytest.mark.slow),  # 5.5 s; one by default
], ids=["hashseed-blas-generic", "hashseed0-blas-haswell-numpy-baseline"])
def test_generated_text_does_not_follow_the_machine(env):
    env = {k: (_dispatched_features() if k == "NPY_DISABLE_CPU_FEATURES" else v)
           for k, v in env.items()}
    proc = subprocess.run([sys.executable, "-c", CHILD, *SCENES], capture_output=True,
                          text=True, env={**os.environ, **env}, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    fresh = json.loads(proc.stdout.strip().splitlines()[-1])
    for name in SCENES:
        assert fresh[name] == _checked_in(name), f"{name} differs under {env}"
