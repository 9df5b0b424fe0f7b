"""Every code block of README.md and of every page of the site (``docs/**/*.md``) runs, and
every excerpt of tool output is what the tool prints now (or opts out, explicitly and counted).

Code blocks, per Markdown file (``README.md`` and every ``docs/**/*.md`` but the built site
under ``docs/_build/``):

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

Excerpts of tool output: a block that shows what a command prints is a ```` ```text ````
block with the command in an HTML comment on the line right above its opening fence
(GitHub shows neither the comment nor the word ``text``)::

    <!-- output: mbgen generate spring_pendulum --explain -->
    ```text
    mbgen-out/spring_pendulum/example.c  (written)
    ...
    ```

``<!-- output (slow): COMMAND -->`` marks a command that takes more than a few seconds; its
case is ``slow``.  The test runs the command in-process (``mbgen.cli.main``, so compiled
modules are reused) in a fresh temporary folder that holds the page's ``# file:`` blocks,
requires exit 0, and compares the whole of its stdout with the block line by line (trailing
blanks aside) after blanking :data:`MASKS` on both sides: durations and nothing else that a
rerun may change.  Every other character -- operation counts, errors, final states,
eigenvalues, file names -- must match.  A block that looks like tool output
(:data:`LOOKS_LIKE_OUTPUT`: a ``$ mbgen`` transcript, a report header) but has no marker fails
:func:`test_no_unmarked_tool_output`, so an excerpt cannot be added unchecked.

When a change alters what a command prints, refresh every excerpt in place in one command
(the slow ones included, about a minute), then review the diff as for ``mbgen golden
--update``::

    .venv/bin/python tests/test_readme_blocks.py --update

It rewrites only the blocks whose masked text differs and names each; without ``--update`` it
lists the stale ones and exits 1; ``--fast`` leaves the slow ones out.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
import tempfile
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path

import pytest
import tomllib

from mbgen.cli import main as mbgen_main

ROOT = Path(__file__).resolve().parent.parent
#: The pages whose blocks run: README.md and the site's Markdown (its build output aside).
PAGES = [ROOT / "README.md",
         *sorted(p for p in (ROOT / "docs").rglob("*.md")
                 if not p.relative_to(ROOT / "docs").parts[0].startswith("_"))]
#: Pages whose code blocks take too long for the default run (page: the reason); their
#: case of test_code_blocks_run is marked ``slow``.  Keep a page's blocks cheap instead
#: where a smaller model shows the same thing.
SLOW_PAGES: dict[str, str] = {}
PYTHON = {"python", "py", "python3"}
SHELL = {"sh", "bash", "shell", "console"}
NOT_OUTPUT = PYTHON | {"c", "cpp", "c++"}  # code: never taken for an unmarked excerpt
OPT_OUT = re.compile(r"^\s*#\s*docs:\s*not run:\s*(\S.*)$", re.MULTILINE)
FENCE = re.compile(r"^```([\w+-]*)[^\n]*\n(.*?)^```\s*$", re.MULTILINE | re.DOTALL)
FILE_NAME = re.compile(r"#\s*file:\s*(\S+)")  # first line of a scene file's block
MARKER = re.compile(r"^<!--\s*output\s*(\(slow\))?\s*:\s*(.*?)\s*-->\s*$")
ANY_MARKER = re.compile(r"^\s*<!--\s*output\b")  # a marker-like line (not a mention in prose)

#: What may differ between an excerpt and a fresh run of its command, each with the reason
#: (regex, reason).  Where a pattern has a group, only the group is blanked.
MASKS = (
    (re.compile(r"(?<![\w.])\d+\.\d+ ?(?:s|ms|us|µs|ns)\b"),
     "a wall-clock duration, which mbgen prints with a decimal point (`0.000 s`, `(26.0 s)`): "
     "it differs from run to run; whole seconds (`over 50 s`, `budget 300 s`) are spans and "
     "budgets, and are compared"),
    (re.compile(r"^[^\n]*?\((?:s|ms|us|µs)\)[ \t]+(\d+\.\d+)", re.MULTILINE),
     "the value of a table row whose label names a time unit (`derive (s)  2.08`, "
     "`RHS call (us)  0.98`): a wall-clock duration"),
    (re.compile(r"^[ \t]*\d+e-\d+[ \t]+(?:on|off)(?:[ \t]+\S+){4}[ \t]+(\d+\.\d+)$",
                re.MULTILINE),
     "the last column of `bench constraints`' four-bar table, `time (ms)`: a wall-clock "
     "duration"),
    (re.compile(re.escape(tempfile.gettempdir()) + r"/\S+"),
     "a path in the temporary folder a command runs in (a new one every run)"),
)

#: Signs that a block shows tool output (regex, what prints it): such a block needs a marker.
LOOKS_LIKE_OUTPUT = (
    (r"^\$ mbgen\b", "a shell transcript"),
    (r"^mbgen: (error|note|check \w+):", "an mbgen error or note line"),
    (r"  \((written|unchanged|kept\b|removed\b)[^)]*\)$", "generate/demo: the files written"),
    (r"^operations: \d+ before CSE", "generate"),
    (r"^audit of scene |\[ops \d+ -> \d+\]", "generate --explain"),
    (r"^check \S+: \d+ seeded random states|^tolerance: .*; (PASSED|FAILED|INCONCLUSIVE)",
     "check"),
    (r"^final state: |^trajectory: \S+ \(\d+ rows\)", "simulate or demo"),
    (r"^mbgen demo: ", "demo"),
    (r"^eigenvalues of A:|: operating point ", "linearize"),
    (r"^case\s+figure\s+bound\s+verdict", "stress"),
    (r"^Work-precision summary: |^configuration\s+rtol ", "bench SCENE"),
    (r"^stage\s+seconds\s+peak GB", "bench --stages"),
    (r"^Whipple bicycle \(|^Four-bar, C dopri5|BLAS threads pinned", "bench constraints, "
                                                                      "scaling or arm"),
    (r"\(FMI 2\.0, model exchange and co-simulation\)$", "fmu"),
    (r": (up to date|\d+ difference\(s\))", "golden"),
)


# ------------------------------------------------------------------------ reading pages
def _name(page: Path) -> str:
    """``page`` as the messages name it: relative to the repository when inside it."""
    return page.relative_to(ROOT).as_posix() if page.is_relative_to(ROOT) else page.name


@dataclass(frozen=True)
class Fence:
    """A fenced block: language, line of its first body line, body, the body's character span
    in the page, and the line right above its opening fence."""

    lang: str
    line: int
    body: str
    span: tuple[int, int]
    above: str


def fences(page: Path) -> list[Fence]:
    """Every fenced block of ``page``, in order."""
    text = page.read_text(encoding="utf-8")
    found = []
    for m in FENCE.finditer(text):
        start = text.rfind("\n", 0, max(m.start() - 1, 0)) + 1
        above = text[start:m.start()].rstrip("\n")
        found.append(Fence(m.group(1).lower(), text.count("\n", 0, m.start()) + 2, m.group(2),
                           (m.start(2), m.end(2)), above))
    return found


def blocks(page: Path) -> list[tuple[str, int, str]]:
    """``(language, first line number, code)`` of every fenced block of ``page``."""
    return [(f.lang, f.line, f.body) for f in fences(page)]


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


def page_files(page: Path) -> dict[str, str]:
    """The ``# file: NAME`` blocks of ``page`` by name (scene files the commands use)."""
    files = {}
    for lang, _, code in blocks(page):
        named = FILE_NAME.match(code) if lang in PYTHON else None
        if named:
            files[named.group(1)] = code
    return files


