"""Building from many threads and many processes at once (mbgen.build.extension).

cffi builds through distutils, which changes the process's working directory, and the
compiler writes to file descriptors 1 and 2: done in the asking process, two threads
building at once lost a source file (``cc1: fatal error: ... No such file``) and left
the process's stdout pointing at a deleted file.  The build now runs in a child process.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
import threading

import pytest

import mbgen
from mbgen.build import extension
from mbgen.pipeline import run
from models import pendulum


def _compile_in_threads(names):
    """Compile one pendulum per name, each in its own thread: ``(models, errors, cwds)``.

    ``cwds`` is every working directory a watcher thread saw while the builds ran.
    """
    models, errors, cwds = {}, [], set()
    done = threading.Event()

    def watch():
        while not done.is_set():
            cwds.add(os.getcwd())
            done.wait(0.001)

    def compile_one(name):
        try:
            models[name] = mbgen.compile(pendulum(name))
        except Exception as exc:  # collected: an error in a thread must fail the test
            errors.append(f"{name}: {exc!r}")

    watcher = threading.Thread(target=watch)
    watcher.start()
    threads = [threading.Thread(target=compile_one, args=(n,)) for n in names]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    done.set()
    watcher.join()
    return models, errors, cwds


def test_four_threads_compile_into_an_empty_cache(tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path / "cache"))
    cwd, stdout = os.getcwd(), os.fstat(1)
    models, errors, cwds = _compile_in_threads([f"thread{i}" for i in range(4)])
    assert not errors, errors
    assert cwds == {cwd}, "a build changed the process's working directory"
    for model in models.values():  # q'' = -(g / l) sin q
        assert (model.rhs(0.0, [0.5, 0.0], [1.0, 9.81, 1.0])[1]
                == pytest.approx(-9.81 * math.sin(0.5)))
    after = os.fstat(1)
    assert (after.st_dev, after.st_ino) == (stdout.st_dev, stdout.st_ino), "fd 1 was swapped"
    os.write(1, b"fd 1 still works\n")
    print("sys.stdout still works")
    out = capfd.readouterr().out
    assert "fd 1 still works" in out and "sys.stdout still works" in out


def test_threads_loading_one_model_build_it_once(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    rendered = run(pendulum("once"), build=False).rendered
    calls = []
    real = extension._compile

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(extension, "_compile", counted)
    loaded = []
    threads = [threading.Thread(target=lambda: loaded.append(extension.load(rendered)))
               for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(loaded) == 3 and len({id(m) for m in loaded}) == 1
    assert len(calls) == 1


CHILD = textwrap.dedent("""
    import sys
    sys.path.insert(0, sys.argv[1])
    import mbgen
    from models import pendulum
    model = mbgen.compile(pendulum("twoprocs"))
    print(model.rhs(0.0, [0.5, 0.0], [1.0, 9.81, 1.0]).tolist())
""")


def test_two_processes_build_one_module_at_once(tmp_path):
    support = os.path.join(os.path.dirname(os.path.dirname(__file__)), "support")
    env = {**os.environ, "MBGEN_CACHE_DIR": str(tmp_path)}
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, support], env=env, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [err[-2000:] for _, err in outs]
    assert outs[0][0] == outs[1][0] and outs[0][0].startswith("[")
    folders = [p for p in tmp_path.iterdir()
               if p.is_dir() and not p.name.startswith("templates-")]  # compiled templates
    assert not folders, "a build folder was left behind"
