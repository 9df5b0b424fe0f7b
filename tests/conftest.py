"""Test-suite setup: a private cache of compiled modules for the whole session, and the
quick tier.

Tests never read or pollute the user's ``~/.cache/mbgen``, and every model is compiled at
least once per run, as on a fresh CI machine, and derived every time (``MBGEN_WARM=0``).

The quick tier (``pytest -m quick``, under a minute on an idle 2-core machine) is for the
edit loop: the files of :data:`QUICK`, at least one per stage, chosen for their run time
(``pytest --durations=0`` of the default run, a cold cache).  The default command (README)
still runs everything but the ``slow`` cases.
"""

import os
import shutil
import tempfile
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent

#: Test files of the quick tier (paths under tests/), by stage.
QUICK = frozenset({
    "model/test_scene.py", "model/test_names.py", "model/test_expressions.py",
    "model/test_kinematics.py", "model/test_limits.py",
    "derivation/test_constraints_errors.py", "derivation/test_derive.py",
    "derivation/test_reactions_loads.py", "derivation/test_damping.py",
    "symbolic/test_graph.py",
    "codegen/test_printing.py", "codegen/test_escape.py", "codegen/test_outputs.py",
    "codegen/test_targets.py", "codegen/test_solver.py",
    "build/test_cflags.py",
    "runtime/test_runtime.py", "runtime/test_linearize.py", "runtime/test_batch.py",
    "runtime/test_base.py", "runtime/test_consistent.py", "runtime/test_named.py",
    "runtime/test_simulate.py", "runtime/test_inputs.py",
    "verify/test_audit.py", "studies/test_cluster.py",
    "bench/test_timing.py", "bench/test_crossing.py",
    "cli/test_conventions.py", "cli/test_generate_paths.py",
    "test_errors.py", "test_layout.py",
})


def pytest_configure(config):
    # every run derives what it compiles (tests change module settings that shape the code,
    # which the warm cache's key does not see); tests/test_pipeline_warm.py turns it on
    os.environ.setdefault("MBGEN_WARM", "0")
    if "MBGEN_CACHE_DIR" not in os.environ:
        path = tempfile.mkdtemp(prefix="mbgen-test-cache-")
        os.environ["MBGEN_CACHE_DIR"] = path
        config._mbgen_cache = path


def pytest_unconfigure(config):
    path = getattr(config, "_mbgen_cache", None)
    if path:
        shutil.rmtree(path, ignore_errors=True)
        os.environ.pop("MBGEN_CACHE_DIR", None)


def pytest_collection_modifyitems(config, items):
    """Mark the tests of :data:`QUICK`'s files ``quick``."""
    for item in items:
        if Path(item.fspath).resolve().relative_to(TESTS).as_posix() in QUICK:
            item.add_marker(pytest.mark.quick)