# --------------------------------------------------------------------------- excerpts
@dataclass(frozen=True)
class Excerpt:
    """A block of tool output and the command that prints it."""

    page: Path
    line: int
    command: str
    slow: bool
    body: str
    span: tuple[int, int]

    @property
    def where(self) -> str:
        return f"{_name(self.page)}:{self.line}"


def excerpts(page: Path) -> list[Excerpt]:
    """The marked excerpts of ``page`` (markers that do not parse: :func:`marker_problems`)."""
    found = []
    for f in fences(page):
        m = MARKER.match(f.above)
        if m:
            found.append(Excerpt(page, f.line, m.group(2), bool(m.group(1)), f.body, f.span))
    return found


def marker_problems(page: Path) -> list[str]:
    """Markers that mark nothing, do not parse, name no ``mbgen`` command or mark code."""
    name = _name(page)
    lines = page.read_text(encoding="utf-8").splitlines()
    above = {f.line - 3: f for f in fences(page)}  # 0-based index of the line above a fence
    problems = []
    for k, line in enumerate(lines):
        if not ANY_MARKER.search(line):
            continue
        m, fence = MARKER.match(line), above.get(k)
        if not m:
            problems.append(f"{name}:{k + 1}: write a marker as <!-- output: mbgen ... --> or "
                            f"<!-- output (slow): mbgen ... --> on a line of its own")
        elif fence is None:
            problems.append(f"{name}:{k + 1}: the marker must sit on the line right above the "
                            f"block's opening fence")
        elif not m.group(2).startswith("mbgen "):
            problems.append(f"{name}:{k + 1}: the marked command must be an `mbgen ...` command")
        elif fence.lang in PYTHON | SHELL:
            problems.append(f"{name}:{k + 1}: mark a ```text block (a {fence.lang} block runs "
                            f"as code)")
    return problems


