"""One set of conventions in every command (issue 19, item 5): a user's mistake exits 2,
``--derivation`` and ``--integrator`` mean one thing (``--method`` still works, with a
note), every option states its default, one default tolerance, stage lines on a
terminal, ``mbgen golden``'s summary first, the golden tree refused as an output folder."""

import argparse
import inspect
import io
import shutil
import subprocess
from pathlib import Path

import pytest

from mbgen.cli import EXIT_CHECK, EXIT_OK, EXIT_USAGE, HelpFormatter, main, parser
from mbgen.codegen.targets import Targets
from mbgen.codegen.targets.fmu import fmu_files
from mbgen.integrators import DEFAULT_ATOL, DEFAULT_RTOL
from mbgen.model.scene import load_scene
from mbgen.pipeline import COMPARISONS, run
from mbgen.runtime.compiled import CompiledModel
from mbgen.runtime.simulate import simulate, simulate_in_c
from mbgen.runtime.stepper import Stepper
from mbgen.studies.ensemble import ensemble
from mbgen.verify import golden

ROOT = Path(__file__).resolve().parents[2]


def usage_error(argv, capsys, *patterns):
    """``mbgen argv`` exits 2 with one ``mbgen: error:`` line holding every pattern."""
    code = main(argv)
    err = capsys.readouterr().err
    assert code == EXIT_USAGE, err
    assert err.startswith("mbgen: error: ") and err.count("\n") == 1, err
    for pattern in patterns:
        assert pattern in err, err


# ------------------------------------------------------------------ exit code 2
def test_an_output_path_that_is_a_file_exits_2_in_every_command(tmp_path, capsys):
    """Was 3 in generate and golden (a SceneError), 2 in demo, linearize and fmu."""
    afile = tmp_path / "afile"
    afile.write_text("mine")
    for argv in (["generate", "disc_pendulum", "-o", str(afile)],
                 ["demo", "-o", str(afile)],
                 ["linearize", "disc_pendulum", "-o", str(afile)],
                 ["fmu", "disc_pendulum", "-o", str(afile)],
                 ["golden", "--root", str(afile), "--scenes", "disc_pendulum"],
                 ["simulate", "disc_pendulum", "--csv", str(tmp_path)],
                 ["sweep", "disc_pendulum", "--csv", str(tmp_path)],
                 ["animate", "disc_pendulum", "-o", str(afile / "a.html")]):
        usage_error(argv, capsys, "is a folder" if argv[0] in ("simulate", "sweep") else "afile")
    assert afile.read_text() == "mine"


def test_an_animation_file_of_another_kind_exits_2(tmp_path, capsys):
    """Was 3 (a SceneError from the picture code, after loading the scene)."""
    usage_error(["animate", "disc_pendulum", "-o", str(tmp_path / "a.mp4")], capsys,
                ".html or .gif")
    usage_error(["animate", "disc_pendulum", "--frames", "1"], capsys, "--frames 1")


@pytest.mark.parametrize("argv, message", [
    (["simulate", "disc_pendulum", "--t-end", "inf"], "--t-end inf: give a finite end time"),
    (["animate", "disc_pendulum", "--t-end", "-1"], "after the scene's start 0.0"),
    (["sweep", "disc_pendulum", "--t-end", "nan"], "--t-end nan"),
    (["sweep", "disc_pendulum", "--grid", "l=abc"], "grid 'l=abc': values must be numbers"),
    (["sweep", "disc_pendulum", "--samples", "q2=weird:1:2"], "unknown distribution 'weird'"),
    (["sweep", "disc_pendulum", "--grid", "ll=1,2"], "did you mean 'l'?"),
    (["sweep", "disc_pendulum", "--integrator", "foo"], "choose dopri5, rk4, rosenbrock"),
    (["generate", "disc_pendulum", "--outputs", "rhss"], "--outputs: unknown output 'rhss'"),
])
def test_a_mistake_in_an_argument_exits_2(argv, message, tmp_path, capsys):
    """Were 3 (--t-end of simulate, a sweep's grid and samples, generate --outputs), 5 (animate
    --t-end; a sweep with --t-end nan ran every member into BAD_ARGUMENT) or a traceback
    (sweep --method foo)."""
    where = {"generate": "-o", "animate": "-o"}.get(argv[0], "--csv")
    target = tmp_path / ("out.html" if argv[0] == "animate" else "out")
    usage_error(argv + [where, str(target), "--serial"] if argv[0] == "sweep"
                else argv + [where, str(target)], capsys, message)
    assert not target.exists()


