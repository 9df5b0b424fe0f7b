"""The command line: every command, --help, and exit codes."""

import re
import subprocess
import sys

import numpy as np
import pytest

import mbgen
from mbgen.cli import (
    COMMANDS,
    EXIT_CHECK,
    EXIT_MODEL,
    EXIT_OK,
    EXIT_USAGE,
    command_module,
    main,
    parser,
)


def test_help_everywhere(capsys):
    commands = [a.dest for a in parser()._subparsers._group_actions[0]._choices_actions]
    assert {"scenes", "generate", "check", "simulate", "demo", "bench", "stress",
            "golden"} <= set(commands)
    for cmd in [[]] + [[c] for c in commands]:
        with pytest.raises(SystemExit) as info:
            main(cmd + ["--help"])
        assert info.value.code == 0
        assert "usage: mbgen" in capsys.readouterr().out


def test_every_command_module_has_configure_and_run():
    for name in COMMANDS:
        module = command_module(name)
        assert callable(getattr(module, "configure", None)), f"{module.__name__}.configure"
        assert callable(getattr(module, "run", None)), f"{module.__name__}.run"
    assert set(COMMANDS) == {a.dest for a in
                             parser()._subparsers._group_actions[0]._choices_actions}


def test_every_benchmark_is_named_in_the_help():
    from mbgen.cli.bench import BENCHMARKS

    for name in BENCHMARKS:
        assert f"'mbgen bench {name}'" in COMMANDS["bench"].help, name