def normalised(text: str) -> str:
    """``text`` without trailing blanks on its lines and without trailing empty lines."""
    return "\n".join(line.rstrip() for line in text.rstrip().splitlines())


def _blank(m: re.Match) -> str:
    """The match with its group (or, without one, all of it) replaced by ``<~>``."""
    if not m.re.groups:
        return "<~>"
    a, b = m.start(1) - m.start(), m.end(1) - m.start()
    return m.group(0)[:a] + "<~>" + m.group(0)[b:]


def masked(text: str) -> str:
    """``text`` normalised, with every :data:`MASKS` match blanked to ``<~>`` (and the blanks
    before it to one: a duration's width moves the alignment of its column)."""
    text = normalised(text)
    for pattern, _ in MASKS:
        text = pattern.sub(_blank, text)
    return re.sub(r"(?<=\S) +<~>", " <~>", text)


def run_mbgen(line: str, where: str) -> str:
    """Run the command line ``mbgen ...`` in-process in the current folder; its stdout.  An
    exit code other than 0 is an AssertionError with both streams."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = mbgen_main(shlex.split(line)[1:])
        except SystemExit as exc:  # argparse: an unknown option or command
            rc = exc.code
    assert rc == 0, f"{where}: `{line}` exited {rc}\n{out.getvalue()}\n{err.getvalue()}"
    return out.getvalue()


def command_output(excerpt: Excerpt, folder: Path) -> str:
    """Stdout of the excerpt's command run in ``folder`` (with the page's scene files),
    normalised."""
    for name, code in page_files(excerpt.page).items():
        (folder / name).write_text(code, encoding="utf-8")
    here = os.getcwd()
    try:
        os.chdir(folder)
        return normalised(run_mbgen(excerpt.command, excerpt.where))
    finally:
        os.chdir(here)


def unmarked_output(page: Path) -> list[str]:
    """``file:line: ...`` for each unmarked block that looks like tool output."""
    name = _name(page)
    found = []
    for f in fences(page):
        if f.lang in NOT_OUTPUT or MARKER.match(f.above):
            continue
        for pattern, what in LOOKS_LIKE_OUTPUT:
            hit = re.search(pattern, f.body, re.MULTILINE)
            if hit:
                found.append(f"{name}:{f.line}: looks like the output of {what} "
                             f"({hit.group(0).strip()!r}) but has no <!-- output: mbgen ... --> "
                             f"marker above its fence")
                break
    return found


def refresh(pages, *, slow: bool = True, write: bool = True, say=print) -> list[Excerpt]:
    """Run every excerpt's command; rewrite (``write``) the stale blocks in place; return them."""
    stale = []
    for page in pages:
        text, edits = page.read_text(encoding="utf-8"), []
        for ex in excerpts(page):
            if ex.slow and not slow:
                say(f"{ex.where}: left out (slow): {ex.command}")
                continue
            with tempfile.TemporaryDirectory(prefix="mbgen-docs-") as folder:
                out = command_output(ex, Path(folder))
            if masked(ex.body) == masked(out):
                say(f"{ex.where}: up to date: {ex.command}")
                continue
            stale.append(ex)
            edits.append((ex.span, out + "\n"))
            say(f"{ex.where}: {'rewritten' if write else 'stale'}: {ex.command}")
        for (a, b), new in reversed(edits):
            text = text[:a] + new + text[b:]
        if edits and write:
            page.write_text(text, encoding="utf-8")
    return stale


