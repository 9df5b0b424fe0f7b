"""The compiler's answers remembered in the cache (mbgen.build.probes): asked once, asked
again for another compiler or a damaged answer, never an error."""

import os
import stat

import pytest

from mbgen.build import probes


@pytest.fixture
def compiler(tmp_path, monkeypatch):
    """A private cache and a compiler of our own on PATH (a script: only its file is read)."""
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path / "cache"))
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    exe = bin_dir / "mbgen-test-cc"
    exe.write_text("#!/bin/sh\nexit 0\n")
    exe.chmod(exe.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    return exe


def asker(answer):
    calls = []

    def ask():
        calls.append(1)
        return answer
    return ask, calls


def test_an_answer_is_asked_once(compiler):
    ask, calls = asker("abc")
    assert probes.remembered("native", compiler.name, ask) == "abc"
    assert probes.remembered("native", compiler.name, ask) == "abc"
    assert len(calls) == 1
    other, other_calls = asker("1")
    assert probes.remembered("accepts -fx", compiler.name, other) == "1"   # another question
    assert len(other_calls) == 1


def test_another_compiler_build_asks_again(compiler):
    ask, calls = asker("abc")
    probes.remembered("native", compiler.name, ask)
    info = compiler.stat()
    os.utime(compiler, ns=(info.st_atime_ns, info.st_mtime_ns + 10**9))   # upgraded
    probes.remembered("native", compiler.name, ask)
    assert len(calls) == 2


def test_a_damaged_answer_is_asked_again(compiler, tmp_path):
    ask, calls = asker("abc")
    probes.remembered("native", compiler.name, ask)
    (kept,) = (tmp_path / "cache").glob("probe-*.txt")
    kept.write_text("xyz")
    assert probes.remembered("native", compiler.name, ask) == "abc"
    assert len(calls) == 2


def test_a_missing_compiler_is_asked_every_time(compiler):
    ask, calls = asker("")
    for _ in range(2):
        assert probes.remembered("native", "mbgen-no-such-cc", ask) == ""
    assert len(calls) == 2


def test_the_key_names_the_cpu(compiler, monkeypatch):
    here = probes.probe_key("native", compiler.name)
    monkeypatch.setattr(probes, "cpu_identity", lambda: "another cpu")
    assert probes.probe_key("native", compiler.name) != here
