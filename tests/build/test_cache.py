"""The build cache verifies what it loads, and loads only what its user built.

A damaged module is loaded in a child process: a truncated library used to crash the
interpreter (SIGBUS) when mapped, so the crash must not take the test run down.  A
planted library is refused before it is mapped (its constructor would run), a module
swapped after its check is not the one loaded (the checked file is), and a full disk,
a read-only cache or a cache reached through another user's link is a named error
(CacheError), never an OSError.
"""

from __future__ import annotations

import errno
import hashlib
import importlib.machinery
import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

from mbgen.build import cache as cache_module
from mbgen.build import extension
from mbgen.build.cache import STALE_AFTER, cache_dir, remove_stale_builds, verified
from mbgen.build.extension import build, compiled_path, load, module_name
from mbgen.errors import CacheError
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from models import pendulum

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


@pytest.mark.parametrize("damage", ["truncate", "empty", "flip",
                                    pytest.param("no-record", marks=pytest.mark.slow)])
def test_a_damaged_module_is_rebuilt_not_loaded(cache, damage):
    root, path, answer = cache
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 5])  # 20%: mapping it was a SIGBUS
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "flip":  # same size, one byte changed, same modification time
        stat = path.stat()
        i = len(data) // 3
        path.write_bytes(data[:i] + bytes([data[i] ^ 0xFF]) + data[i + 1:])
        os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
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
        import os, signal
        from mbgen.build import extension
        def compile(*a, **k):
            os.kill(os.getpid(), signal.SIGKILL)
        extension._compile = compile
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


# ------------------------------------------------------------ whose folder, whose file
def _tiny(name):
    return run(pendulum(name), build=False).rendered


def _module_file(folder: Path, rendered) -> Path:
    return folder / (module_name(rendered) + importlib.machinery.EXTENSION_SUFFIXES[0])


PLANTED = r"""
#include <stdio.h>
__attribute__((constructor)) static void planted(void) {
    FILE *f = fopen("%s", "w");
    if (f) fclose(f);
}
"""


def _plant(path: Path, marker: Path, scratch: Path) -> None:
    """A library at ``path`` whose constructor creates ``marker``, with a matching record."""
    source = scratch / "planted.c"
    source.write_text(PLANTED % marker)
    subprocess.run([extension.compiler(), "-shared", "-fPIC", "-o", str(path), str(source)],
                   check=True)
    data = path.read_bytes()
    path.with_name(path.name + ".sha256").write_text(
        f"{len(data)} {hashlib.sha256(data).hexdigest()}\n")


def _shared_fallback(tmp_path, monkeypatch) -> Path:
    """An unusable home cache, and a fallback folder under TMPDIR that anyone can write."""
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.delenv("MBGEN_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    tmp.chmod(0o1777)
    monkeypatch.setenv("TMPDIR", str(tmp))
    monkeypatch.setattr(tempfile, "tempdir", None)
    shared = tmp / f"mbgen-cache-{os.getuid()}"
    shared.mkdir()
    shared.chmod(0o777)
    return shared


def _owned_by_someone_else(path: Path, monkeypatch) -> None:
    """Give ``path`` another owner (as root), or pretend to be another user."""
    if os.geteuid() == 0:
        os.chown(path, 65534, 65534)
    else:
        other = os.stat(path).st_uid + 1
        monkeypatch.setattr(os, "getuid", lambda: other)
        monkeypatch.setattr(os, "geteuid", lambda: other)


def test_a_library_planted_in_a_shared_fallback_folder_is_not_loaded(tmp_path, monkeypatch):
    shared = _shared_fallback(tmp_path, monkeypatch)
    rendered = _tiny("planted")
    marker = tmp_path / "constructor-ran"
    _plant(_module_file(shared, rendered), marker, tmp_path)
    with pytest.raises(CacheError) as info:
        load(rendered)
    message = str(info.value)
    assert str(shared) in message and "0o777" in message
    assert "chmod" in message and "MBGEN_CACHE_DIR" in message
    assert not marker.exists(), "the planted library's constructor ran"
    shared.chmod(0o700)  # the plant itself would pass: only the folder's mode refused it
    assert verified(_module_file(shared, rendered))


@pytest.mark.parametrize("mode", [0o777, 0o770, 0o702], ids=oct)
def test_a_cache_folder_others_can_write_is_refused(tmp_path, monkeypatch, mode):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    tmp_path.chmod(mode)
    with pytest.raises(CacheError, match=f"{tmp_path}.*{oct(mode)}.*chmod go-w"):
        cache_dir()


def test_a_cache_folder_owned_by_someone_else_is_refused(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(cache))
    _owned_by_someone_else(cache, monkeypatch)
    with pytest.raises(CacheError, match=f"{cache}.*owned by.*MBGEN_CACHE_DIR"):
        cache_dir()


def test_new_cache_folders_are_private(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path / "new" / "cache"))
    assert cache_dir().stat().st_mode & 0o777 == 0o700
    shared = _shared_fallback(tmp_path, monkeypatch)
    shared.rmdir()
    assert cache_dir() == shared and shared.stat().st_mode & 0o777 == 0o700


