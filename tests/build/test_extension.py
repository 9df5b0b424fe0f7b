"""The flags of a model's module (mbgen.build.extension): the level a long function gets, the
vectoriser's cost model where the compiler takes it, and the line a benchmark compiles the
model's source with to time it as the user runs it.

The slow tests render (never compile) the models whose Jacobians used to fall to -O1: the
32-link spatial arm and the G1 humanoid on its floating base.  Their block entries (the
``DT`` columns of the Jacobian) were printed in the public function, 348 KB of C at n = 32;
:mod:`mbgen.codegen.split` now stores them from the parts, so every function stays below
:data:`~mbgen.build.extension.LARGE_FUNCTION_CHARS` and the module keeps -O2.
"""

import dataclasses

import pytest

from mbgen.abi import Output
from mbgen.build import extension
from mbgen.derivation import Method
from mbgen.model.robots import robot_path
from mbgen.model.scene import urdf_scene
from mbgen.pipeline import run
from mbgen.scenes.spatial_arm import scene as arm_scene


def _levels(flags):
    return [f for f in flags if f.startswith("-O")]


@pytest.fixture(scope="module")
def rendered():
    return run(arm_scene(2), build=False).rendered


def test_model_flags_end_with_the_module_level(monkeypatch, rendered):
    """Python's own flags hold -O3 (or none): the module's level must come last to win."""
    flags = extension.model_flags(rendered, native=False)
    assert flags[-len(extension.cflags(rendered, native=False)):] == \
        extension.cflags(rendered, native=False)
    assert _levels(flags)[-1] == "-O2" and "-march=native" not in flags
    monkeypatch.setenv("MBGEN_OPT", "-O1")
    assert _levels(extension.model_flags(rendered, native=False))[-1] == "-O1"


def _jacobian_level(scene, **kw):
    rendered = run(dataclasses.replace(scene, outputs=(Output.JACOBIAN,)), build=False,
                   **kw).rendered
    source = rendered.files[f"{rendered.prefix}.c"]
    return extension.longest_function(source), _levels(extension.cflags(rendered))[-1], source


@pytest.mark.slow
def test_the_32_link_arms_jacobian_keeps_O2():
    longest, level, source = _jacobian_level(arm_scene(32), method=Method.NEWTON_EULER)
    assert longest < extension.LARGE_FUNCTION_CHARS and level == "-O2"
    # the last right-hand side (DT[2047], stored in place in J's rows) is stored in a part
    assert "J[4095] = " in source.split("spatial_arm_jacobian(double t")[0]


@pytest.mark.slow
def test_g1s_floating_jacobian_keeps_O2():
    path = robot_path("g1")
    if path is None:
        pytest.skip("example-robot-data is not installed")
    longest, level, _ = _jacobian_level(urdf_scene(path, floating=True))
    assert longest < extension.LARGE_FUNCTION_CHARS and level == "-O2"


@pytest.mark.parametrize("name", ["VECTORIZE", "NO_SLP"])
def test_the_vectoriser_flags_are_added_only_where_the_compiler_takes_them(monkeypatch,
                                                                           rendered, name):
    cc = extension._cc()
    flags = getattr(extension, name)
    assert not extension.accepts(cc, ("-fno-such-option-mbgen",))
    wanted = extension.accepts(cc, flags)
    assert (flags[0] in extension.cflags(rendered)) == wanted
    monkeypatch.setattr(extension, "accepts", lambda cc, flags: False)
    assert flags[0] not in extension.cflags(rendered)


@pytest.mark.slow
@pytest.mark.parametrize("solve", ["_jacobian_tree_columns(M, CD", "_ldl_solve_columns(M, DT"])
def test_the_vectorised_column_solve_gives_the_same_numbers_bit_for_bit(monkeypatch, solve):
    """13 speeds: past the unrolled solver, the Jacobian's columns go through the vector
    loops of the tree's column solve or (the tree refused) of ``ldl_solve_columns``, which
    the dynamic cost model vectorises across columns."""
    import numpy as np

    from mbgen.codegen import tree_solve
    from mbgen.runtime.compiled import CompiledModel
    if "ldl" in solve:
        monkeypatch.setattr(tree_solve, "TREE_DENSE_MAX", 0)
    rendered = run(dataclasses.replace(arm_scene(13), outputs=(Output.JACOBIAN,)),
                   build=False).rendered
    assert solve in rendered.files[f"{rendered.prefix}.c"]
    fast = CompiledModel(rendered, extension.load(rendered))
    monkeypatch.setattr(extension, "VECTORIZE", ())
    plain = CompiledModel(rendered, extension.load(rendered))
    x = np.random.default_rng(3).uniform(-1, 1, fast.n_x)
    np.testing.assert_array_equal(fast.jacobian(0.0, x), plain.jacobian(0.0, x))
