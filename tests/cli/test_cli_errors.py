"""User mistakes on the command line: `mbgen: error: ...`, exit code 2, no traceback; a
scene file naming what its model lacks stops every command at load (exit code 3)."""

import os

import pytest

from mbgen import pipeline
from mbgen.cli import EXIT_MODEL, EXIT_USAGE, main
from mbgen.studies import cluster
from models import scene_file


def fails(argv, capsys, *patterns):
    """Run ``mbgen argv``: exit code 2, one `mbgen: error:` line matching every pattern."""
    code = main(argv)
    err = capsys.readouterr().err
    assert code == EXIT_USAGE, err
    assert err.startswith("mbgen: error: ") and "Traceback" not in err
    for pattern in patterns:
        assert pattern in err, err
    return err


def test_unknown_method(capsys):
    fails(["simulate", "disc_pendulum", "--integrator", "RK99"], capsys,
          "unknown integration method 'RK99'", "DOP853", "rosenbrock")


def test_output_folder_that_is_a_file(tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("mine")
    fails(["linearize", "disc_pendulum", "-o", str(afile)], capsys, "is a file, not a folder")
    fails(["bench", "disc_pendulum", "-o", str(afile)], capsys, "is a file, not a folder")
    assert afile.read_text() == "mine"


def test_bad_output_path(tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("mine")
    fails(["linearize", "disc_pendulum", "-o", str(afile / "sub")], capsys,
          "is a file, so the folder cannot be created")
    fails(["fmu", "disc_pendulum", "-o", str(afile / "sub")], capsys, "cannot be created")


def test_bad_csv(tmp_path, capsys):
    fails(["simulate", "disc_pendulum", "--csv", str(tmp_path)], capsys,
          "is a folder; give a file path")
    afile = tmp_path / "afile"
    afile.write_text("mine")
    fails(["simulate", "disc_pendulum", "--csv", str(afile / "x.csv")], capsys,
          "is a file, not a folder")
    assert afile.read_text() == "mine" and not list(tmp_path.glob("*.csv"))


def test_unwritable_cache_folder(tmp_path, capsys, monkeypatch):
    afile = tmp_path / "afile"
    afile.write_text("")
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(afile / "cache"))
    fails(["simulate", "disc_pendulum", "--csv", str(tmp_path / "t.csv")], capsys,
          "cache folder MBGEN_CACHE_DIR", "point MBGEN_CACHE_DIR at a writable folder")


def test_numbers_by_name_mistakes(tmp_path, capsys):
    csv = ["--csv", str(tmp_path / "t.csv")]
    fails(["simulate", "disc_pendulum", "-p", "mm=2"] + csv, capsys,
          "'mm' is not one of the parameters", "did you mean 'm'?")
    fails(["simulate", "n_link_cart", "-x", "qq1=0.1"] + csv, capsys,
          "'qq1' is not one of the states", "did you mean 'q1'")
    fails(["simulate", "n_link_cart", "-r", "f=1"] + csv, capsys,
          "'f' is not one of the inputs", "did you mean 'F'")
    fails(["simulate", "disc_pendulum", "-p", "m"] + csv, capsys, "must look like NAME=VALUE")
    fails(["check", "disc_pendulum", "-p", "m=heavy"], capsys, "'heavy' is not a number")
    fails(["linearize", "n_link_cart", "-r", "G=1"], capsys, "not one of the inputs")


@pytest.mark.parametrize("command", [["generate"], ["check"], ["simulate"], ["linearize"]])
def test_every_command_validates_the_scene_at_load(command, tmp_path, capsys, monkeypatch):
    """Refused at load, before the derivation starts (a spy on it, not a clock)."""
    path = scene_file(tmp_path, "bad.py")
    path.write_text(path.read_text().replace('"l": 1.0', '"ll": 1.0'))
    derived = []
    monkeypatch.setattr(pipeline, "derive", lambda *a, **k: derived.append(a))
    assert main(command + [str(path)]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert err.startswith("mbgen: error:") and "'ll'" in err and "did you mean 'l'" in err
    assert derived == []


def test_a_bad_dask_scheduler_address_is_one_line(tmp_path, capsys, monkeypatch):
    """Was a 30 s wait and a traceback (``--scheduler``: an unknown flag); now the address is
    tried first, within the connect timeout (shortened here), and named with the fix."""
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 1.0)
    csv = ["--quiet", "--csv", str(tmp_path / "s.csv")]
    for flag in ("--scheduler", "--address"):
        fails(["sweep", "disc_pendulum", flag, "tcp://nonexistent:1"] + csv, capsys,
              "cannot reach a Dask scheduler at 'tcp://nonexistent:1'", "LocalCluster")
    fails(["sweep", "disc_pendulum", "--address", "nonsense"] + csv, capsys,
          "'nonsense'", "tcp://HOST:8786")
    assert not (tmp_path / "s.csv").exists()


@pytest.mark.parametrize("argv, message", [
    (["simulate", "disc_pendulum", "--points", str(10**12)], "must be at most 1,000,000"),
    (["simulate", "disc_pendulum", "--points", "1"], "must be at least 2"),
    (["sweep", "disc_pendulum", "--points", str(10**12)], "must be at most 1,000,000"),
    (["sweep", "disc_pendulum", "--chunk", "0"], "--chunk 0: members per task"),
    (["sweep", "disc_pendulum", "--workers", "0"], "--workers 0: worker processes"),
    (["sweep", "disc_pendulum", "-n", str(10**12)], "must be at most 10,000,000"),
    (["bench", "disc_pendulum", "--repeats", str(10**12)], "must be at most 1,000"),
])
def test_huge_or_empty_counts_are_refused_before_any_work(argv, message, tmp_path, capsys):
    """``--points 10**12`` allocated 7 TiB (a MemoryError traceback); ``--chunk 0`` ran
    nothing and called every member a success."""
    out = ["-o", str(tmp_path / "out")] if argv[0] == "bench" else ["--csv",
                                                                    str(tmp_path / "out")]
    fails(argv + out, capsys, message)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["robot.urdf", "robot.xml", "scene.py"])
def test_a_scene_path_that_is_no_file_is_named_for_what_it_is(name, tmp_path, capsys):
    """A folder or a named pipe given as the scene was said not to exist (exit 3 stays: the
    scene named is what is wrong); now the message says what the path is."""
    folder = tmp_path / name
    folder.mkdir()
    paths = [(folder, "is a folder, not a file")]
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / f"pipe-{name}")
        paths.append((tmp_path / f"pipe-{name}", "is a named pipe (FIFO), not a file"))
    for path, message in paths:
        assert main(["check", str(path)]) == EXIT_MODEL
        err = capsys.readouterr().err
        assert message in err and "does not exist" not in err and "Traceback" not in err, err
