"""The extension's flags (mbgen.build.extension.cflags): optimisation level by source size and its
override, built for this machine's CPU (cache key included) with the portable build's results;
every argument of the compiler in the cache key, IEEE-breaking flags and open quotes refused."""

import dataclasses
import re
import shutil

import numpy as np
import pytest

from mbgen.build import extension
from mbgen.build.extension import (
    IEEE_BREAKERS,
    LARGE_FUNCTION_CHARS,
    NATIVE,
    cflags,
    compiled_path,
    compiler,
    load,
    module_name,
    native_target,
)
from mbgen.errors import ArgumentError, BuildError
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.compiled import CompiledModel
from mbgen.studies.ensemble import worker_module


@pytest.fixture(scope="module")
def rendered():
    return run(load_scene("disc_pendulum"), ("rhs",), build=False).rendered


def test_small_functions_compile_at_O2_a_long_one_at_O1(rendered, monkeypatch):
    """The level follows the longest function, not the file: a split function's parts
    (mbgen.codegen.split) keep -O2 however long the file is."""
    monkeypatch.delenv("MBGEN_OPT", raising=False)
    assert "-O2" in cflags(rendered) and "-ffp-contract=off" in cflags(rendered)
    c = f"{rendered.prefix}.c"
    pad = "/* pad */\n" * (LARGE_FUNCTION_CHARS // 10 + 1)
    big = dataclasses.replace(rendered, files={**rendered.files, c: rendered.files[c] + pad})
    assert "-O1" in cflags(big) and "-O2" not in cflags(big)
    parts = "static void part(void)\n{\n" + pad[:LARGE_FUNCTION_CHARS // 4] + "}\n"
    many = dataclasses.replace(rendered, files={**rendered.files, c: rendered.files[c] + parts * 8})
    assert len(many.source) > 2 * LARGE_FUNCTION_CHARS
    assert "-O2" in cflags(many) and "-O1" not in cflags(many)


def test_MBGEN_OPT_overrides_and_is_part_of_the_cache_key(rendered, monkeypatch):
    monkeypatch.delenv("MBGEN_OPT", raising=False)
    default = module_name(rendered)
    monkeypatch.setenv("MBGEN_OPT", "-O3")
    assert "-O3" in cflags(rendered)
    assert module_name(rendered) != default
    monkeypatch.setenv("MBGEN_OPT", "-O9; rm -rf /")
    with pytest.raises(BuildError, match="MBGEN_OPT"):
        cflags(rendered)


# ------------------------------------------------------------------ built for this machine
def test_a_users_module_is_built_for_this_cpu_where_the_compiler_takes_it(rendered, monkeypatch):
    monkeypatch.delenv("MBGEN_NATIVE", raising=False)
    takes = bool(native_target(compiler()))
    assert (NATIVE[0] in cflags(rendered)) == takes
    assert NATIVE[0] not in cflags(rendered, native=False)
    assert "-ffp-contract=off" in cflags(rendered)        # the results stay the portable ones
    monkeypatch.setenv("MBGEN_NATIVE", "0")
    assert NATIVE[0] not in cflags(rendered)
    monkeypatch.setenv("MBGEN_NATIVE", "yes")
    with pytest.raises(BuildError, match="MBGEN_NATIVE='yes'"):
        cflags(rendered)


def test_a_compiler_that_refuses_march_native_gets_the_portable_flags(rendered, monkeypatch):
    monkeypatch.delenv("MBGEN_NATIVE", raising=False)
    monkeypatch.setenv("CC", "false")          # exits 1 for anything
    assert native_target("false") == ""
    assert NATIVE[0] not in cflags(rendered)


def test_the_cache_key_names_the_cpu(rendered, monkeypatch):
    """A cache shared by two machines never loads a module built for the other's CPU."""
    monkeypatch.delenv("MBGEN_NATIVE", raising=False)
    if not native_target(compiler()):
        pytest.fail("this machine's compiler refuses -march=native; the test needs gcc or clang")
    here = module_name(rendered)
    assert module_name(rendered, native=False) != here
    monkeypatch.setattr(extension, "native_target", lambda cc: "another-cpu")
    assert module_name(rendered) != here


def test_native_and_portable_modules_give_the_same_bits(tmp_path, monkeypatch):
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    res = run(load_scene("spatial_arm", n=4), ("rhs", "jacobian"), build=False)
    r = res.rendered
    native, portable = (CompiledModel(r, load(r, native=flag)) for flag in (True, False))
    assert compiled_path(r, True) != compiled_path(r, False)
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = rng.uniform(-2, 2, native.n_x)
        assert np.array_equal(native.rhs(0.0, x), portable.rhs(0.0, x))
        assert np.array_equal(native.jacobian(0.0, x), portable.jacobian(0.0, x))


def test_a_compiled_model_is_its_rendered_code_and_module(tmp_path, monkeypatch):
    """``CompiledModel(rendered, module)``; the older form, which repeated the rendered code's
    layout, defaults and outputs, still works and refuses values the C does not have."""
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    r = run(load_scene("disc_pendulum"), ("rhs",), build=False).rendered
    module = load(r)
    new, old = CompiledModel(r, module), CompiledModel(r, module, r.layout, r.defaults, r.outputs)
    assert new.layout == old.layout == r.layout and new.outputs == old.outputs == r.outputs
    assert new.parameter_defaults == old.parameter_defaults
    assert CompiledModel(r, module, outputs=["rhs"]).outputs == r.outputs   # names are outputs
    with pytest.raises(ArgumentError, match=r"rendered\.outputs"):
        CompiledModel(r, module, outputs=("rhs", "energy"))
    with pytest.raises(ArgumentError, match=r"rendered\.defaults"):
        CompiledModel(r, module, r.layout, {})


def test_ensemble_workers_build_portable_modules(tmp_path, monkeypatch):
    """A Dask worker's machine may differ from the client's: portable flags unless asked."""
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("MBGEN_NATIVE", raising=False)
    r = run(load_scene("disc_pendulum"), ("rhs",), build=False).rendered
    native = bool(native_target(compiler()))
    module, compiled = worker_module(r.sources())
    assert compiled and compiled_path(r, False).exists()
    assert not (native and compiled_path(r, True).exists())
    assert worker_module(r.sources()) == (module, False)      # once per process
    monkeypatch.setenv("MBGEN_NATIVE", "1")                    # asked for
    worker_module(r.sources())
    assert compiled_path(r, True).exists() == native
    monkeypatch.delenv("MBGEN_NATIVE")
    assert worker_module(r.sources(), native=True)[0] is load(r)   # a serial run's: this CPU's


# ------------------------------------------------------------------ the user's own flags
def test_every_argument_of_the_compiler_is_in_the_cache_key(rendered, monkeypatch):
    """Issue 28: a module built once with CFLAGS=-ffast-math was loaded later without it."""
    for var in ("CFLAGS", "LDFLAGS", "CC"):
        monkeypatch.delenv(var, raising=False)
    names = {module_name(rendered)}
    for var, value in (("CFLAGS", "-DMBGEN_X=1"), ("LDFLAGS", "-Wl,-O1"),
                       ("CC", shutil.which(compiler()))):
        monkeypatch.setenv(var, value)
        names.add(module_name(rendered))
        monkeypatch.delenv(var)
    assert len(names) == 4


@pytest.mark.parametrize("flag, var", [(row[0], "CFLAGS") for row in IEEE_BREAKERS]
                         + [("-Ofast", "LDFLAGS"), ("-ffast-math", "LDFLAGS")])
def test_flags_that_break_ieee_arithmetic_are_refused_with_the_reason(rendered, monkeypatch,
                                                                      flag, var):
    monkeypatch.delenv("CFLAGS", raising=False)
    monkeypatch.setenv(var, f"-g {flag} -DX=1")
    with pytest.raises(BuildError, match=rf"\${var} holds {re.escape(flag)}, .*: it .*"
                                         rf"remove it from {var}"):
        module_name(rendered)


def test_a_flag_taken_back_later_on_the_line_is_accepted(rendered, monkeypatch):
    monkeypatch.setenv("CFLAGS", "-ffast-math -ffinite-math-only -fno-fast-math "
                                 "-fno-finite-math-only")
    assert module_name(rendered).startswith("_mbgen_")
    monkeypatch.setenv("CFLAGS", "-fno-fast-math -ffast-math")
    with pytest.raises(BuildError, match="-ffast-math"):
        module_name(rendered)


@pytest.mark.parametrize("var", ["CFLAGS", "LDFLAGS"])
def test_a_quote_left_open_is_a_named_error(rendered, monkeypatch, var):
    monkeypatch.setenv(var, "-DNAME='a b")
    with pytest.raises(BuildError, match=rf"\${var}=.*no closing quotation.*close the quote "
                                         rf"or unset {var}") as info:
        module_name(rendered)
    assert "\n" not in str(info.value)
