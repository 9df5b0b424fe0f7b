"""Numbers are finite where they enter: scene options (``-O``), scene fields, model
constants; an option that is not ``KEY=VALUE`` of the right type is refused.
"""

import pytest
import sympy as sm

from mbgen import Scene
from mbgen.cli import EXIT_MODEL, main
from mbgen.errors import ModelError, SceneError
from models import pendulum


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400"])
def test_non_finite_scene_option_is_refused(value, capsys):
    """Issue 9.3: -O stiffness=nan exited 0 and wrote p[2] = inf."""
    assert main(["generate", "stiff_chain", "-O", f"stiffness={value}", "-o", "/nonexistent/x"]) \
        == EXIT_MODEL
    err = capsys.readouterr().err
    assert f"option stiffness={value!r}" in err and "finite" in err  # refused where it enters


@pytest.mark.parametrize("option,why", [("n=2.5", "integer"), ("n=abc", "integer"),
                                        ("n", "KEY=VALUE"), ("=3", "option name")])
def test_bad_option_values(option, why, capsys):
    assert main(["generate", "n_link_cart", "-O", option, "-o", "/nonexistent/x"]) == EXIT_MODEL
    assert why in capsys.readouterr().err


@pytest.mark.parametrize("field,value", [("parameters", {"g": float("inf")}),
                                         ("fixed", {"g": float("nan")}),
                                         ("initial_state", {"q": float("inf")}),
                                         ("parameters", {"g": "9.81"}),
                                         ("t_span", (0.0, float("inf"))),
                                         ("t_span", (1.0, 1.0))])
def test_scene_numbers_are_finite(field, value):
    with pytest.raises(SceneError, match=r"finite|real number|after the start"):
        Scene(name="p", model=pendulum(), **{field: value})


@pytest.mark.parametrize("value", [float("inf"), float("nan"), sm.oo, sm.zoo, sm.Float("1e400")])
def test_model_numbers_are_finite(value):
    m = pendulum()
    with pytest.raises(ModelError, match="finite"):
        m.spring("s", list(m.points)[-1], m.origin, value)
