"""``mbgen bench`` and ``mbgen stress`` on the command line: the help separates bench's
modes and every option shows its default; ``--methods`` is the old spelling of
``--integrators``; on a core install (no matplotlib) bench writes its CSV and says how to
get the plot, before the sweep starts and after it; stress refuses a report path before
it runs and writes the report before printing it."""

import argparse
import os
import subprocess
import sys

import pytest

from mbgen.cli import EXIT_OK, EXIT_USAGE, main, parser

NOTE = "mbgen: note: matplotlib is not installed: the CSV is written, the plot is not " \
       "(pip install 'mbgen[plot]' draws it)"


def command_parser(name: str) -> argparse.ArgumentParser:
    sub = next(a for a in parser([name])._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


def test_bench_help_separates_its_modes(capsys):
    """Each mode is a group of options headed by its command line, saying what it measures
    and writes; the options every mode shares come first.  (Every option states its
    default: tests/cli/test_conventions.py.)"""
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    text = capsys.readouterr().out
    groups = {g.title: [a.dest for a in g._group_actions]
              for g in command_parser("bench")._action_groups}
    assert groups["every mode but SCENE --stages"] == ["output", "repeats"]
    assert groups["mbgen bench SCENE"] == ["option", "parameter", "state", "rtols",
                                           "integrators", "integrators", "backends",
                                           "time_budget"]
    assert groups["mbgen bench SCENE --stages"] == ["stages", "outputs"]
    assert groups["mbgen bench scaling"] == ["ns", "sympy_max_n"]
    assert groups["mbgen bench arm"] == ["no_pinocchio", "no_cxx", "derivation", "no_casadi"]
    assert groups["mbgen bench constraints"] == ["budget", "sympy_budget", "memory_gb"]
    for title in groups:
        if title.startswith("mbgen bench"):
            assert f"\n{title}:\n" in text, title
    assert "work_precision.csv and .png" in text and "pip install 'mbgen[plot]'" in text


def test_methods_is_the_old_spelling_of_integrators(tmp_path, capsys):
    """Was a ValueError traceback for an unknown integrator; now one line, exit 2, and the
    old spelling says the new one."""
    out = ["-o", str(tmp_path / "out")]
    assert main(["bench", "bead_wire", "--methods", "RK99", *out]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert ("mbgen: note: --methods is the old spelling of --integrators here (the "
            "integration methods); use --integrators") in err
    assert "mbgen: error: unknown integrator(s) ['RK99']" in err and "Traceback" not in err
    assert main(["bench", "bead_wire", "--integrators", "RK99", *out]) == EXIT_USAGE
    assert "note" not in capsys.readouterr().err
    for bad in (["--rtols", "1e-3,tight"], ["--ns", "2,x"]):
        with pytest.raises(SystemExit) as stop:
            main(["bench", "scaling", *bad])
        assert stop.value.code == EXIT_USAGE
        assert "is not a comma-separated list" in capsys.readouterr().err


def test_bench_without_matplotlib_writes_the_csv_and_says_how_to_get_the_plot(tmp_path):
    """Issue 19.4: on a core install, ``ModuleNotFoundError: matplotlib`` came as a traceback
    after the whole sweep.  matplotlib is hidden in a child process (``sys.modules``)."""
    argv = ["bench", "bead_wire", "--rtols", "1e-3,1e-6", "--integrators", "RK45,dopri5",
            "--backends", "c", "--repeats", "1", "-o", "out"]
    code = ("import sys\nsys.modules['matplotlib'] = None\nfrom mbgen.cli import main\n"
            f"sys.exit(main({argv!r}))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)             # a hang guard, not a budget
    assert proc.returncode == EXIT_OK, proc.stderr
    assert "Traceback" not in proc.stderr
    assert proc.stderr.splitlines()[0] == NOTE                # said before the sweep
    assert (tmp_path / "out" / "work_precision.csv").read_text().startswith("method,")
    assert not (tmp_path / "out" / "work_precision.png").exists()
    assert proc.stdout.rstrip().endswith(
        "no plot: matplotlib is not installed (pip install 'mbgen[plot]', then run this again)")


def test_bench_scaling_without_matplotlib_says_so_before_the_sweep(tmp_path, monkeypatch,
                                                                   capsys):
    import mbgen.bench.scaling as bench
    from mbgen.bench.scaling import ScalingRow

    said_before = []

    def sweep(ns, **kw):
        said_before.append(capsys.readouterr().err)
        return [ScalingRow(n, 0.1, 0.01, 0.02, 1.0, 1e-6, 100, 40) for n in ns]

    monkeypatch.setattr(bench, "scaling", sweep)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    assert main(["bench", "scaling", "--ns", "2,4", "-o", str(tmp_path)]) == EXIT_OK
    assert said_before == [NOTE + "\n"]
    assert (tmp_path / "scaling.csv").exists() and not (tmp_path / "scaling.png").exists()
    assert "no plot: matplotlib is not installed" in capsys.readouterr().out


def test_stress_refuses_a_report_path_before_the_suite_runs(tmp_path, capsys, monkeypatch):
    """Was the whole suite, then ``mbgen: numerical error: ... use .csv or .json`` (exit 5)."""
    import mbgen.cli.stress as command

    ran = []
    monkeypatch.setattr(command, "stress", lambda *a, **k: ran.append(a))
    assert main(["stress", "spherical_rod", "-o", str(tmp_path / "r.txt")]) == EXIT_USAGE
    assert main(["stress", "spherical_rod", "-o", str(tmp_path)]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert "use a file name ending in .csv or .json" in err and "is a folder" in err
    assert ran == []


def test_stress_writes_its_report_even_when_the_output_pipe_closes(tmp_path):
    """``mbgen stress SCENE -o r.csv | head -1`` lost the file: the table was printed first,
    and the closed pipe ended the command.  The reader here is gone before the child
    prints (unbuffered, so the first print meets the closed pipe whatever its size)."""
    code = ("import sys\nfrom mbgen.cli import main\n"
            f"sys.exit(main(['stress', 'bead_wire', '-o', {str(tmp_path / 'r.csv')!r}]))\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    proc.stdout.close()                                       # the reader went away
    assert proc.wait(timeout=600) == EXIT_OK                  # a hang guard, not a budget
    assert (tmp_path / "r.csv").read_text().startswith("kind,name,figure,")
