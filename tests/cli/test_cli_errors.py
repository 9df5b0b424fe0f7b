"""User mistakes on the command line: `mbgen: error: ...`, exit code 2, no traceback."""

import subprocess
import sys

import numpy as np
import pytest
from sympy.physics.mechanics.models import n_link_pendulum_on_cart

import mbgen
from mbgen.cli import EXIT_OK, EXIT_USAGE, main


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


def test_numbers_by_name_reach_the_simulation(tmp_path, capsys):
    path = tmp_path / "t.csv"
    base = ["simulate", "n_link_cart", "-O", "n=1", "-x", "q1=0.3", "-x", "q0=0.5", "--csv",
            str(path), "--points", "3"]
    assert main(base + ["-p", "g=0"]) == EXIT_OK  # no gravity, no push: at rest
    rows = np.loadtxt(path, delimiter=",", skiprows=1)
    assert np.array_equal(rows[:, 1:], np.tile([0.5, 0.3, 0.0, 0.0], (3, 1)))
    assert main(base) == EXIT_OK  # gravity swings the pendulum
    assert np.loadtxt(path, delimiter=",", skiprows=1)[-1, 2] != 0.3
    assert main(base + ["-p", "g=0", "-r", "F=2"]) == EXIT_OK  # pushed along
    assert np.loadtxt(path, delimiter=",", skiprows=1)[-1, 1] > 1.0


def test_simulate_cli_picks_the_c_integrator_of_a_stiff_scene(tmp_path, capsys):
    assert main(["simulate", "stiff_chain", "-O", "stiffness=1e8", "--csv",
                 str(tmp_path / "s.csv")]) == EXIT_OK
    out = capsys.readouterr().out
    assert "C rosenbrock" in out and "Jacobians" in out


def test_python_dash_m_mbgen():
    out = subprocess.run([sys.executable, "-m", "mbgen", "--version"], capture_output=True,
                         text=True, check=True).stdout
    assert out.strip() == f"mbgen {mbgen.__version__}"
    bad = subprocess.run([sys.executable, "-m", "mbgen", "simulate", "disc_pendulum", "--method",
                          "RK99"], capture_output=True, text=True)
    assert bad.returncode == EXIT_USAGE and "Traceback" not in bad.stderr


@pytest.mark.parametrize("output, option", [("energy", "Output.ENERGY"),
                                            ("positions", "Output.POSITIONS"),
                                            ("reactions", "Output.REACTIONS")])
def test_from_sympy_messages_name_its_own_arguments(output, option):
    eq = mbgen.from_sympy(n_link_pendulum_on_cart(1, cart_force=True))
    with pytest.raises(mbgen.ModelError) as info:
        mbgen.compile(eq, ["rhs", output])
    text = str(info.value)
    assert "from_sympy(obj, name=, parameters=, dependent=)" in text and option in text
    assert "energy=True" not in text and "points=..." not in text


def test_integrate_result_reads_like_scipy():
    scene = mbgen.load_scene("disc_pendulum")
    model = mbgen.compile(scene)
    res = model.integrate("dopri5", np.linspace(0, 1, 6), scene.x0(model.layout))
    assert res.y.shape == (model.n_x, 6) and np.array_equal(res.y.T, res.x)
    assert res.success and res.status == 0 and "successfully" in res.message
    assert (res.nfev, res.njev, res.nlu) == (res.n_rhs, res.n_jac, res.n_lu) and res.nfev > 0
    assert res["y"] is not None and np.array_equal(res["t"], res.t)
    with pytest.raises(KeyError):
        res["nope"]
