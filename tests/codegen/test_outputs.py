"""Every output is one row in each table that holds outputs, and the tables agree.

An expression output (``mbgen.abi.EXPRESSION_OUTPUTS``) has an ``OutputDef`` row
(``mbgen.codegen.outputs.OUTPUTS``: what the generated function computes), a
reference row (``mbgen.runtime.lambdified.REFERENCES``) and an accessor on every
runtime model; what it needs of the equations is its row of
``mbgen.symbolic.availability.REQUIREMENTS``, which the code generator and the
reference both read.
"""

import numpy as np
import pytest

import mbgen
from mbgen.abi import EXPRESSION_OUTPUTS, INTEGRATORS, Output
from mbgen.codegen.outputs import OUTPUTS, spec
from mbgen.errors import ModelError
from mbgen.runtime.lambdified import REFERENCES
from mbgen.symbolic.availability import REQUIREMENTS, SENSITIVITIES, applicable, applies


@pytest.mark.parametrize("output", EXPRESSION_OUTPUTS, ids=lambda o: o.value)
def test_every_expression_output_has_a_spec_a_reference_and_an_accessor(output):
    assert OUTPUTS[output].output is output
    assert callable(REFERENCES[output])
    for model in (mbgen.CompiledModel, mbgen.PythonModel, mbgen.LambdifiedModel):
        assert callable(getattr(model, output.value, None)), (model, output)


def test_the_tables_hold_expression_outputs_only():
    for table in (OUTPUTS, REFERENCES, REQUIREMENTS, SENSITIVITIES):
        assert set(table) <= set(EXPRESSION_OUTPUTS)
        assert not set(table) & set(INTEGRATORS)
    assert set(OUTPUTS) == set(REFERENCES) == set(EXPRESSION_OUTPUTS)


@pytest.fixture(scope="module", params=["spring_pendulum", "four_bar", "rolling_disc"])
def equations(request):
    """Unconstrained; configuration constraints; motion constraints only (no holonomic)."""
    return mbgen.equations_of(mbgen.load_scene(request.param), reactions=True)


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