def test_the_folder_is_checked_before_every_load_not_only_when_made(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    rendered = _tiny("everyload")
    path = build(rendered)
    tmp_path.chmod(0o777)
    with pytest.raises(CacheError, match="0o777"):
        build(rendered)
    tmp_path.chmod(0o700)
    path.chmod(0o666)  # the module file itself: others could have changed it
    assert not verified(path)
    assert build(rendered) == path and verified(path)
    assert path.stat().st_mode & 0o022 == 0


def _read_only(folder: Path, monkeypatch) -> None:
    """Make ``folder`` read-only; root writes anyway, so its access check says no, too."""
    folder.chmod(0o500)
    real = os.access

    def access(path, mode, **kwargs):
        if Path(path) == folder and mode & os.W_OK:
            return False
        return real(path, mode, **kwargs)

    monkeypatch.setattr(os, "access", access)


def test_a_read_only_cache_that_holds_the_module_loads_it(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(cache))
    rendered = _tiny("readonly")
    build(rendered)
    before = sorted(cache.iterdir())
    _read_only(cache, monkeypatch)
    try:
        mod = load(rendered)
        assert hasattr(mod.lib, "readonly_rhs")
        with pytest.raises(CacheError, match=f"{cache}.*read-only.*MBGEN_CACHE_DIR"):
            load(_tiny("readonly2"))
        assert sorted(cache.iterdir()) == before
    finally:
        cache.chmod(0o700)


# ------------------------------------------------------------------------ a full disk
def test_a_full_disk_while_writing_the_sources_is_a_named_error(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))

    def full(folder, files):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(Path(folder) / "x.c"))

    monkeypatch.setattr(extension, "write_files", full)
    with pytest.raises(CacheError) as info:
        load(_tiny("fulldisk"))
    message = str(info.value)
    assert str(tmp_path) in message and "no space left" in message.lower()
    assert "\n" not in message
    folders = [p for p in tmp_path.iterdir()
               if p.is_dir() and not p.name.startswith("templates-")]  # compiled templates
    assert not folders, "the build folder stayed"


FULL_DISK_CC = """#!/bin/sh
echo "cc1: fatal error: error writing to /tmp/ccXz1.s: No space left on device" >&2
exit 1
"""


def full_disk_compiler(folder: Path) -> Path:
    """A C compiler that fails as gcc does on a full disk."""
    cc = folder / "full-disk-cc"
    cc.write_text(FULL_DISK_CC)
    cc.chmod(0o755)
    return cc


def test_a_full_disk_while_compiling_is_a_named_error(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(cache))
    monkeypatch.setenv("CC", str(full_disk_compiler(tmp_path)))
    with pytest.raises(CacheError) as info:
        load(_tiny("fullcc"))
    message = str(info.value)
    assert str(cache) in message and "no space left" in message.lower()
    assert "\n" not in message


# ------------------------------------------------------------------ links, records, the load
def test_a_cache_is_reached_only_through_the_users_own_links(tmp_path, monkeypatch):
    """Issue 28: a link another user owns can be pointed elsewhere while modules load."""
    real = tmp_path / "real"
    real.mkdir(mode=0o700)
    (tmp_path / "mine").symlink_to(real)
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path / "mine" / "cache"))
    assert cache_dir() == real / "cache"                    # used by its real path
    theirs = tmp_path / "theirs"
    theirs.symlink_to("mine")                               # a link on the way, not the last
    if os.geteuid() == 0:
        os.lchown(theirs, 65534, 65534)
    else:
        lstat = os.lstat
        monkeypatch.setattr(os, "lstat", lambda p, **k: os.stat_result(
            (*lstat(p, **k)[:4], 65534, *lstat(p, **k)[5:10])) if str(p) == str(theirs)
            else lstat(p, **k))
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(theirs / "cache"))
    with pytest.raises(CacheError, match=f"through the link {theirs}, owned by .*65534"):
        cache_dir()
    loop = tmp_path / "loop"
    loop.symlink_to("loop")
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(loop / "cache"))
    with pytest.raises(CacheError, match="more than 40 links"):
        cache_dir()


def test_a_record_that_is_not_the_users_own_private_file_vouches_for_nothing(cache,
                                                                             monkeypatch):
    """The record (``<module>.sha256``) is what makes a module trusted: one that group or
    others could write, another user's, or a link is not read."""
    root, path, _ = cache
    record = path.with_name(path.name + ".sha256")
    record.chmod(0o666)
    assert not verified(path)
    record.chmod(0o644)
    assert verified(path)
    elsewhere = root / "elsewhere.sha256"
    os.replace(record, elsewhere)
    record.symlink_to(elsewhere)
    assert not verified(path)
    os.replace(elsewhere, record)
    assert verified(path)
    _owned_by_someone_else(record, monkeypatch)
    assert not verified(path)


@pytest.mark.parametrize("way", ["proc", "copy"])
def test_the_loaded_bytes_are_the_checked_bytes(cache, monkeypatch, tmp_path_factory, way):
    """Issue 28: the check and the load opened the module by name, ~0.2 ms apart; a planted
    library swapped in between ran (7 loads in 300).  Here the swap comes right after the
    check, with a plant that would pass it: the module loaded is still the checked one."""
    root, path, _ = cache
    scratch = tmp_path_factory.mktemp("plant")
    marker, plant = scratch / "constructor-ran", scratch / "plant.so"
    _plant(plant, marker, scratch)
    if way == "copy":
        monkeypatch.setattr(cache_module, "PROC_FD", None)
    real = cache_module.open_verified

    def checked_then_swapped(module):
        fd = real(module)
        if sys._getframe(1).f_code.co_name != "loadable":      # build's check: no swap yet
            return fd
        os.replace(plant.with_name(plant.name + ".sha256"), module.with_name(
            module.name + ".sha256"))
        os.replace(plant, module)
        return fd

    monkeypatch.setattr(cache_module, "open_verified", checked_then_swapped)
    rendered = run(load_scene("n_link_cart", n=1), build=False).rendered
    mod = load(rendered)
    assert not marker.exists(), "the library swapped in after the check was loaded"
    assert hasattr(mod.lib, f"{rendered.prefix}_rhs")
    monkeypatch.undo()
    assert verified(path), "the plant would have passed a check by name"
    assert not list(root.glob("_mbgen_load-*")), "the private copy stayed"