def test_a_missing_scene_stays_a_scene_error(tmp_path, capsys):
    """The exit-code table of docs/reference/cli.md: an unknown scene or a missing scene
    file is 3, in every command."""
    for argv in (["generate", "no_such_scene"], ["simulate", str(tmp_path / "missing.py")],
                 ["fmu", "no_such_scene"]):
        assert main(argv) == 3
    assert "mbgen: error:" in capsys.readouterr().err


def test_generate_refuses_the_golden_tree(capsys):
    """``generate -o generated/...`` wrote into the checked-in tree the tests compare."""
    tree = golden.default_root()
    target = tree / "cli_test_never_written"
    before = {p: p.read_bytes() for p in (tree / "disc_pendulum").iterdir()}
    try:
        for folder in (tree, tree / "disc_pendulum", target):
            usage_error(["generate", "disc_pendulum", "-o", str(folder)], capsys,
                        "golden tree", "mbgen golden --update")
        assert not target.exists()
        assert {p: p.read_bytes() for p in (tree / "disc_pendulum").iterdir()} == before
    finally:
        shutil.rmtree(target, ignore_errors=True)


def test_mbgen_out_is_ignored_by_git():
    for path in ("mbgen-out/disc_pendulum/disc_pendulum.c", "mbgen-demo/example.c"):
        done = subprocess.run(["git", "check-ignore", "-q", path], cwd=ROOT)
        assert done.returncode == 0, f"{path} is not ignored by .gitignore"


# ------------------------------------------------------------------ --derivation, --integrator
@pytest.mark.parametrize("command, args, dest, value, new, meaning", [
    ("generate", ["disc_pendulum"], "derivation", "newton_euler", "--derivation", "derivation"),
    ("check", ["disc_pendulum"], "derivation", "newton_euler", "--derivation", "derivation"),
    ("linearize", ["disc_pendulum"], "derivation", "kane", "--derivation", "derivation"),
    ("simulate", ["disc_pendulum"], "integrator", "dopri5", "--integrator", "integration"),
    ("sweep", ["disc_pendulum"], "integrator", "rk4", "--integrator", "integration"),
])
def test_method_is_the_old_spelling_with_a_note(command, args, dest, value, new, meaning,
                                                capsys):
    """``--method`` was the derivation in generate/check/linearize and the integrator in
    simulate/sweep; both new names work everywhere they apply, the old one with a note."""
    p = parser([command])
    old = p.parse_args([command, *args, "--method", value])
    err = capsys.readouterr().err
    assert getattr(old, dest) == value
    assert err == (f"mbgen: note: --method is the old spelling of {new} here (the {meaning} "
                   f"method); use {new}\n")
    fresh = p.parse_args([command, *args, new, value])
    assert getattr(fresh, dest) == value and capsys.readouterr().err == ""


def test_every_command_that_takes_a_scene_takes_derivation():
    p = parser()
    for name, sub in p._subparsers._group_actions[0].choices.items():
        flags = {f for a in sub._actions for f in a.option_strings}
        if any(a.dest == "scene" for a in sub._actions):
            assert "--derivation" in flags, name


def test_old_and_new_spelling_give_the_same_run(tmp_path, capsys):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["simulate", "disc_pendulum", "--method", "rk4", "--csv", str(a),
                 "--points", "5"]) == EXIT_OK
    assert main(["simulate", "disc_pendulum", "--integrator", "rk4", "--csv", str(b),
                 "--points", "5"]) == EXIT_OK
    assert a.read_text() == b.read_text()


# ------------------------------------------------------------------ help and defaults
def test_every_option_has_help_that_states_its_default():
    """``simulate --rtol`` and ``--atol`` had no help text and no default shown."""
    p = parser()
    for name, sub in p._subparsers._group_actions[0].choices.items():
        formatter = HelpFormatter(f"mbgen {name}")
        assert sub.formatter_class is HelpFormatter, name
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            assert action.help, f"mbgen {name} {action.option_strings or action.dest}: no help"
            if action.option_strings and action.default not in (None, False):
                shown = formatter._get_help_string(action) % {"default": action.default}
                assert "default" in shown, f"mbgen {name} {action.option_strings}: no default"
    text = io.StringIO()
    parser(["simulate"])._subparsers._group_actions[0].choices["simulate"].print_help(text)
    assert "(default: 1e-06)" in text.getvalue() and "(default: 1e-09)" in text.getvalue()


