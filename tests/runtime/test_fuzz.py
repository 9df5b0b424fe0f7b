"""Fuzz the compiled C and the generated Python with hostile arguments (hypothesis).

Every call runs in a child process (``tests/support/fuzz_worker.py``), so a crash (a
segfault, an abort) is counted instead of taking the test run down.  What must
hold over every seeded call:

* 0 crashes;
* 0 unnamed exceptions: every refusal is an :class:`mbgen.errors.MbgenError`;
* 0 silent non-finite results: NaN or infinity is never returned;
* C and generated Python agree: the same outcome (ok, or the same error class)
  and, when both succeed, the same values;
* 8 threads making the same calls at once get the answers of one thread.

The default run is small (CI, under a minute); ``-m slow`` runs a larger one.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

WORKER = Path(__file__).resolve().parents[1] / "support" / "fuzz_worker.py"


def census(examples: int, seed: int, max_restarts: int = 5) -> dict:
    """Run the worker; restart it after a crash (the crashing call is counted and skipped)."""
    crashes, crashed_at, skip = 0, [], 0
    with tempfile.TemporaryDirectory() as tmp:
        progress = os.path.join(tmp, "progress")
        for _ in range(max_restarts + 1):
            proc = subprocess.run([sys.executable, str(WORKER), str(examples), str(seed),
                                   str(skip), progress], capture_output=True, text=True,
                                  timeout=1800)
            if proc.returncode == 0:
                result = json.loads(proc.stdout.strip().splitlines()[-1])
                result["crashes"], result["crashed_at"] = crashes, crashed_at
                return result
            if proc.returncode > 0:  # the worker itself failed: show why
                raise AssertionError(f"fuzz worker failed (exit {proc.returncode}):\n"
                                     f"{proc.stderr[-4000:]}")
            crashes += 1
            at = int(Path(progress).read_text()) if os.path.exists(progress) else -1
            crashed_at.append((at, proc.returncode))
            skip = at + 1
    raise AssertionError(f"fuzz worker crashed {crashes} times at {crashed_at}")


def assert_clean(result: dict) -> None:
    summary = {k: result[k] for k in ("calls", "examples", "ok", "named", "unnamed", "nonfinite",
                                      "disagree_outcome", "disagree_value", "crashes")}
    bad = "\n".join(result["samples"][:20])
    assert result["crashes"] == 0, f"{summary} crashed at {result['crashed_at']}"
    assert result["unnamed"] == 0, f"{summary}\n{bad}"
    assert result["nonfinite"] == 0, f"{summary}\n{bad}"
    assert result["disagree_outcome"] == 0, f"{summary}\n{bad}"
    assert result["disagree_value"] == 0, f"{summary}\n{bad}"
    # the run did something: most calls were refused or answered, and some succeeded
    assert result["ok"] > result["calls"] // 10, summary


def test_fuzz_small():
    """About 400 seeded hostile calls (seconds once the two models are compiled)."""
    assert_clean(census(examples=250, seed=20261124))


def test_threads_agree_with_one_thread():
    """8 threads making the same calls (C and Python, good and NaN inputs) at once."""
    proc = subprocess.run([sys.executable, str(WORKER), "threads", "300", "5"],
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, f"exit {proc.returncode}: {proc.stderr[-3000:]}"
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["calls"] == 8 * 600
    assert result["mismatches"] == 0 and result["unnamed"] == 0, result


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_fuzz_large(seed):
    assert_clean(census(examples=4000, seed=seed))
