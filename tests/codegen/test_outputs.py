"""Every output is one row of ``mbgen.abi.OUTPUT_INFO``, and one builder in each stage.

An expression output (``mbgen.abi.EXPRESSION_OUTPUTS``) has one ``OutputInfo`` row (its
array, shape, description, needs and ``wrt``) and exactly one row in each builder table:
``mbgen.codegen.outputs.BUILDERS`` (what the generated function computes),
``mbgen.runtime.lambdified.REFERENCES`` (the reference) and an accessor line in
``mbgen.runtime.base.ModelBase``.  What it needs of the equations and what a sensitivity
differentiates by are read from the row (``mbgen.symbolic.availability``); the table of
``docs/modelling.md`` is the rows' (a failure prints the table they give).
"""

import ast
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

import mbgen
from mbgen.abi import EXPRESSION_OUTPUTS, INTEGRATORS, OUTPUT_INFO, Need, Output
from mbgen.codegen import outputs as codegen_outputs
from mbgen.codegen.outputs import BUILDERS, spec
from mbgen.errors import ModelError
from mbgen.names import RESERVED, identifier
from mbgen.runtime import base, lambdified
from mbgen.runtime.lambdified import REFERENCES
from mbgen.symbolic.availability import (
    CONDITIONS,
    REQUIREMENTS,
    SENSITIVITIES,
    applicable,
    applies,
    dynamic_parameters,
)

ROOT = Path(__file__).resolve().parents[2]
#: docs/modelling.md's table of outputs starts after this line
DOCS_MARK = "<!-- The rows below are mbgen.abi.OUTPUT_INFO's"


def _keys(module, table: str) -> list[str]:
    """The ``Output.<NAME>`` keys of the dict literal ``table`` in ``module``'s source, as
    written (a duplicate key would be lost in the dict itself)."""
    for node in ast.walk(ast.parse(inspect.getsource(module))):
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and isinstance(node.value, ast.Dict):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == table for t in targets):
                return [k.attr for k in node.value.keys]
    raise AssertionError(f"no dict literal {table} in {module.__name__}")


def _rows() -> list[str]:
    """The outputs of the ``OutputInfo(Output.<NAME>, ...)`` rows in mbgen/abi.py, as written."""
    return [node.args[0].attr for node in ast.walk(ast.parse(inspect.getsource(mbgen.abi)))
            if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "OutputInfo"]


def _accessor_lines() -> dict[str, str]:
    """``{attribute: output name}`` of the ``<name> = _accessor(Output.<NAME>)`` lines."""
    cls = next(n for n in ast.walk(ast.parse(inspect.getsource(base)))
               if isinstance(n, ast.ClassDef) and n.name == "ModelBase")
    lines = [(n.targets[0].id, n.value.args[0].attr) for n in cls.body
             if isinstance(n, ast.Assign) and isinstance(n.value, ast.Call)
             and getattr(n.value.func, "id", "") == "_accessor"]
    assert len({a for a, _ in lines}) == len(lines), lines
    return dict(lines)


def test_every_output_has_one_row_and_one_builder_in_each_table():
    expression = sorted(o.name for o in EXPRESSION_OUTPUTS)
    assert sorted(_rows()) == expression
    assert sorted(_keys(codegen_outputs, "BUILDERS")) == expression
    assert sorted(_keys(lambdified, "REFERENCES")) == expression
    accessors = _accessor_lines()
    assert sorted(accessors.values()) == expression
    for attribute, name in accessors.items():
        assert attribute == Output[name].value, (attribute, name)
    for output in INTEGRATORS:
        assert output not in OUTPUT_INFO and output not in BUILDERS
        assert output not in REFERENCES and not hasattr(base.ModelBase, output.value)


@pytest.mark.parametrize("output", EXPRESSION_OUTPUTS, ids=lambda o: o.value)
def test_every_expression_output_has_a_spec_a_reference_and_an_accessor(output):
    assert OUTPUT_INFO[output].output is output
    assert callable(BUILDERS[output]) and callable(REFERENCES[output])
    for model in (mbgen.CompiledModel, mbgen.PythonModel, mbgen.LambdifiedModel):
        assert callable(getattr(model, output.value, None)), (model, output)


def test_what_the_stages_read_of_an_output_comes_from_its_row():
    assert set(CONDITIONS) == set(Need)
    for output, row in OUTPUT_INFO.items():
        assert REQUIREMENTS.get(output, ()) == tuple(CONDITIONS[n] for n in row.needs)
        assert (output in SENSITIVITIES) == bool(row.wrt)
        # plain text that ends without a period: a C comment, a docstring and a table cell
        for text in (row.doc, row.note):
            assert text.isascii() and "|" not in text and not text.endswith("."), text
    arrays = [row.array for row in OUTPUT_INFO.values()]
    assert len(set(arrays)) == len(arrays)
    # a symbol named like an array is renamed (a parameter "Jr" once overwrote df/dr's array)
    assert set(arrays) <= RESERVED and identifier("Jr") == "Jr_"


