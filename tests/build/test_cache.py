"""The build cache verifies what it loads.

Loading happens in a child process: a truncated library used to crash the
interpreter (SIGBUS) when mapped, so the crash must not take the test run down.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from mbgen.build.extension import (STALE_AFTER, cache_dir, compiled_path, remove_stale_builds,
                                   verified)
from mbgen.errors import CacheError
from mbgen.pipeline import run
from mbgen.model.scene import load_scene

LOAD = textwrap.dedent("""
    import numpy as np
    import mbgen
    from mbgen.model.scene import load_scene
    model = mbgen.compile(load_scene("n_link_cart", n=1))
    print(repr(model.rhs(0.0, np.array([0.1, 0.2, 0.0, 0.0])).tolist()))
""")


def _load_in_child(cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "MBGEN_CACHE_DIR": str(cache)}
    return subprocess.run([sys.executable, "-c", LOAD], capture_output=True, text=True,
                          env=env, timeout=600)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The compiled 1-link cart in a cache of its own (built once), and its answer."""
    root = tmp_path_factory.mktemp("built")
    first = _load_in_child(root)
    assert first.returncode == 0, first.stderr
    return root, first.stdout


@pytest.fixture()
def cache(built, tmp_path, monkeypatch):
    """A fresh copy of that cache: (folder, module path, answer)."""
    root, answer = built
    for f in root.iterdir():
        if f.is_file():
            shutil.copy2(f, tmp_path / f.name)
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    rendered = run(load_scene("n_link_cart", n=1), build=False).rendered
    path = compiled_path(rendered)
    assert path.exists() and verified(path)
    return tmp_path, path, answer


@pytest.mark.parametrize("damage", ["truncate", "empty",
                                    pytest.param("flip", marks=pytest.mark.slow),
                                    pytest.param("no-record", marks=pytest.mark.slow)])
def test_a_damaged_module_is_rebuilt_not_loaded(cache, damage):
    root, path, answer = cache
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 5])  # 20%: mapping it was a SIGBUS
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "flip":  # same size, one byte changed
        i = len(data) // 3
        path.write_bytes(data[:i] + bytes([data[i] ^ 0xFF]) + data[i + 1:])
    else:
        path.with_name(path.name + ".sha256").unlink()
    assert not verified(path)
    again = _load_in_child(root)
    assert again.returncode == 0, f"exit {again.returncode}: {again.stderr[-2000:]}"
    assert again.stdout == answer
    assert verified(path)


def test_stale_build_folders_are_removed(cache):
    root, path, _ = cache
    dead = root / "_mbgen_x_0123456789abcdef-killed"
    dead.mkdir()
    (dead / "owner").write_text(f"{os.uname().nodename} 999999999\n")
    (dead / "x.c").write_text("/* half */")
    old = root / "_mbgen_y_0123456789abcdef-old"
    old.mkdir()
    os.utime(old, (0, 0))  # no owner file, older than STALE_AFTER
    alive = root / "_mbgen_z_0123456789abcdef-running"
    alive.mkdir()
    (alive / "owner").write_text(f"{os.uname().nodename} {os.getpid()}\n")
    removed = remove_stale_builds(root)
    assert set(removed) == {dead, old}
    assert alive.exists() and not dead.exists() and not old.exists()
    assert STALE_AFTER > 3600


@pytest.mark.slow
def test_a_killed_build_leaves_nothing_behind_after_the_next(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    # a child killed in the middle of its build: SIGKILL when the compiler would start
    killer = textwrap.dedent("""
        import os, signal, cffi
        def compile(self, *a, **k):
            os.kill(os.getpid(), signal.SIGKILL)
        cffi.FFI.compile = compile
    """) + LOAD
    proc = subprocess.run([sys.executable, "-c", killer], env={**os.environ},
                          capture_output=True, timeout=600)
    assert proc.returncode == -9
    leftovers = [p for p in tmp_path.glob("_mbgen_*-*") if p.is_dir()]
    assert leftovers, "the killed build left no folder (nothing to clean up)"
    again = _load_in_child(tmp_path)
    assert again.returncode == 0, again.stderr
    assert not [p for p in tmp_path.glob("_mbgen_*-*") if p.is_dir()]


def test_an_unusable_explicit_cache_folder_is_a_named_error(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(blocker / "cache"))
    with pytest.raises(CacheError) as info:
        cache_dir()
    assert "MBGEN_CACHE_DIR" in str(info.value)


def test_an_unusable_default_cache_folder_falls_back(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.delenv("MBGEN_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))
    (tmp_path / "tmp").mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", None)
    root = cache_dir()
    assert root.is_dir() and str(root).startswith(str(tmp_path / "tmp"))
