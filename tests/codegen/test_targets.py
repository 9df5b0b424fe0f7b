"""Targets and integrators as data: every registry row has its templates, and what is
rendered is chosen from the rows' properties."""

from pathlib import Path
from types import SimpleNamespace

import pytest

from mbgen.abi import INTEGRATORS, Output
from mbgen.codegen.targets import SECTIONS, TARGETS
from mbgen.codegen.targets.base import EXTENSION, HEADER, SOURCE
from mbgen.codegen.targets.step import adaptive_method, step_methods
from mbgen.codegen.templating import environment
from mbgen.integrators import METHODS

TEMPLATES = Path(__file__).resolve().parents[2] / "templates"
#: Template folders that belong to no target (loaded by mbgen.bench).
OTHER_FOLDERS = {"bench"}


@pytest.mark.parametrize("target", TARGETS, ids=lambda t: t.name)
def test_every_target_has_its_templates(target):
    assert (TEMPLATES / target.name).is_dir()
    for template, where in target.templates("demo"):
        assert template.startswith(f"{target.name}/")
        assert (TEMPLATES / template).is_file(), template
        environment().get_template(template)        # parses
        assert where in (HEADER, SOURCE, EXTENSION) or "demo" in where or "." in where


def test_every_template_folder_is_a_target():
    folders = {p.name for p in TEMPLATES.iterdir() if p.is_dir() and p.name != "__pycache__"}
    assert folders == {t.name for t in TARGETS} | OTHER_FOLDERS
    assert len({t.name for t in TARGETS}) == len(TARGETS)
    assert set(SECTIONS) <= set(TARGETS)


def test_the_model_includes_the_sections_it_is_given():
    text = (TEMPLATES / "model" / "model.c.j2").read_text()
    for target in SECTIONS:
        assert f'"{target.name}/' not in text, "model.c.j2 names a section's template"
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
