"""Test-suite setup: a private cache of compiled modules for the whole session.

Tests then never read or pollute the user's ``~/.cache/mbgen``, and every model
is compiled at least once per run, as on a fresh CI machine.
"""

import os
import shutil
import tempfile


def pytest_configure(config):
    if "MBGEN_CACHE_DIR" not in os.environ:
        path = tempfile.mkdtemp(prefix="mbgen-test-cache-")
        os.environ["MBGEN_CACHE_DIR"] = path
        config._mbgen_cache = path


def pytest_unconfigure(config):
    path = getattr(config, "_mbgen_cache", None)
    if path:
        shutil.rmtree(path, ignore_errors=True)
        os.environ.pop("MBGEN_CACHE_DIR", None)
