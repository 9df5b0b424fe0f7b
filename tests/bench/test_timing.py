"""The benchmarks time the one pipeline: a stage timer hears every stage of ``run`` as it ends
(nothing timed is asserted beyond signs and sums)."""

import ast
from dataclasses import replace
from pathlib import Path

import mbgen.bench
from mbgen import Output
from mbgen.bench.timing import pipeline_timer
from mbgen.derivation import Method
from mbgen.model.scene import load_scene
from mbgen.pipeline import Comparisons, StageTimer, run


def test_a_benchmark_timer_emits_every_stage_and_the_kernel_counts():
    emitted = []
    timer = pipeline_timer(lambda key, value: emitted.append((key, value)), "x_",
                           counts={"ops_after": "x_ops"})
    result = run(load_scene("disc_pendulum"), (Output.RHS,), build=False, method=Method.KANE,
                 timer=timer)
    assert [k for k, _ in emitted] == ["x_derive_s", "x_bake_s", "x_cse_s", "x_ops",
                                       "x_render_s"]
    values = dict(emitted)
    assert values["x_ops"] == result.kernel.ops_after
    assert {k: values[f"x_{k}_s"] for k in result.timings} == result.timings


def test_while_comparing_stages_name_the_method_and_add_up():
    heard = []
    timer = StageTimer(started=lambda name: heard.append(("start", name)),
                       finished=lambda name, seconds, value: heard.append((name, seconds)))
    scene = replace(load_scene("car_trailer"), method=None)
    result = run(scene, (Output.RHS,), build=False, timer=timer, comparisons=Comparisons())
    started = [name for what, name in heard if what == "start"]
    assert started[:3] == ["derive/newton_euler", "bake/newton_euler", "cse/newton_euler"]
    assert "derive/kane" in started and started[-1] == "render"
    derive = [s for name, s in heard if name == "derive"]
    assert len(derive) == 2 and 0 < derive[0] <= derive[1] == result.timings["derive"]
    assert run(scene, (Output.RHS,), build=False, stage=heard.append,
               comparisons=None).timings.keys() == result.timings.keys()


#: The stages as functions: a benchmark that imports one re-types the pipeline.
STAGE_FUNCTIONS = {("mbgen.derivation", "derive"), ("mbgen.pipeline", "equations_of"),
                   ("mbgen.codegen.slicing", "bake"), ("mbgen.codegen.optimize", "optimize"),
                   ("mbgen.codegen.render", "render"), ("mbgen.build.extension", "load")}


def test_benchmarks_run_the_pipeline_rather_than_a_copy_of_its_stages():
    """Only ``bench/stages.py`` (each output's CSE alone, under a budget) calls stages."""
    folder = Path(mbgen.bench.__file__).parent
    calls = {}
    for path in sorted(folder.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        names = {("mbgen." + node.module.lstrip("."), a.name)
                 for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module
                 for a in node.names}
        calls[path.stem] = sorted(name for _, name in names & STAGE_FUNCTIONS)
    assert {stem for stem, found in calls.items() if found} == {"stages"}, calls
