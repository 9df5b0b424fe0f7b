"""A warm start: an unchanged model loads without deriving (mbgen.build.warm through
mbgen.pipeline.run), and every change of what the user gave misses, always."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import mbgen
from mbgen import Method, Output, Scene, Targets
from mbgen.build import warm
from mbgen.build.extension import compiled_path
from mbgen.codegen.cse import CseBackend
from mbgen.codegen.outputs import Form
from mbgen.model.scene import load_scene
from mbgen.pipeline import SCENE_UNKEYED, StageTimer, run
from models import pendulum, scene_file

SUPPORT = Path(__file__).resolve().parent / "support"


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    """A cache of this test's own, the warm cache on (the suite turns it off)."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("MBGEN_CACHE_DIR", str(folder))
    monkeypatch.setenv("MBGEN_WARM", "1")
    return folder


def scene(**changes) -> Scene:
    base = Scene("warm_pendulum", pendulum("warm_pendulum"),
                 parameters={"l": 1.0, "g": 9.81, "m": 1.0}, initial_state={"q": 0.3})
    return dataclasses.replace(base, **changes)


class _Looked(Exception):
    """Raised by the stand-in lookup: the key is known, nothing is derived."""


def key_of(source, **options) -> str:
    """The warm cache's key of ``run(source, **options)``, taken where run looks it up."""
    seen = []

    def look(key):
        seen.append(key)
        raise _Looked
    with pytest.MonkeyPatch.context() as patch, pytest.raises(_Looked):
        patch.setattr(warm, "lookup", look)
        run(source, warm=True, **options)
    return seen[0]


def test_a_second_run_loads_without_deriving(cache, monkeypatch):
    cold = run(scene())
    assert not cold.warm and "derive" in cold.timings
    monkeypatch.setattr("mbgen.pipeline._chosen", _no_derivation)
    heard = []
    again = run(scene(initial_state={"q": 1.0}, t_span=(0, 5)), stage=heard.append)
    assert again.warm and heard == ["warm"] and set(again.timings) == {"warm"}
    assert again.rendered.digest() == cold.rendered.digest()
    x = np.array([0.3, 0.1])
    assert np.array_equal(again.compiled.rhs(0.0, x), cold.compiled.rhs(0.0, x))
    assert again.layout == cold.layout and again.fixed == cold.fixed


def _no_derivation(*args, **kwargs):
    raise AssertionError("a warm run derived")


def test_a_warm_results_derived_values_come_when_read(cache):
    cold = run(scene())
    again = run(scene())
    assert again.warm and "equations=None" in repr(again)
    assert again.kernel.layout == again.rendered.layout       # derived now, once
    assert again.equations.mass_matrix == cold.equations.mass_matrix
    assert again.baked.forcing == cold.baked.forcing and again.later is None


def test_a_compile_in_a_new_process_derives_nothing(cache):
    code = textwrap.dedent("""
        import json, sys, numpy as np, mbgen
        from models import pendulum
        result = mbgen.run(pendulum("fresh_pendulum"))
        rhs = result.compiled.rhs(0.0, np.array([0.3, 0.1]), np.array([1.0, 9.81, 1.0]))
        print(json.dumps([result.warm, sorted(result.timings), rhs.tolist()]))
    """)
    env = {**os.environ, "MBGEN_CACHE_DIR": str(cache), "PYTHONPATH": str(SUPPORT)}
    env.pop("MBGEN_WARM")                       # a user's default: on
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, timeout=600) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), runs[-1].stderr
    (warm1, stages1, rhs1), (warm2, stages2, rhs2) = (json.loads(r.stdout.splitlines()[-1])
                                                      for r in runs)
    assert (warm1, warm2) == (False, True)
    assert "derive" in stages1 and stages2 == ["warm"] and rhs1 == rhs2


def test_mbgen_warm_0_derives_every_time(cache, monkeypatch):
    run(scene())
    monkeypatch.setenv("MBGEN_WARM", "0")
    assert not run(scene()).warm
    monkeypatch.setenv("MBGEN_WARM", "1")
    assert run(scene()).warm and not run(scene(), warm=False).warm
    assert not mbgen.run(scene(), build=False).warm       # writing source always derives


def test_a_timed_run_runs_every_stage(cache):
    run(scene())
    heard = []
    timed = run(scene(), timer=StageTimer(finished=lambda name, s, v: heard.append(name)))
    assert not timed.warm and heard[:1] == ["derive"] and heard[-1] == "compile"
    assert run(scene(), timer=StageTimer(), warm=True).warm


def test_other_compiler_flags_rebuild_from_the_stored_code(cache, monkeypatch):
    before = compiled_path(run(scene()).rendered)
    monkeypatch.setenv("CFLAGS", "-DMBGEN_WARM_TEST=1")
    monkeypatch.setattr("mbgen.pipeline._chosen", _no_derivation)
    again = run(scene())
    assert again.warm and not again.compile_cached        # compiled anew, derived never
    assert compiled_path(again.rendered) != before and compiled_path(again.rendered).exists()


