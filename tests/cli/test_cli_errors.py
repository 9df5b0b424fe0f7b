"""User mistakes on the command line: `mbgen: error: ...`, exit code 2, no traceback; a
scene file naming what its model lacks stops every command at load (exit code 3)."""

import time

import pytest

from mbgen.cli import EXIT_MODEL, EXIT_USAGE, main

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
    fails(["simulate", "disc_pendulum", "--method", "RK99"], capsys,
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
def test_every_command_validates_the_scene_at_load(command, tmp_path, capsys):
    path = scene_file(tmp_path, "bad.py")
    path.write_text(path.read_text().replace('"l": 1.0', '"ll": 1.0'))
    start = time.perf_counter()
    assert main(command + [str(path)]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert err.startswith("mbgen: error:") and "'ll'" in err and "did you mean 'l'" in err
    assert time.perf_counter() - start < 10
