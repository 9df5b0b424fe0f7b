"""What the README shows in C, ``mbgen generate`` writes (issue 19, item 3): the step API
(``--step``, or a scene's ``targets``), an ``example.c`` driven by constant inputs or an
input table (``-r F=2``, ``-r F=table.csv``).  ``mbgen demo`` writes ``example.c`` too
(``tests/cli/test_generate_paths.py::test_demo_does_not_overwrite_a_users_file``)."""

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import mbgen
from mbgen.cli import EXIT_OK, EXIT_USAGE, main
from mbgen.codegen.targets import Targets
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.named import merge_inputs, read_input_csv
from mbgen.runtime.stepper import Stepper
from mbgen.verify.golden import example_integration
from models import scene_file

ROOT = Path(__file__).resolve().parents[2]
CC = shutil.which("gcc") or shutil.which("cc")
C_FLAGS = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2"]


def readme_step_snippet() -> str:
    """The documentation's C block that uses the step API (docs/tutorials/embedding.md)."""
    text = (ROOT / "docs" / "tutorials" / "embedding.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```c\n(.*?)^```", text, re.MULTILINE | re.DOTALL)
    [snippet] = [b for b in blocks if "_dopri5_memory" in b]
    return snippet


MAIN = """#include <stdio.h>
#include "disc_pendulum.h"

int main(void)
{{
    const double x0[DISC_PENDULUM_N_X] = {{0.0, 1.0, 0.5, 0.0}};
    double p[DISC_PENDULUM_N_P];
    int i, k, status = 0;
    disc_pendulum_default_parameters(p);
{snippet}
    for (i = 0; i < DISC_PENDULUM_N_X; ++i) {{
        printf("%.17g\\n", mem.x[i]);
    }}
    return status;
}}
"""


def build(folder: Path, sources, exe: str) -> subprocess.CompletedProcess:
    return subprocess.run([CC, *C_FLAGS, "-o", exe, *sources, "-lm"], cwd=folder,
                          capture_output=True, text=True)


def test_the_readmes_step_snippet_builds_against_generate_step(tmp_path, capsys):
    """It failed with ``unknown type name 'disc_pendulum_dopri5_memory'``: generate had no
    way to ask for the step API."""
    plain, step = tmp_path / "plain", tmp_path / "step"
    snippet = readme_step_snippet()
    for folder, extra in ((plain, []), (step, ["--step"])):
        assert main(["generate", "disc_pendulum", "-o", str(folder), *extra]) == EXIT_OK
        (folder / "main.c").write_text(MAIN.format(snippet=snippet))
    failed = build(plain, ["main.c", "disc_pendulum.c"], "main")
    assert failed.returncode != 0 and "disc_pendulum_dopri5_memory" in failed.stderr
    assert "step API: rk4, dopri5" in capsys.readouterr().out
    done = build(step, ["main.c", "disc_pendulum.c"], "main")
    assert done.returncode == 0 and not done.stderr, done.stderr
    out = subprocess.run([str(step / "main")], capture_output=True, text=True, check=True)
    from_c = [float(v) for v in out.stdout.split()]
    # the same 1000 steps through the Python driver of the step API: the same bits
    scene = load_scene("disc_pendulum")
    model = mbgen.compile(scene, targets=Targets(step=True))
    stepper = Stepper(model, "dopri5", 0.0, [0.0, 1.0, 0.5, 0.0], rtol=1e-8, atol=1e-10)
    for _ in range(1000):
        stepper.step(0.01)
    assert from_c == stepper.x.tolist()


def test_a_scene_asks_for_the_step_api_with_targets(tmp_path, capsys):
    path = scene_file(tmp_path)
    path.write_text(path.read_text().replace("from mbgen import Model, Output, Scene",
                                             "from mbgen import Model, Output, Scene, Targets")
                    .replace("description=DESCRIPTION)",
                             "description=DESCRIPTION, targets=Targets(step=True))"))
    out = tmp_path / "out"
    assert main(["generate", str(path), "-o", str(out)]) == EXIT_OK
    header = (out / "pend.h").read_text()
    assert "pend_dopri5_memory" in header and "int pend_rk4_step(" in header
    model = mbgen.compile(load_scene(str(path)))       # the Python API honours it too
    assert model.rendered.step_methods == ("rk4", "dopri5")
    assert "pend_dopri5_memory" not in run(load_scene(str(path)), build=False,
                                           targets=Targets()).rendered.files["pend.h"]


FORCE = "t,F\n0,0\n0.5,2\n1.5,2\n2,-1\n"


