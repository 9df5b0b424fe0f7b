"""The warm cache's records: kept and read back whole, and never read (let alone unpickled)
unless they are the user's own, whole, unchanged and filed under their own key."""

from __future__ import annotations

import errno
import os
import pickle
import stat

import pytest

from mbgen.build import warm
from mbgen.build.cache import record_path, write_record
from mbgen.errors import BuildError
from mbgen.pipeline import run
from models import pendulum

KEY, OTHER = "a" * 64, "b" * 64


@pytest.fixture(scope="module")
def rendered():
    return run(pendulum("warm_pendulum"), build=False).rendered


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    return tmp_path


def test_a_record_reads_back_whole(cache, rendered):
    assert warm.lookup(KEY) is None
    assert warm.store(KEY, rendered)
    back = warm.lookup(KEY)
    assert back is not rendered and back.digest() == rendered.digest()
    assert back.layout == rendered.layout and back.functions == rendered.functions
    assert stat.S_IMODE(os.stat(warm.path(KEY)).st_mode) & 0o022 == 0


@pytest.mark.parametrize("which", ["record", "checksum"])
def test_a_record_others_could_write_is_not_read(cache, rendered, which):
    warm.store(KEY, rendered)
    target = warm.path(KEY) if which == "record" else record_path(warm.path(KEY))
    os.chmod(target, 0o666)
    assert warm.lookup(KEY) is None


def test_a_changed_or_unvouched_record_is_not_read(cache, rendered):
    warm.store(KEY, rendered)
    path = warm.path(KEY)
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 1                       # same size, one bit
    path.write_bytes(bytes(data))
    assert warm.lookup(KEY) is None
    warm.store(KEY, rendered)
    record_path(path).unlink()
    assert warm.lookup(KEY) is None


def test_a_record_filed_under_another_key_is_not_read(cache, rendered):
    warm.store(OTHER, rendered)
    for src, dst in ((warm.path(OTHER), warm.path(KEY)),
                     (record_path(warm.path(OTHER)), record_path(warm.path(KEY)))):
        dst.write_bytes(src.read_bytes())
        os.chmod(dst, 0o600)
    assert warm.lookup(OTHER) is not None and warm.lookup(KEY) is None


class _Planted:
    """Unpickling runs ``open(marker, 'w')``: what a planted record would do."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return open, (self.marker, "w")


def test_a_planted_record_never_runs(cache, tmp_path_factory):
    marker = tmp_path_factory.mktemp("planted") / "ran"
    path = warm.path(KEY)
    path.write_bytes(pickle.dumps(_Planted(marker)))
    write_record(path, record_path(path))
    os.chmod(path, 0o664)                           # a group member could have written it
    assert warm.lookup(KEY) is None
    assert not marker.exists()


def test_a_full_cache_keeps_nothing_and_says_nothing(cache, rendered, monkeypatch):
    def full(path, data):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(warm, "write_verified", full)
    assert warm.store(KEY, rendered) is False
    assert warm.lookup(KEY) is None


def test_clear_forgets_the_records_only(cache, rendered):
    warm.store(KEY, rendered)
    warm.store(OTHER, rendered)
    (cache / "_mbgen_model_0123.so").write_bytes(b"module")
    assert warm.clear() == 2
    assert sorted(p.name for p in cache.iterdir()) == ["_mbgen_model_0123.so"]


@pytest.mark.parametrize("env, expected", [("", True), ("1", True), ("0", False)])
def test_mbgen_warm_turns_it_off(monkeypatch, env, expected):
    monkeypatch.setenv("MBGEN_WARM", env)
    assert warm.enabled() is expected
    assert warm.enabled(False) is False and warm.enabled(True) is True


def test_a_bad_mbgen_warm_is_named(monkeypatch):
    monkeypatch.setenv("MBGEN_WARM", "yes")
    with pytest.raises(BuildError, match="MBGEN_WARM='yes': give 1 .*, 0 "):
        warm.enabled()


def test_the_key_covers_mbgens_own_code(monkeypatch):
    before = warm.key({"model": 1})
    assert warm.key({"model": 1}) == before and warm.key({"model": 2}) != before
    assert len(warm.code_identity()) == 64
    monkeypatch.setattr(warm, "code_identity", lambda: "an edited mbgen")
    assert warm.key({"model": 1}) != before
