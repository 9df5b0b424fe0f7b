"""Bad input gets a clear error that names the problem."""

import dataclasses

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen import Model
from mbgen.build.extension import load
from mbgen.errors import (
    BuildError,
    ModelError,
    NonFiniteResultError,
    SceneError,
    SingularMassMatrixError,
    UsageError,
)
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from models import pendulum


def test_scene_file_that_does_not_exist():
    with pytest.raises(SceneError, match="does not exist"):
        load_scene("no/such/scene.py")


def test_unknown_scene_lists_builtins():
    with pytest.raises(SceneError, match="disc_pendulum"):
        load_scene("no_such_scene")


def test_unknown_scene_option():
    with pytest.raises(SceneError, match="no option 'links'"):
        load_scene("n_link_cart", links=3)


def test_body_without_inertia():
    m = Model("rod")
    q, = m.coordinates("q")
    m.speeds("u")
    N = m.newtonian()
    B = m.rotate(N, "B", 3, q)
    with pytest.raises(ModelError, match="has no inertia"):
        m.body("rod", B, 1.0, None, m.origin)


@pytest.mark.parametrize("name", ["int", "double", "return", "class", "lambda"])
def test_model_name_that_is_a_keyword(name):
    with pytest.raises(ModelError, match="keyword"):
        Model(name)


def test_symbol_named_like_c_keyword_is_sanitised():
    m = Model("kw")
    q, = m.coordinates("q")
    m.speeds("u")
    dbl, = m.constants("double")
    N = m.newtonian()
    P = m.point("P", m.origin, q * N.x)
    m.particle("P_mass", P, dbl)
    result = run(m, parameters={"double": 2.0})
    assert "const double double_ = p[0];" in result.rendered.source
    np.testing.assert_allclose(result.compiled.rhs(0, [0.0, 1.0]), [1.0, 0.0])


def test_unknown_symbol():
    m = pendulum()
    k = sm.Symbol("k")  # never declared
    m.force(m.points and list(m.points)[-1], k * m.N.x)
    with pytest.raises(ModelError, match="unknown symbol.*k"):
        mbgen.derive(m)


def test_undeclared_time_function():
    from sympy.physics.vector import dynamicsymbols

    m = pendulum()
    w = dynamicsymbols("w")
    m.force(list(m.points)[-1], w * m.N.x)
    with pytest.raises(ModelError, match="w"):
        mbgen.derive(m)


def test_frame_from_another_model():
    a, b = pendulum("a"), pendulum("b")
    with pytest.raises(ModelError, match="not part of model"):
        a.rotate(b.N, "C", 1, 0.1)


def test_duplicate_names():
    m = Model("dup")
    m.coordinates("q")
    with pytest.raises(ModelError, match="already used"):
        m.constants("q")


def test_bad_rotation_axis():
    m = Model("ax")
    q, = m.coordinates("q")
    N = m.newtonian()
    with pytest.raises(ModelError, match="axis"):
        m.rotate(N, "B", 4, q)


def test_model_without_masses():
    m = Model("empty")
    m.coordinates("q")
    m.speeds("u")
    m.newtonian()
    with pytest.raises(ModelError, match="no particles or bodies"):
        mbgen.derive(m)


def test_singular_mass_matrix_is_an_exception_not_nan():
    model = mbgen.compile(pendulum(), parameters={"l": 1.0, "g": 9.81, "m": 1.0})
    with pytest.raises(SingularMassMatrixError, match="not positive definite"):
        model.rhs(0.0, [0.1, 0.0], [1.0, 9.81, 0.0])   # zero mass
    with pytest.raises(SingularMassMatrixError):
        model.rhs(0.0, [0.1, 0.0], [1.0, 9.81, -1.0])  # negative mass
    with pytest.raises(NonFiniteResultError, match="NaN"):
        model.rhs(0.0, [np.nan, 0.0])                   # NaN state: never a silent NaN