def _cli_modules_after(argv) -> set:
    """The command modules of mbgen.cli imported by ``main(argv)`` in a fresh interpreter."""
    code = (f"import sys\nfrom mbgen.cli import main\ntry:\n    main({argv!r})\n"
            "except SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith('mbgen.cli.')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return set(eval(done.stdout.strip().splitlines()[-1]))


def test_help_imports_no_command_module():
    assert _cli_modules_after(["--help"]) == set()


def test_a_command_imports_only_its_own_module():
    assert _cli_modules_after(["scenes"]) == {"mbgen.cli.scenes"}
    assert _cli_modules_after(["check", "--help"]) == {"mbgen.cli.check", "mbgen.cli._common"}


#: What ``import mbgen``, ``mbgen --version`` and ``mbgen --help`` must not import (issue
#: 32: about 4 s of imports on a loaded machine, before a command even started).
HEAVY = ("sympy", "numpy", "scipy", "jinja2", "symengine", "cffi", "mbgen.model",
         "mbgen.derivation", "mbgen.codegen", "mbgen.runtime", "mbgen.pipeline")


#: The packages of sys.modules that ran (a package _moved registers to load on first use,
#: a LazyLoader's module, has not), each as its top name (``mbgen.X`` for mbgen's).
RAN = ("import sys\nprint(sorted({m.split('.')[0] if not m.startswith('mbgen.') else "
       "'.'.join(m.split('.')[:2]) for m, mod in list(sys.modules.items()) "
       "if type(mod).__name__ != '_LazyModule'}))")


def _heavy_modules_after(code: str) -> list:
    done = subprocess.run([sys.executable, "-c", code + "\n" + RAN], capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr
    loaded = set(eval(done.stdout.strip().splitlines()[-1]))
    return sorted(loaded & set(HEAVY))


@pytest.mark.parametrize("argv", [["--version"], ["--help"]])
def test_version_and_help_import_no_stage(argv):
    code = f"from mbgen.cli import main\ntry:\n    main({argv!r})\nexcept SystemExit:\n    pass"
    assert _heavy_modules_after(code) == []


def test_import_mbgen_imports_no_stage_until_a_name_is_used():
    assert _heavy_modules_after("import mbgen") == []
    assert _heavy_modules_after("from mbgen import Output") == []
    assert "sympy" in _heavy_modules_after("from mbgen import Model")


def test_every_public_name_resolves_lazily():
    names = set(mbgen.__all__)
    assert names == {n for n in dir(mbgen) if not n.startswith("__")} | {"__version__"}
    for name in sorted(names):
        assert getattr(mbgen, name) is not None, name
    from mbgen import Scene, run
    assert run is mbgen.pipeline.run and Scene is mbgen.model.scene.Scene
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        mbgen.nothing  # noqa: B018


def test_scenes_lists_builtins(capsys):
    assert main(["scenes"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "disc_pendulum" in out and "n_link_cart" in out and "n=3" in out


def test_generate_writes_files_and_is_idempotent(tmp_path, capsys):
    assert main(["generate", "disc_pendulum", "-o", str(tmp_path)]) == EXIT_OK
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == [".mbgen-manifest.json", "disc_pendulum.c", "disc_pendulum.h",
                     "disc_pendulum.py", "example.c"]
    assert "written" in capsys.readouterr().out
    assert main(["generate", "disc_pendulum", "-o", str(tmp_path)]) == EXIT_OK
    assert "unchanged" in capsys.readouterr().out


def test_check_passes(capsys):
    assert main(["check", "n_link_cart", "-O", "n=2", "--samples", "5"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "PASSED" in out and "python" in out


def test_check_fails_above_tolerance(capsys):
    assert main(["check", "n_link_cart", "-O", "n=3", "--rtol", "0", "--atol", "0",
                 "--samples", "5"]) == EXIT_CHECK
    assert "FAILED" in capsys.readouterr().out


def test_simulate_writes_csv(tmp_path, capsys):
    csv = tmp_path / "traj.csv"
    assert main(["simulate", "disc_pendulum", "--csv", str(csv), "--points", "11"]) == EXIT_OK
    lines = csv.read_text().splitlines()
    assert lines[0] == "t,q1,q2,u1,u2" and len(lines) == 12
    assert "final state" in capsys.readouterr().out


def test_simulate_with_a_c_integrator(tmp_path, capsys):
    csv = tmp_path / "c.csv"
    assert main(["simulate", "disc_pendulum", "--integrator", "dopri5", "--rtol", "1e-9",
                 "--atol", "1e-12", "--csv", str(csv), "--points", "5"]) == EXIT_OK
    out = capsys.readouterr().out
    final = {k: float(v)
             for k, v in re.findall(r"(\w+) = ([-\d.e+]+)", out.split("final state:")[1])}
    assert final["q1"] == pytest.approx(26.5621957, abs=1e-6)  # the DOP853 result in the demo
    assert len(csv.read_text().splitlines()) == 6


def test_user_scene_file(tmp_path, capsys):
    scene = tmp_path / "my_scene.py"
    scene.write_text(
        "from mbgen import Model, Scene\n"
        "def scene(k: float = 2.0):\n"
        "    m = Model('spring_mass')\n"
        "    x, = m.coordinates('x')\n"
        "    m.speeds('v')\n"
        "    kk, mass = m.constants('k mass')\n"
        "    N = m.newtonian()\n"
        "    P = m.point('P', m.origin, x * N.x)\n"
        "    m.particle('body', P, mass)\n"
        "    m.spring('s', P, m.origin, kk)\n"
        "    return Scene('spring_mass', m, parameters={'k': k, 'mass': 1.0},\n"
        "                 initial_state={'x': 1.0}, t_span=(0.0, 3.14159265358979))\n")
    assert main(["check", str(scene), "--samples", "3"]) == EXIT_OK
    assert main(["simulate", str(scene), "-O", "k=1", "--rtol", "1e-9", "--atol", "1e-12",
                 "--csv", str(tmp_path / "s.csv")]) == EXIT_OK
    out = capsys.readouterr().out
    final_x = float(re.search(r"final state: x = (\S+),", out).group(1))
    assert final_x == pytest.approx(-1.0, abs=1e-8)  # half a period of a unit oscillator


def test_bad_scene_exit_codes(tmp_path, capsys):
    assert main(["check", "no_such_scene"]) == EXIT_MODEL
    assert main(["check", str(tmp_path / "missing.py")]) == EXIT_MODEL
    assert main(["check", "n_link_cart", "-O", "n=x"]) == EXIT_MODEL
    assert main(["check", "n_link_cart", "-O", "n"]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert "no scene 'no_such_scene'" in err and "does not exist" in err


def test_usage_error_exit_code():
    proc = subprocess.run([sys.executable, "-m", "mbgen.cli", "check"], capture_output=True,
                          text=True)
    assert proc.returncode == 2 and "SCENE" in proc.stderr


def test_golden_check_and_update(tmp_path, capsys):
    root = tmp_path / "g"
    some = ["--scenes", "disc_pendulum,car_trailer"]   # the full tree: tests/verify/test_golden.py
    assert main(["golden", "--root", str(root), *some]) == EXIT_CHECK
    assert main(["golden", "--root", str(root), "--update", *some]) == EXIT_OK
    assert sorted(p.name for p in root.iterdir()) == ["car_trailer", "disc_pendulum"]
    assert main(["golden", "--root", str(root), *some]) == EXIT_OK
    assert "up to date" in capsys.readouterr().out


def test_bench_arm_small_run(tmp_path, capsys):
    args = ["bench", "arm", "--ns", "2", "--no-pinocchio", "--sympy-budget", "0",
            "--repeats", "1", "-o", str(tmp_path)]
    assert main(args) == EXIT_OK
    out = capsys.readouterr().out
    assert "n=2: mbgen ok; sympy not run" in out
    assert (tmp_path / "arm_scaling.csv").read_text().startswith("n,derive_s,")
    assert (tmp_path / "arm_scaling.png").exists()
    assert main(args + ["--derivation", "lagrange"]) == 2
    assert "unknown derivation method 'lagrange'" in capsys.readouterr().err


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
