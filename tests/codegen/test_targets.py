"""Targets, runtime routines and integrators as data: every registry row has its templates,
what is rendered is chosen from the rows' properties, one loop renders them all, and a
runtime routine is declared by every target that calls it and emitted once."""

import ast
import inspect
import re
import shutil
import subprocess
from pathlib import Path
from types import SimpleNamespace

import pytest

import mbgen.codegen.render
import mbgen.codegen.targets
from mbgen.abi import INTEGRATORS, Output
from mbgen.codegen.targets import (
    CHOSEN,
    DEFAULT,
    SECTIONS,
    TARGETS,
    Targets,
    select,
    switches,
    target,
)
from mbgen.codegen.targets.base import EXTENSION, HEADER, SOURCE, Target
from mbgen.codegen.targets.runtime import ROUTINES, Runtime
from mbgen.codegen.targets.step import adaptive_method, step_methods
from mbgen.codegen.templating import environment
from mbgen.errors import UsageError
from mbgen.integrators import METHODS
from mbgen.model.scene import load_scene
from mbgen.pipeline import run

TEMPLATES = Path(__file__).resolve().parents[2] / "templates"
#: Template folders that belong to no target (loaded by mbgen.bench; the runtime routines).
OTHER_FOLDERS = {"bench", "runtime"}
CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++") or shutil.which("c++")


@pytest.mark.parametrize("target", TARGETS, ids=lambda t: t.name)
def test_every_target_has_its_templates(target):
    assert (TEMPLATES / target.template_folder).is_dir()
    for template, where in target.templates("demo"):
        assert template.startswith(f"{target.template_folder}/")
        assert (TEMPLATES / template).is_file(), template
        environment().get_template(template)        # parses
        assert where in (HEADER, SOURCE, EXTENSION) or "demo" in where or "." in where
    assert set(target.requires) <= set(ROUTINES)
    assert set(target.needs) | set(target.uses) <= {t.name for t in TARGETS} - {target.name}


def test_every_template_folder_is_a_target():
    folders = {p.name for p in TEMPLATES.iterdir() if p.is_dir() and p.name != "__pycache__"}
    assert folders == {t.template_folder for t in TARGETS} | OTHER_FOLDERS
    assert len({t.name for t in TARGETS}) == len(TARGETS)
    assert set(SECTIONS) <= set(TARGETS)
    assert set(DEFAULT) <= set(CHOSEN)


def test_one_loop_renders_every_target():
    """render() reads the rows and names none (no target is rendered by a function of its own)."""
    tree = ast.parse(inspect.getsource(mbgen.codegen.render))
    rows = {name for name, value in vars(mbgen.codegen.targets).items()
            if isinstance(value, Target)}
    used = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} | {
        a.asname or a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
        for a in n.names}
    assert rows and not rows & used
    assert "TARGETS" in used


@pytest.mark.parametrize("routine", ROUTINES.values(), ids=lambda r: r.name)
def test_every_routine_has_its_template_and_contract(routine):
    text = (TEMPLATES / routine.template).read_text()
    assert text.startswith("{# contract: ")
    for fn in routine.functions:
        assert re.search(rf"^static \w+ {{{{ prefix }}}}_{fn}\(", text, re.M), fn
    assert set(routine.requires) <= set(ROUTINES) - {routine.name}
    assert {p.name[:-len(".c.j2")] for p in (TEMPLATES / "runtime").glob("*.c.j2")} == set(ROUTINES)


@pytest.mark.parametrize("folder", sorted({t.template_folder for t in TARGETS}))
def test_a_template_calls_only_the_routines_its_targets_list(folder):
    """The step API called the integrators' LU without saying so; now a call of a routine's
    function needs the routine in ``requires`` of the target owning the template."""
    owner = {fn: r.name for r in ROUTINES.values() for fn in r.functions}
    listed = {n for t in TARGETS if t.template_folder == folder for n in t.requires}
    for path in (TEMPLATES / folder).glob("*.j2"):
        called = set(re.findall(r"\{\{ prefix \}\}_(\w+)\(", path.read_text()))
        assert {owner[f] for f in called if f in owner} <= listed, path.name
        asked = set(re.findall(r'runtime\("(\w+)"\)', path.read_text()))
        assert asked <= listed, path.name