def test_singular_mass_matrix_in_generated_python():
    result = run(pendulum(), parameters={"l": 1.0, "g": 9.81, "m": 1.0})
    py = mbgen.python_model(result.rendered)
    with pytest.raises(SingularMassMatrixError):
        py.rhs(0.0, [0.1, 0.0], [1.0, 9.81, 0.0])


def test_compiler_failure_carries_compiler_output(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    rendered = run(pendulum("broken"), build=False).rendered
    files = dict(rendered.files)
    files["broken.c"] = files["broken.c"].replace("return BROKEN_OK;", "return BROKEN_OK", 1)
    broken = dataclasses.replace(rendered, files=files)
    with pytest.raises(BuildError) as info:
        load(broken)
    text = str(info.value)
    assert "broken.c" in text and "error" in text
    leftovers = list(tmp_path.glob("_mbgen_broken_*.so"))
    assert not leftovers, "no half-built module may stay in the cache"


def test_missing_compiler(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "no-such-compiler-xyz")
    with pytest.raises(BuildError, match="no C compiler"):
        load(run(pendulum("nocc"), build=False).rendered)


# ------------------------------------------------------------------ exit codes of the CLI
#: The exit code and message heading of every error on the command line.
EXIT_CODES = {
    "MbgenError": (5, "numerical error"),
    "ModelError": (3, "error"), "ModelSizeError": (3, "error"),
    "NonFiniteConstantError": (3, "error"), "SceneError": (3, "error"),
    "BuildError": (4, "compiler error"), "CacheError": (2, "error"),
    "SingularMassMatrixError": (5, "numerical error"),
    "SingularConstraintError": (5, "numerical error"),
    "ConstraintError": (5, "numerical error"), "NonFiniteResultError": (5, "numerical error"),
    "IntegrationError": (5, "numerical error"), "ArgumentError": (5, "numerical error"),
    "ArgumentTypeError": (5, "numerical error"),
    "CheckFailed": (1, "check failed"), "CheckInconclusive": (6, "check inconclusive"),
    "UnknownNameError": (2, "error"), "UsageError": (2, "error"),
    "MissingExtraError": (2, "error"), "BenchmarkError": (2, "error"),
    "OutputPathError": (2, "error"), "OutputConflictError": (2, "error"),
    "OutputBusyError": (2, "error"),
    "UrdfError": (3, "error"), "UrdfSyntaxError": (3, "error"), "UrdfInertiaError": (3, "error"),
    "UrdfStructureError": (3, "error"), "UrdfUnsupportedError": (3, "error"),
    "MjcfError": (3, "error"),
}


def test_every_error_has_its_exit_code():
    import mbgen.errors as errors

    classes = {name: cls for name, cls in vars(errors).items()
               if isinstance(cls, type) and issubclass(cls, errors.MbgenError)}
    assert set(classes) == set(EXIT_CODES)
    assert {name: cls.exit_code for name, cls in classes.items()} == \
        {name: code for name, (code, _) in EXIT_CODES.items()}


@pytest.mark.parametrize("name", sorted(EXIT_CODES))
def test_the_cli_exits_with_the_error_s_code(name, monkeypatch, capsys):
    import mbgen.errors as errors
    from mbgen.cli import command_module, main

    def fail(args):
        raise getattr(errors, name)("what went wrong")

    monkeypatch.setattr(command_module("scenes"), "run", fail)
    code, heading = EXIT_CODES[name]
    assert main(["scenes"]) == code
    assert capsys.readouterr().err == f"mbgen: {heading}: what went wrong\n"


def test_targets_that_are_not_a_targets_value_are_a_usage_error():
    """``run(scene, targets=("c", "step"))`` raised an AttributeError from the renderer."""
    with pytest.raises(UsageError, match=r"Targets\(step=True\).*mbgen\.generate"):
        run(pendulum("targets"), targets=("c", "step"), build=False)