def _docs_table() -> list[str]:
    """The rows of the outputs' table in docs/modelling.md, as the rows give them."""
    return [f"| `{o.name}` | `{o.value}` | {row.doc}{'. ' + row.note if row.note else ''} | "
            f"`{row.shape_text}` |" for o, row in OUTPUT_INFO.items()]


def test_the_docs_table_is_the_rows():
    text = (ROOT / "docs" / "modelling.md").read_text(encoding="utf-8")
    after = text.split(DOCS_MARK, 1)[1].splitlines()[1:]
    table = [line for line in after[:2 + len(OUTPUT_INFO)]]
    expected = _docs_table()
    assert table[2:] == expected, ("docs/modelling.md, 'Outputs and their shapes': the table "
                                   "rows should read\n" + "\n".join(expected))


@pytest.fixture(scope="module", params=["spring_pendulum", "four_bar", "rolling_disc"])
def equations(request):
    """Unconstrained; configuration constraints; motion constraints only (no holonomic)."""
    return mbgen.equations_of(mbgen.load_scene(request.param), reactions=True)


def _sizes(eq) -> dict[str, int]:
    """The sizes an ``OutputInfo.shape`` names, of ``eq``."""
    L, c = eq.layout, eq.constraints
    return dict(n_x=L.n_x, n_q=L.n_q, n_u=L.n_u, n_d=L.n_d, n_p=L.n_p, n_r=L.n_r,
                n_pd=len(dynamic_parameters(eq)),
                m=c.m if c else 0, m_h=c.m_h if c else 0, k=len(eq.points),
                n_joints=len(eq.reactions.names) if eq.reactions else 0)


def _term(text: str, sizes) -> int:
    """``3``, ``n_u`` or ``2*n_u``: a number, a size, or a number times a size."""
    factor, _, name = text.rpartition("*")
    value = int(name) if name.isdigit() else sizes[name]
    return value * (int(factor) if factor else 1)


def _shape(row, sizes) -> tuple[int, ...]:
    return tuple(sum(_term(t, sizes) for t in re.split(r"\s*\+\s*", entry))
                 for entry in row.shape)


def test_the_rows_say_the_shape_and_the_comment_of_the_spec(equations):
    sizes = _sizes(equations)
    for output in applicable(equations):
        s = spec(equations, output)
        row = OUTPUT_INFO[output]
        assert _shape(row, sizes) == s.out_shape, output
        assert s.out_name == row.array and s.doc.endswith("."), output


def test_spec_reference_and_applicable_agree(equations):
    offered = applicable(equations)
    assert offered == tuple(o for o in EXPRESSION_OUTPUTS if applies(equations, o))
    assert mbgen.LambdifiedModel(equations).outputs == offered
    for output in EXPRESSION_OUTPUTS:
        if output in offered:
            continue
        failed = next(r for r in REQUIREMENTS[output] if not r.holds(equations))
        with pytest.raises(ModelError) as err:
            spec(equations, output)
        assert str(err.value) == failed.message(equations, output)


def test_the_reference_has_the_shape_of_the_spec(equations):
    """Cheap outputs of each kind: a solve, a plain block, the constraint rows."""
    reference = mbgen.LambdifiedModel(equations)
    L = equations.layout
    x = np.random.default_rng(0).uniform(-0.5, 0.5, L.n_x)
    p = np.ones(L.n_p)
    for output in (Output.RHS, Output.MASS_MATRIX, Output.ENERGY, Output.CONSTRAINT_FORCES,
                   Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN, Output.POSITIONS):
        if output in reference.outputs:
            value = getattr(reference, output.value)(0.1, x, p)
            assert value.shape == spec(equations, output).out_shape, output


def test_an_output_the_equations_cannot_give_is_not_offered():
    """A model with motion constraints only has no configuration constraints to evaluate."""
    eq = mbgen.equations_of(mbgen.load_scene("rolling_disc"))
    assert eq.constraints.m_h == 0
    reference = mbgen.LambdifiedModel(eq, (Output.RHS, Output.HOLONOMIC))
    assert reference.outputs == (Output.RHS,)
    with pytest.raises(mbgen.MbgenError, match="was not generated"):
        reference.holonomic(0.0, np.zeros(eq.layout.n_x), np.ones(eq.layout.n_p))
