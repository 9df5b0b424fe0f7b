"""The header's stack bounds: every target states those of its public functions and every
runtime routine the bound of one call (``mbgen.codegen.header`` gives the units); gcc's
``-fstack-usage`` along the deepest call chain must stay under each."""

import shutil

import pytest

import mbgen.codegen.targets.model
from cstack import call_graph, deepest, stack_usage
from mbgen.codegen import tree_solve
from mbgen.codegen.header import FRAME_BYTES, frame
from mbgen.codegen.targets import Targets
from mbgen.model.scene import load_scene
from mbgen.pipeline import run

CC = shutil.which("gcc") or shutil.which("cc")

#: (scene, options, outputs or None for the scene's): the built-in shapes, a constrained
#: scene whose LU and step-size control both targets share, and (UNROLL_MAX lowered) the
#: row-wise column solve of the sensitivities.
CASES = {
    "disc_pendulum": ("disc_pendulum", {}, None),
    "stiff_chain": ("stiff_chain", {}, None),
    "n_link_cart": ("n_link_cart", {}, None),
    "four_bar": ("four_bar", {}, None),
    "slider_crank": ("slider_crank", {}, None),
    "four_bar_shared": ("four_bar", {}, ("rhs", "jacobian", "holonomic", "holonomic_jacobian",
                                         "rosenbrock", "dopri5")),
    "columns": ("n_link_cart", {"n": 3}, ("rhs", "jacobian", "parameter_jacobian", "dopri5")),
}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("opt", ["-O0", "-O2"])
def test_stack_bounds_hold(case, opt, tmp_path, monkeypatch):
    """gcc's stack usage along the deepest call chain of each public function stays under the
    bound the header states (-O0: every local in its own slot; -O2: inlining and spills)."""
    name, options, outputs = CASES[case]
    if case == "columns":   # the dense loops, not the tree's column solve
        monkeypatch.setattr(mbgen.codegen.targets.model, "UNROLL_MAX", 1)
        monkeypatch.setattr(tree_solve, "TREE_FILL", 0.0)
        monkeypatch.setattr(tree_solve, "TREE_DENSE_MAX", 0)
    rendered = run(load_scene(name, **options), outputs, build=False,
                   targets=Targets(step=True)).rendered
    if case == "columns":
        assert f"{rendered.prefix}_ldl_solve_columns(" in rendered.source
    usage = stack_usage(CC, tmp_path, rendered.files, opt)
    graph = call_graph(rendered.source)
    bounds = dict(rendered.stack_bounds)
    assert set(bounds) <= set(usage) and set(bounds) <= set(graph)
    for fn, bound in bounds.items():
        macro = f"{rendered.prefix.upper()}_STACK_{fn[len(rendered.prefix) + 1:].upper()}"
        assert f"#define {macro} {bound}\n" in rendered.header
        graph_o2 = {f: {c for c in cs if c in usage} for f, cs in graph.items()}  # inlined: gone
        assert deepest(fn, usage, graph_o2) <= bound, (fn, deepest(fn, usage, graph_o2), bound)


def test_a_frame_is_its_locals_over_the_allowance():
    assert frame() == FRAME_BYTES and frame(2, 3) == FRAME_BYTES + 2 * 8 + 3 * 4