@pytest.mark.parametrize("given", ["table", "number"])
def test_example_c_runs_with_the_inputs_given(given, tmp_path, capsys):
    """``-r`` reached simulate and linearize only; the example held every input at 0."""
    (tmp_path / "force.csv").write_text(FORCE)
    value = str(tmp_path / "force.csv") if given == "table" else "1.5"
    out = tmp_path / "out"
    assert main(["generate", "n_link_cart", "-O", "n=2", "-r", f"F={value}", "-o",
                 str(out)]) == EXIT_OK
    example = (out / "example.c").read_text()
    assert ("static const double table_t[4] = { 0.0, 0.5, 1.5, 2.0 };" in example) \
        == (given == "table")
    done = build(out, ["example.c", "n_link_cart.c"], "example")
    assert done.returncode == 0 and not done.stderr, done.stderr
    rows = subprocess.run([str(out / "example")], capture_output=True, text=True,
                          check=True).stdout.strip().splitlines()
    from_c = np.array([line.split(",") for line in rows[1:]], dtype=float)
    scene = load_scene("n_link_cart", n=2)
    result = run(scene)
    table = read_input_csv(tmp_path / "force.csv")
    r = (merge_inputs({"F": (table.times, table.values["F"])}).for_model(result.compiled)
         if given == "table" else np.array([1.5]))
    python = example_integration(scene, result, r)
    np.testing.assert_array_equal(from_c[:, 0], python.t)
    np.testing.assert_allclose(from_c[:, 1:], python.x, rtol=1e-10, atol=1e-12)
    unforced = example_integration(scene, result)
    assert not np.allclose(python.x[-1], unforced.x[-1])   # the inputs moved the cart


def test_inputs_for_an_example_that_is_not_there(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["generate", "n_link_cart", "--outputs", "rhs", "-r", "F=1", "-o",
                 str(out)]) == EXIT_USAGE
    assert "no integrator among its outputs" in capsys.readouterr().err
    assert not out.exists()
    assert main(["generate", "n_link_cart", "-r", "f=1", "-o", str(out)]) == EXIT_USAGE
    assert "'f' is not one of the inputs of 'n_link_cart'; did you mean 'F'" in \
        capsys.readouterr().err



# ------------------------------------------------------------------ --target (issue 29, item 2)
def _written(folder: Path) -> set:
    return {p.name for p in folder.iterdir() if not p.name.startswith(".")}


def test_target_names_the_files_written(tmp_path, capsys):
    """One registry row per target: ``--target`` picks rows, each adds the rows it needs."""
    for targets, files in ((None, {"disc_pendulum.h", "disc_pendulum.c", "disc_pendulum.py",
                                   "example.c"}),
                           ("c", {"disc_pendulum.h", "disc_pendulum.c"}),
                           ("python", {"disc_pendulum.py"}),
                           ("python,step", {"disc_pendulum.h", "disc_pendulum.c",
                                            "disc_pendulum.py"})):
        out = tmp_path / str(targets)
        extra = ["--target", targets] if targets else []
        assert main(["generate", "disc_pendulum", "-o", str(out), *extra]) == EXIT_OK
        assert _written(out) == files, targets
        if "disc_pendulum.h" in files:
            header = (out / "disc_pendulum.h").read_text()
            assert ("disc_pendulum_dopri5_memory" in header) == (targets == "python,step")
    capsys.readouterr()
    assert main(["generate", "disc_pendulum", "--target", "c,pyton", "-o",
                 str(tmp_path / "x")]) == EXIT_USAGE
    assert "unknown target 'pyton'; did you mean 'python'" in capsys.readouterr().err
    assert main(["generate", "disc_pendulum", "--target", "example", "--outputs", "rhs", "-o",
                 str(tmp_path / "y")]) == EXIT_USAGE
    assert "example.c runs the scene's first integrator" in capsys.readouterr().err
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_batch_target_compiles_with_the_model(tmp_path, capsys):
    """The loops the Python extension compiles, written out: they compile strictly beside
    the model's source (integrator loops included)."""
    out = tmp_path / "out"
    assert main(["generate", "stiff_chain", "--target", "batch", "-o", str(out)]) == EXIT_OK
    assert _written(out) == {"stiff_chain.h", "stiff_chain.c", "stiff_chain_batch.c"}
    text = (out / "stiff_chain_batch.c").read_text()
    assert "int stiff_chain_rosenbrock_batch(" in text and '#include "stiff_chain.h"' in text
    for src in ("stiff_chain_batch.c", "stiff_chain.c"):
        done = subprocess.run([CC, *C_FLAGS, "-c", src], cwd=out, capture_output=True,
                              text=True)
        assert done.returncode == 0 and not done.stderr, done.stderr


def test_the_library_front_is_the_command(tmp_path):
    """``mbgen.generate`` writes what ``mbgen generate`` writes, and says what it did."""
    scene = load_scene("disc_pendulum")
    done = mbgen.generate(scene, "c,example", tmp_path / "lib")
    assert done.targets == ("c", "example") and done.archives == ()
    assert [p.name for p in done.files] == ["disc_pendulum.c", "disc_pendulum.h", "example.c"]
    assert set(done.written) == set(done.files)
    assert main(["generate", "disc_pendulum", "--target", "c,example", "-o",
                 str(tmp_path / "cli")]) == EXIT_OK
    for path in done.files:
        assert path.read_text() == (tmp_path / "cli" / path.name).read_text()
    again = mbgen.generate(scene, ["example", "c"], tmp_path / "lib")
    assert again.written == () and again.files == done.files