# ------------------------------------------------------------------------------ tests
def _declared_extras() -> set[str]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    return set(data["project"].get("optional-dependencies", {}))


def _run_shell(code: str, where: str) -> None:
    check = subprocess.run(["bash", "-n"], input=code, text=True, capture_output=True)
    assert check.returncode == 0, f"{where}: not valid shell: {check.stderr}"
    for extra in re.findall(r"\.\[([\w,-]+)\]", code):
        missing = set(extra.split(",")) - _declared_extras()
        assert not missing, f"{where}: extra(s) {sorted(missing)} are not in pyproject.toml"
    for raw in code.splitlines():
        line = raw.strip()
        if line.startswith("mbgen "):
            run_mbgen(line, where)


@pytest.mark.parametrize("page", [
    pytest.param(p, id=_name(p), marks=[pytest.mark.slow] if _name(p) in SLOW_PAGES else [])
    for p in PAGES])
def test_code_blocks_run(page, tmp_path, monkeypatch):
    run, _ = runnable(page)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"docs_{page.stem}"}
    for lang, line, code in run:
        where = f"{page.relative_to(ROOT)}:{line}"
        if lang in SHELL:
            _run_shell(code, where)
            continue
        named = FILE_NAME.match(code)
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


EXCERPTS = [ex for page in PAGES for ex in excerpts(page)]


@pytest.mark.parametrize("excerpt", [
    pytest.param(ex, marks=[pytest.mark.slow] if ex.slow else [], id=ex.where)
    for ex in EXCERPTS])
def test_output_excerpt_is_current(excerpt, tmp_path):
    """The block shows what its command prints now (masks aside); refresh with --update."""
    out = command_output(excerpt, tmp_path)
    if masked(excerpt.body) != masked(out):
        pytest.fail(f"{excerpt.where}: the excerpt of `{excerpt.command}` is stale; run "
                    f"`.venv/bin/python tests/test_readme_blocks.py --update`.\n"
                    f"--- the page\n{normalised(excerpt.body)}\n--- the command now\n{out}",
                    pytrace=False)


def test_output_markers_are_well_formed():
    problems = [p for page in PAGES for p in marker_problems(page)]
    assert not problems, "\n".join(problems)
    assert any(not ex.slow for ex in EXCERPTS), "no excerpt is checked in the default run"


def test_no_unmarked_tool_output():
    """Every block that looks like tool output is marked, so the test above compares it."""
    found = [hit for page in PAGES for hit in unmarked_output(page)]
    assert not found, "\n".join(found)


def test_masks_blank_durations_only():
    """Wall-clock durations are masked; results (operation counts, errors, states) are not."""
    for reason in (r for _, r in MASKS):
        assert len(reason) >= 20, "every mask says why what it hides may differ"
    header = ("   rtol  projection  max |f_h| per step  |f_h| at end  energy drift  RHS calls"
              "  time (ms)\n")
    row = "  1e-10          on            8.68e-12      2.14e-12      4.69e-08      44356"
    same = [("mbgen: ok (26.0 s)", "mbgen: ok (31.7 s)"),
            ("derive (s)    2.08  -", "derive (s)    2.61  -"),
            ("RHS call (us)   0.98 (in C)", "RHS call (us)   1.04 (in C)"),
            ("t = 0 .. 5, 3386 RHS calls, 0.000 s", "t = 0 .. 5, 3386 RHS calls, 0.012 s"),
            (header + row + "      9.284", header + row + "     10.112")]  # the width moves
    differ = [("[ops 490 -> 207]", "[ops 632 -> 207]"),
              ("ops before -> after CSE  56675 -> 3133", "ops before -> after CSE  56675 -> 3149"),
              (header + row + "      9.284", header + row[:-1] + "7      9.284"),
              ("over 50 s (10x the span)", "over 60 s (10x the span)"),
              ("rhs  c  1.421e-14  2.158e-16  20/20", "rhs  c  1.421e-14  2.1e-16  20/20"),
              ("final state: theta = 0.8146287849", "final state: theta = 0.81462878")]
    for before, after in same:
        assert masked(before) == masked(after), (before, after)
    for before, after in differ:
        assert masked(before) != masked(after), (before, after)