def test_an_undeclared_routine_is_refused():
    view = Runtime({}).view(target("python"))
    with pytest.raises(LookupError, match="without listing it"):
        view("lu")


def test_select_names_what_is_asked_with_what_it_needs():
    assert [t.name for t in select("example")] == ["c", "example"]
    assert [t.name for t in select(["fmu", "python"])] == ["python", "fmu"]
    assert [t.name for t in select("step,batch")] == ["c", "step", "batch"]
    with pytest.raises(UsageError, match="did you mean 'python'"):
        select("pyton")
    with pytest.raises(UsageError, match="unknown target 'integrators'"):
        select("integrators")          # it follows the outputs
    assert switches(select("fmu")) == Targets(step=True)
    assert switches(select("c"), Targets(step=True)) == Targets(step=True)
    assert switches(select("c")) == Targets()


def _definitions(source):
    return re.findall(r"^static \w+ (\w+)\(", source, re.M)


def test_each_routine_is_emitted_once_and_the_files_compile_strictly(tmp_path):
    """A constrained scene with both targets on: the LU of the constraints, of the projection
    and of Rosenbrock's stages, and the step-size control of both targets, defined once."""
    rendered = run(load_scene("four_bar"), ("rhs", "jacobian", "holonomic",
                                            "holonomic_jacobian", "rosenbrock", "dopri5"),
                   build=False, targets=Targets(step=True)).rendered
    names = _definitions(rendered.source)
    assert len(names) == len(set(names)), names
    for fn in ("lu_factor", "lu_solve", "lu_solve_t", "rms", "initial_step", "ldl"):
        assert f"four_bar_{fn}" in names
    assert "_step_rms" not in rendered.source and "con_lu" not in rendered.source
    for name, text in rendered.files.items():
        (tmp_path / name).write_text(text)
    for tool, flags in ((CC, ["-std=c99"]), (CXX, ["-x", "c++", "-std=c++11"])):
        done = subprocess.run([tool, *flags, "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2",
                               "-c", "four_bar.c", "-o", "m.o"], cwd=tmp_path,
                              capture_output=True, text=True)
        assert done.returncode == 0 and not done.stderr, done.stderr


def test_the_model_includes_the_sections_it_is_given():
    text = (TEMPLATES / "model" / "model.c.j2").read_text()
    for section in SECTIONS:
        assert f'"{section.name}/' not in text, "model.c.j2 names a section's template"
    assert "{% include section %}" in text


@pytest.mark.parametrize("output", INTEGRATORS, ids=lambda o: o.value)
def test_every_integrator_has_its_templates(output):
    T = METHODS[output]
    assert T.output is output and T.label
    for template in (f"integrators/{output.value}.c.j2", f"step/{output.value}.c.j2",
                     f"step/{output.value}.h.j2"):
        assert (TEMPLATES / template).is_file(), template
        environment().get_template(template)


def _kernel(*outputs):
    return SimpleNamespace(integrators=tuple(o for o in INTEGRATORS if o in outputs))


@pytest.mark.parametrize("wanted, methods, adaptive", [
    ((), ("rk4", "dopri5"), "dopri5"),
    ((Output.RK4,), ("rk4", "dopri5"), "dopri5"),
    ((Output.DOPRI5,), ("rk4", "dopri5"), "dopri5"),
    ((Output.ROSENBROCK,), ("rk4", "rosenbrock"), "rosenbrock"),
    ((Output.DOPRI5, Output.ROSENBROCK), ("rk4", "dopri5", "rosenbrock"), "rosenbrock"),
])
def test_step_methods_follow_the_properties(wanted, methods, adaptive):
    """Fixed-step methods always; an adaptive one when asked for; the explicit adaptive
    ones also when no implicit one is; the co-simulation steps with the implicit one."""
    assert step_methods(_kernel(*wanted)) == methods
    assert adaptive_method(_kernel(*wanted)) == adaptive
