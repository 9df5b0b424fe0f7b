"""Every code block of README.md and docs/*.md runs (or opts out, explicitly and counted).

Rules, per Markdown file (``README.md`` and every ``docs/*.md``):

* ```` ```python ```` blocks run in order, in one namespace per file (a page reads
  top to bottom like a notebook), in a temporary working folder.  A block whose
  first line is ``# file: NAME`` is also written to ``NAME`` there (a scene file
  that the shell blocks below it use).
* ```` ```sh ```` / ```` ```bash ```` / ```` ```console ```` blocks are checked with
  ``bash -n``; every line that starts with ``mbgen `` runs in-process
  (``mbgen.cli.main``) in the same folder and must exit 0; the other commands
  (installs, the C compiler) are parsed only.  Extras named as ``.[extra]`` must
  be declared in pyproject.toml.
* A block opts out only with a line ``# docs: not run: <reason>`` in it; opt-outs
  are counted and reported as a warning on every run, and need a reason.

Other languages (``c``, plain fences) are not run.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import subprocess
import tomllib
import traceback
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PYTHON = {"python", "py", "python3"}
SHELL = {"sh", "bash", "shell", "console"}
OPT_OUT = re.compile(r"^\s*#\s*docs:\s*not run:\s*(\S.*)$", re.MULTILINE)
FENCE = re.compile(r"^```([\w+-]*)[^\n]*\n(.*?)^```\s*$", re.MULTILINE | re.DOTALL)


def blocks(page: Path) -> list[tuple[str, int, str]]:
    """``(language, first line number, code)`` of every fenced block of ``page``."""
    text = page.read_text(encoding="utf-8")
    return [(m.group(1).lower(), text.count("\n", 0, m.start()) + 2, m.group(2))
            for m in FENCE.finditer(text)]


def runnable(page: Path):
    """Blocks of ``page`` that run, and the opt-outs ``(line, reason)``."""
    run, skipped = [], []
    for lang, line, code in blocks(page):
        if lang not in PYTHON | SHELL:
            continue
        opt = OPT_OUT.search(code)
        if opt:
            skipped.append((line, opt.group(1).strip()))
        else:
            run.append((lang, line, code))
    return run, skipped


def _declared_extras() -> set[str]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    return set(data["project"].get("optional-dependencies", {}))


def _run_shell(code: str, where: str) -> None:
    from mbgen.cli import main

    check = subprocess.run(["bash", "-n"], input=code, text=True, capture_output=True)
    assert check.returncode == 0, f"{where}: not valid shell: {check.stderr}"
    for extra in re.findall(r"\.\[([\w,-]+)\]", code):
        missing = set(extra.split(",")) - _declared_extras()
        assert not missing, f"{where}: extra(s) {sorted(missing)} are not in pyproject.toml"
    for raw in code.splitlines():
        line = raw.strip()
        if not line.startswith("mbgen "):
            continue
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main(shlex.split(line)[1:])
            except SystemExit as exc:  # argparse: an unknown option or command
                rc = exc.code
        assert rc == 0, f"{where}: `{line}` exited {rc}\n{out.getvalue()}\n{err.getvalue()}"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_code_blocks_run(page, tmp_path, monkeypatch):
    run, _ = runnable(page)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"docs_{page.stem}"}
    for lang, line, code in run:
        where = f"{page.relative_to(ROOT)}:{line}"
        if lang in SHELL:
            _run_shell(code, where)
            continue
        first = code.splitlines()[0] if code.strip() else ""
        named = re.match(r"#\s*file:\s*(\S+)", first)
        if named:
            (tmp_path / named.group(1)).write_text(code, encoding="utf-8")
        try:
            exec(compile(code, where, "exec"), namespace)
        except Exception as exc:
            tb = traceback.extract_tb(exc.__traceback__)
            inside = [f.lineno for f in tb if f.filename == where]
            at = f"{page.relative_to(ROOT)}:{line + inside[-1] - 1}" if inside else where
            raise AssertionError(f"{at}: the code block failed: {type(exc).__name__}: "
                                 f"{exc}") from exc


def test_opt_outs_are_explicit_and_reported():
    """Opt-outs need a reason; their number is reported on every run."""
    report = []
    for page in PAGES:
        _, skipped = runnable(page)
        for line, reason in skipped:
            assert len(reason) >= 10, f"{page.name}:{line}: say why the block is not run"
            report.append(f"{page.relative_to(ROOT)}:{line} ({reason})")
    total = sum(1 for p in PAGES for lang, _, _ in blocks(p) if lang in PYTHON | SHELL)
    assert total > len(report), "no code block runs at all"
    if report:
        warnings.warn(f"{len(report)} of {total} python/shell blocks opted out of running: "
                      + "; ".join(report), UserWarning)


def test_the_runner_sees_a_failing_block(tmp_path, monkeypatch):
    """A wrong example fails the test (the runner is not vacuous)."""
    page = tmp_path / "bad.md"
    page.write_text("# x\n\n```python\nassert 1 + 1 == 3\n```\n\n```sh\nmbgen nosuch\n```\n"
                    "\n```python\n# docs: not run: a fragment for the test\nundefined_name\n```\n",
                    encoding="utf-8")
    run, skipped = runnable(page)
    assert [lang for lang, _, _ in run] == ["python", "sh"] and len(skipped) == 1
    with pytest.raises(AssertionError):
        exec(compile(run[0][2], "bad.md", "exec"), {})
    monkeypatch.chdir(tmp_path)
    with pytest.raises(AssertionError, match="exited"):
        _run_shell(run[1][2], "bad.md")


def test_readme_links_the_modelling_page():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "docs/modelling.md" in text
    for target in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (ROOT / target).is_file(), f"README links a missing page {target}"
