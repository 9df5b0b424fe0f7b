"""Optimisation level by source size, and its override (mbgen.build.extension.cflags)."""

import dataclasses

import pytest

from mbgen.build.extension import LARGE_SOURCE_CHARS, cflags, module_name
from mbgen.errors import BuildError
from mbgen.pipeline import run
from mbgen.model.scene import load_scene


@pytest.fixture(scope="module")
def rendered():
    return run(load_scene("disc_pendulum"), ("rhs",), build=False).rendered


def test_small_sources_compile_at_O2_large_ones_at_O1(rendered, monkeypatch):
    monkeypatch.delenv("MBGEN_OPT", raising=False)
    assert "-O2" in cflags(rendered) and "-ffp-contract=off" in cflags(rendered)
    c = f"{rendered.prefix}.c"
    files = {**rendered.files, c: rendered.files[c] + "/* pad */\n" * (LARGE_SOURCE_CHARS // 10)}
    big = dataclasses.replace(rendered, files=files)
    assert len(big.source) > LARGE_SOURCE_CHARS
    assert "-O1" in cflags(big) and "-O2" not in cflags(big)


def test_MBGEN_OPT_overrides_and_is_part_of_the_cache_key(rendered, monkeypatch):
    monkeypatch.delenv("MBGEN_OPT", raising=False)
    default = module_name(rendered)
    monkeypatch.setenv("MBGEN_OPT", "-O3")
    assert "-O3" in cflags(rendered)
    assert module_name(rendered) != default
    monkeypatch.setenv("MBGEN_OPT", "-O9; rm -rf /")
    with pytest.raises(BuildError, match="MBGEN_OPT"):
        cflags(rendered)