def test_one_default_tolerance_everywhere():
    """integrate 1e-6/1e-9, simulate 1e-9/1e-12, example.c 1e-8/1e-10, the FMU 1e-6 with
    atol 1e-3 rtol: now all read DEFAULT_RTOL and DEFAULT_ATOL."""
    def defaults(fn):
        params = inspect.signature(fn).parameters
        return params["rtol"].default, params["atol"].default

    expected = (DEFAULT_RTOL, DEFAULT_ATOL)
    for fn in (CompiledModel.integrate, Stepper.__init__, simulate, simulate_in_c, ensemble):
        assert defaults(fn) == expected, fn.__qualname__
    for command in ("simulate", "sweep"):
        args = parser([command]).parse_args([command, "disc_pendulum"])
        assert (args.rtol, args.atol) == expected, command
    scene = load_scene("disc_pendulum")
    files = golden.scene_files("disc_pendulum")
    assert f"options = {{ {DEFAULT_RTOL!r}, {DEFAULT_ATOL!r}," in files["example.c"]
    result = run(scene, build=False, targets=Targets(step=True))
    fmu = fmu_files(scene, result.kernel, result.rendered)
    assert f'tolerance="{DEFAULT_RTOL!r}"' in fmu["modelDescription.xml"]
    glue = fmu[f"sources/{result.rendered.prefix}_fmu.c"]
    assert f"c->rtol = {DEFAULT_RTOL!r};" in glue
    assert f"{DEFAULT_ATOL!r} * (m->rtol / {DEFAULT_RTOL!r})" in glue


# ------------------------------------------------------------------ stage lines
class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_stage_lines_on_a_terminal_only(tmp_path, capsys, monkeypatch):
    """generate and simulate said nothing while they derived and compiled."""
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    assert ".." not in capsys.readouterr().err     # a pipe or a log: results only
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    COMPARISONS.clear()                                  # forget the comparison just made
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    compared = [f"  .. {stage} ({method})" for method in ("Newton-Euler", "Kane's method")
                for stage in ("derive", "bake the scene's slice", "CSE")]   # their rhs
    assert terminal.getvalue().splitlines() == compared + [
        "  .. CSE (Kane's method)", "  .. render"]   # the scene's outputs, of the one kept
    terminal.seek(0), terminal.truncate()
    assert main(["generate", "disc_pendulum", "-o", str(out), "--derivation", "kane"]) == EXIT_OK
    assert terminal.getvalue().splitlines() == [
        "  .. derive", "  .. bake the scene's slice", "  .. CSE", "  .. render"]
    terminal.seek(0), terminal.truncate()
    assert main(["simulate", "disc_pendulum", "--csv", str(tmp_path / "t.csv")]) == EXIT_OK
    lines = terminal.getvalue().splitlines()
    assert lines[-2:] == ["  .. compile (C compiler)", "  .. simulate"], lines
    terminal.seek(0), terminal.truncate()
    assert main(["simulate", "disc_pendulum", "--quiet", "--csv", str(tmp_path / "t.csv")]) \
        == EXIT_OK
    assert terminal.getvalue() == ""


# ------------------------------------------------------------------ golden
def test_golden_prints_the_summary_first_and_the_diff_with_v(tmp_path, capsys):
    root = tmp_path / "g"
    golden.update(root, ["disc_pendulum"])
    header = root / "disc_pendulum" / "disc_pendulum.h"
    header.write_text(header.read_text().replace("disc_pendulum", "disc_pendulum_edited", 1))
    (root / "disc_pendulum" / "old.c").write_text("int stale;\n")
    argv = ["golden", "--root", str(root), "--scenes", "disc_pendulum"]
    assert main(argv) == EXIT_CHECK
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == (f"{root}: 2 file(s) differ from the generator; run mbgen golden "
                        f"--update (-v shows the diffs)")
    assert lines[1:] == [f"  changed: {header}",
                         f"  unexpected: {root / 'disc_pendulum' / 'old.c'}"]
    assert main(argv + ["-v"]) == EXIT_CHECK
    out = capsys.readouterr().out
    assert out.splitlines()[0].endswith("run mbgen golden --update")
    assert "@@" in out and "disc_pendulum_edited" in out
    assert out.index("  changed:") < out.index("@@")


def test_sweep_runs_rk4_with_simulates_step(tmp_path, capsys):
    """``sweep --method rk4`` stopped with "pass h", which the command line could not pass."""
    csv = tmp_path / "s.csv"
    assert main(["sweep", "disc_pendulum", "--integrator", "rk4", "--serial", "--quiet", "-n",
                 "2", "--t-end", "1", "--csv", str(csv)]) == EXIT_OK
    assert "rk4" in capsys.readouterr().out and len(csv.read_text().splitlines()) == 3