# ------------------------------------------------------------------ what misses
CHANGES = {
    "outputs": dict(outputs=(Output.RHS, Output.JACOBIAN)),
    "parameters": dict(parameters={"l": 2.0}),
    "fixed": dict(fixed={"g": 9.81}),
    "name": dict(name="other"),
    "sliced": dict(sliced=False),
    "cse_backend": dict(cse_backend=CseBackend.SYMPY),
    "targets": dict(targets=Targets(step=True)),
    "method": dict(method=Method.KANE),
    "form": dict(form=Form.SOLVE),
}
SCENE_CHANGES = {
    "model": dict(model=pendulum("other_pendulum")),
    "scene parameters": dict(parameters={"l": 1.0, "g": 9.81, "m": 2.0}),
    "scene outputs": dict(outputs=(Output.RHS, Output.RK4)),
    "scene fixed": dict(fixed={"l": 1.0}),
    "scene inputs": dict(inputs=()),
    "scene points": dict(points=("P",)),
    "scene prefix": dict(prefix="pend"),
    "scene method": dict(method=Method.NEWTON_EULER),
    "scene targets": dict(targets=Targets(step=True)),
    "scene name": dict(name="renamed"),
}


def test_every_option_and_scene_field_misses(monkeypatch):
    base = key_of(scene())
    keys = {what: key_of(scene(), **options) for what, options in CHANGES.items()}
    keys |= {what: key_of(scene(**changes))
             for what, changes in SCENE_CHANGES.items()}
    assert base not in keys.values(), [w for w, k in keys.items() if k == base]
    assert len(set(keys.values())) == len(keys)
    assert key_of(scene()) == base


def test_what_never_reaches_the_code_is_not_keyed():
    base = key_of(scene())
    assert key_of(scene(initial_state={"q": 2.0}, t_span=(0.0, 3.0), description="other",
                        conserves_energy=True, options={"n": 3})) == base
    here, there = (key_of(scene(source=f"/{folder}/pend.py")) for folder in ("a", "b"))
    assert here == there != base                 # the header names the file, not its folder
    assert set(SCENE_UNKEYED) < {f.name for f in dataclasses.fields(Scene)}


def test_a_changed_mbgen_misses(monkeypatch):
    base = key_of(scene())
    monkeypatch.setattr(warm, "code_identity", lambda: "an edited mbgen")
    assert key_of(scene()) != base


def test_a_model_without_a_canonical_form_derives(cache, monkeypatch):
    odd = scene(parameters={"l": 1.0, "g": 9.81, "m": 1.0})
    odd.model.note = lambda: None        # a function: no canonical form, no warm cache
    assert not run(odd).warm and not run(odd).warm
    assert not list(cache.glob(f"{warm.PREFIX}*"))


# ------------------------------------------------------------------ files
ROBOT = """<robot name="warm_arm">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="0 0 0.2"/><mass value="{mass}"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="5" velocity="4"/></joint>
</robot>
"""


def test_a_changed_urdf_file_misses_and_a_moved_one_does_not(tmp_path, monkeypatch):
    path = tmp_path / "arm.urdf"
    path.write_text(ROBOT.format(mass=1.5))
    base = key_of(load_scene(str(path)))
    moved = tmp_path / "elsewhere" / "arm.urdf"
    moved.parent.mkdir()
    moved.write_text(path.read_text())
    assert key_of(load_scene(str(moved))) == base
    path.write_text(ROBOT.format(mass=1.25))
    assert key_of(load_scene(str(path))) != base
    assert key_of(load_scene(str(moved), saturate=True)) != base
    assert key_of(load_scene(str(moved), drop=0.5)) == base   # the start only


def test_a_changed_urdf_file_gives_its_own_numbers(cache, tmp_path):
    path = tmp_path / "arm.urdf"
    x = np.array([0.4, 0.0])
    path.write_text(ROBOT.format(mass=1.5))
    first = mbgen.run(load_scene(str(path)), ("rhs",))
    path.write_text(ROBOT.format(mass=3.0))
    changed = mbgen.run(load_scene(str(path)), ("rhs",))
    assert not changed.warm
    assert not np.array_equal(first.compiled.rhs(0.0, x), changed.compiled.rhs(0.0, x))
    path.write_text(ROBOT.format(mass=1.5))
    back = mbgen.run(load_scene(str(path)), ("rhs",))
    assert back.warm and np.array_equal(back.compiled.rhs(0.0, x), first.compiled.rhs(0.0, x))


def test_a_changed_scene_file_misses(tmp_path, monkeypatch):
    path = scene_file(tmp_path)
    base = key_of(load_scene(str(path)))
    scene_file(tmp_path, description="the same pendulum, said otherwise")
    assert key_of(load_scene(str(path))) == base      # prose: no new code
    path.write_text(path.read_text().replace("-l * B.y", "-2 * l * B.y"))
    assert key_of(load_scene(str(path))) != base


MJCF = """<mujoco model="warm_hinge"><worldbody><body name="link" pos="0 0 1">
  <joint name="hinge" type="hinge" axis="0 1 0"/>
  <geom type="capsule" fromto="0 0 0 0 0 -{length}" size="0.05" mass="1"/>
</body></worldbody></mujoco>"""


def test_a_changed_mjcf_file_misses(tmp_path, monkeypatch):
    pytest.importorskip("mujoco", reason="MuJoCo reads MJCF files (the mujoco extra)")
    path = tmp_path / "hinge.xml"
    path.write_text(MJCF.format(length=0.5))
    base = key_of(load_scene(str(path)))
    path.write_text(MJCF.format(length=0.6))
    assert key_of(load_scene(str(path))) != base
