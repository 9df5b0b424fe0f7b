"""The generated C embeds anywhere: plain C and C++ compilers, an example program, several
models."""

import shutil
import subprocess

import numpy as np
import pytest

from heavy import scene_params
from mbgen.abi import Output
from mbgen.model.scene import builtin_names, load_scene
from mbgen.pipeline import run
from mbgen.verify import golden
from mbgen.verify.golden import example_integration

CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++") or shutil.which("c++")
C_FLAGS = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror"]
CXX_FLAGS = ["-x", "c++", "-std=c++11", "-pedantic", "-Wall", "-Wextra", "-Werror"]
WITH_EXAMPLE = [n for n in builtin_names()  # scenes with an integrator get example.c
                if any(Output(o).is_integrator
                       for o in load_scene(n, **golden.GOLDEN_OPTIONS.get(n, {})).outputs)]


def write(folder, files):
    for name, text in files.items():
        (folder / name).write_text(text)


def compile_and_run(folder, sources, exe="prog"):
    build = subprocess.run([CC, *C_FLAGS, "-O2", "-o", exe, *sources, "-lm"], cwd=folder,
                           capture_output=True, text=True)
    assert build.returncode == 0 and not build.stderr, build.stderr
    return subprocess.run([str(folder / exe)], cwd=folder, capture_output=True, text=True,
                          check=True)


@pytest.mark.parametrize("name", scene_params(heavy=True))
def test_plain_c_and_cxx_compile_without_python(name, tmp_path):
    files = golden.scene_files(name)
    write(tmp_path, files)
    sources = [f for f in files if f.endswith(".c")]
    for src in sources:
        c = subprocess.run([CC, *C_FLAGS, "-c", src, "-o", src + ".o"], cwd=tmp_path,
                           capture_output=True, text=True)
        assert c.returncode == 0 and not c.stderr, c.stderr
        cxx = subprocess.run([CXX, *CXX_FLAGS, "-c", src, "-o", src + ".cc.o"], cwd=tmp_path,
                             capture_output=True, text=True)
        assert cxx.returncode == 0 and not cxx.stderr, cxx.stderr


def test_every_scene_with_an_integrator_has_an_example():
    assert set(WITH_EXAMPLE) >= {"disc_pendulum", "n_link_cart", "bead_wire", "torque_free"}


@pytest.mark.parametrize("name", scene_params(WITH_EXAMPLE, heavy=True))
def test_example_matches_the_python_path(name, tmp_path):
    scene = load_scene(name, **golden.GOLDEN_OPTIONS.get(name, {}))
    files = golden.scene_files(name)
    write(tmp_path, files)
    header = files["example.c"].split("*/")[0]
    assert "cc -std=c99 -O2 -o example example.c" in header  # the one-line build command
    prefix = next(f[:-2] for f in files if f.endswith(".h"))
    out = compile_and_run(tmp_path, ["example.c", f"{prefix}.c"], "example").stdout
    rows = [line.split(",") for line in out.strip().splitlines()]
    result = run(scene)
    assert rows[0] == ["t", *result.layout.state_names]
    from_c = np.array(rows[1:], dtype=float)
    python = example_integration(scene, result)
    np.testing.assert_allclose(from_c[:, 0], python.t, rtol=0, atol=0)
    np.testing.assert_allclose(from_c[:, 1:], python.x, rtol=1e-10, atol=1e-12)


MAIN = r"""
#include <stdio.h>
#include "disc_pendulum.h"
#include "n_link_cart.h"
#include "paraboloid.h"
#include "paraboloid_free.h"

int main(void)
{
    const double xd[DISC_PENDULUM_N_X] = {0.0, 1.0, 0.5, 0.0};
    const double pd[DISC_PENDULUM_N_P] = {1.0, 4.0, 10.0, 1.0};
    const double xn[N_LINK_CART_N_X] = {0};
    double pn[N_LINK_CART_N_P];
    const double rn[N_LINK_CART_N_R] = {1.0};
    const double xp[PARABOLOID_N_X] = {1.0, 0.0, 0.0, 2.5};
    const double pp[PARABOLOID_N_P] = {0.5, 1.0};
    const double pf[PARABOLOID_FREE_N_P] = {0.5, 9.81, 1.0};
    double a[DISC_PENDULUM_N_X], b[N_LINK_CART_N_X], c[PARABOLOID_N_X], d[PARABOLOID_FREE_N_X];
    int i;
    n_link_cart_default_parameters(pn);
    if (disc_pendulum_rhs(0.0, xd, pd, a) || n_link_cart_rhs(0.0, xn, pn, rn, b)
        || paraboloid_rhs(0.0, xp, pp, c) || paraboloid_free_rhs(0.0, xp, pf, d)) {
        return 1;
    }
    for (i = 0; i < PARABOLOID_N_X; ++i) {
        printf("%.17g %.17g\n", c[i], d[i]);
    }
    printf("%.17g %.17g\n", a[3], b[N_LINK_CART_N_Q]);
    return 0;
}
"""


def test_several_models_link_into_one_program(tmp_path):
    """Two scenes, and one scene sliced two ways (different prefixes), in one C program."""
    write(tmp_path, golden.scene_files("disc_pendulum"))
    write(tmp_path, golden.scene_files("n_link_cart"))
    write(tmp_path, run(load_scene("paraboloid"), build=False).rendered.files)
    free = run(load_scene("paraboloid"), build=False, fixed={}, name="paraboloid_free")
    write(tmp_path, free.rendered.files)
    (tmp_path / "main.c").write_text(MAIN)
    out = compile_and_run(tmp_path, ["main.c", "disc_pendulum.c", "n_link_cart.c",
                                     "paraboloid.c", "paraboloid_free.c"]).stdout.split("\n")
    pairs = [tuple(map(float, line.split())) for line in out[:4]]
    for baked, free_value in pairs:  # g baked vs g passed: the same numbers
        assert baked == pytest.approx(free_value, rel=1e-14, abs=1e-14)
    disc_u2, cart_u0 = map(float, out[4].split())
    assert disc_u2 == pytest.approx(-1.95624639, abs=1e-8)  # the notes' u2' at the start
    assert cart_u0 > 0  # the pushed cart accelerates
