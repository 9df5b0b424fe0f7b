"""The compiled templates kept in the cache (mbgen.codegen.templating)."""

from __future__ import annotations

import os
import subprocess
import sys

import jinja2

from mbgen.codegen import templating

RENDER = """
from mbgen.codegen.templating import environment
env = environment()
print(type(env.bytecode_cache).__name__)
print(env.get_template("model/model.h.j2").render is not None)
"""


def _child(cache):
    env = {**os.environ, "MBGEN_CACHE_DIR": str(cache)}
    return subprocess.run([sys.executable, "-c", RENDER], env=env, capture_output=True,
                          text=True, timeout=300)


def test_a_template_is_compiled_once_per_cache_and_a_damaged_one_again(tmp_path):
    first = _child(tmp_path)
    assert first.returncode == 0, first.stderr
    assert first.stdout.split()[0] == "_TemplateCache"
    folder = tmp_path / f"templates-{jinja2.__version__}"
    files = sorted(folder.iterdir())
    assert files and oct(folder.stat().st_mode & 0o777) == "0o700"
    stamps = {f: f.stat().st_mtime_ns for f in files}
    again = _child(tmp_path)                      # loaded, not written again
    assert again.returncode == 0, again.stderr
    assert {f: f.stat().st_mtime_ns for f in files} == stamps
    for f in files:                               # damaged: compiled again, no error
        f.write_bytes(b"j2 not a template")
    damaged = _child(tmp_path)
    assert damaged.returncode == 0, damaged.stderr
    assert all(f.read_bytes() != b"j2 not a template" for f in files)


def test_without_a_usable_cache_templates_still_render(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(blocked))
    assert templating._template_cache() is None
    others = tmp_path / "shared"
    others.mkdir()
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(others))
    (others / f"templates-{jinja2.__version__}").mkdir(mode=0o777)
    os.chmod(others / f"templates-{jinja2.__version__}", 0o777)
    assert templating._template_cache() is None   # others could write it: not trusted