def test_the_checker_sees_stale_and_unmarked_output(tmp_path):
    """An outdated excerpt fails and --update rewrites it; an unmarked one and a bad marker
    are reported."""
    old_explain = ("1 outputs  mass_matrix (3 ops), ...  [ops 490 -> 207]\n"
                   "2 fixed parameters  c = 0  [ops 207 -> 185]\n")
    good = ("# x\n\nBefore.\n\n<!-- output: mbgen scenes -->\n```text\n"
            "paraboloid   an old description\n```\n\nMiddle.\n\n```\n" + old_explain + "```\n")
    bad = ("\n<!-- output: mbgen scenes\n```text\n```\n"                # line 17: no -->
           "\n<!-- output: mbgen scenes -->\n\n```text\n```\n"          # 21: not above a fence
           "\n<!-- output: mbgen scenes -->\n```python\n```\n"           # 26: marks code
           "\n<!-- output: python -m mbgen scenes -->\n```text\n```\n")  # 30: not mbgen
    page = tmp_path / "page.md"
    page.write_text(good + bad, encoding="utf-8")
    problems = marker_problems(page)
    assert [int(p.split(":")[1]) for p in problems] == [17, 21, 26, 30], problems
    page.write_text(good, encoding="utf-8")
    assert len(unmarked_output(page)) == 1 and "--explain" in unmarked_output(page)[0]
    (ex,) = excerpts(page)
    assert ex.command == "mbgen scenes" and not ex.slow and ex.line == 7
    assert refresh([page], write=False, say=lambda _: None) == [ex]
    refresh([page], say=lambda _: None)
    (fresh,) = excerpts(page)
    assert "spring_pendulum" in fresh.body and "an old description" not in fresh.body
    assert refresh([page], say=lambda _: None) == []      # now current
    text = page.read_text(encoding="utf-8")
    assert text.startswith("# x\n\nBefore.\n\n") and text.endswith("\n\nMiddle.\n\n```\n" +
                                                                    old_explain + "```\n")


def test_opt_outs_are_explicit_and_reported():
    """Opt-outs need a reason; their number is reported on every run.  So do the pages
    whose blocks run in the slow tier only."""
    for name, reason in SLOW_PAGES.items():
        assert (ROOT / name).is_file() and len(reason) >= 10, f"SLOW_PAGES: {name}: {reason!r}"
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
                      + "; ".join(report), UserWarning,
                      stacklevel=1)  # the test's own line: its caller is pytest


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


def test_readme_links_the_site():
    """The front page links the modelling guide and the site's entry pages (every link of
    every page resolving is tests/test_docs.py's)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    for page in ("docs/modelling.md", "docs/getting-started.md", "docs/api/index.md",
                 "docs/developer.md", "docs/performance.md"):
        assert f"]({page}" in text, f"README does not link {page}"
    for target in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (ROOT / target).is_file(), f"README links a missing page {target}"


def main(argv=None) -> int:
    """``python tests/test_readme_blocks.py [--update] [--fast]``: check or refresh excerpts."""
    parser = argparse.ArgumentParser(description="Check (or --update) every excerpt of tool "
                                                 "output in README.md and docs/**/*.md.")
    parser.add_argument("--update", action="store_true",
                        help="rewrite the stale excerpts in place from their commands' output")
    parser.add_argument("--fast", action="store_true",
                        help="leave out the excerpts marked slow")
    args = parser.parse_args(argv)
    problems = [p for page in PAGES for p in marker_problems(page) + unmarked_output(page)]
    for problem in problems:
        print(problem, file=sys.stderr)
    stale = refresh(PAGES, slow=not args.fast, write=args.update)
    if stale and not args.update:
        print(f"{len(stale)} stale excerpt(s); rerun with --update", file=sys.stderr)
    return 1 if problems or (stale and not args.update) else 0


if __name__ == "__main__":
    sys.exit(main())
