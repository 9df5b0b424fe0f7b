"""Size guards: a model past ``MAX_SPEEDS`` or ``MAX_BODIES`` is refused before work
starts (on the command line too), unless forced; equations from elsewhere are checked
when a scene holds them.
"""

import pytest
import sympy.physics.vector as spv

from mbgen import Model, Scene
from mbgen.cli import EXIT_MODEL, main
from mbgen.errors import ModelSizeError
from mbgen.model.limits import MAX_BODIES, MAX_SPEEDS
from mbgen.model.scene import load_scene
from models import pendulum


def test_huge_model_is_refused_before_work_starts(capsys, monkeypatch):
    """Issue 9.9: generate n_link_cart -O n=100000 ran until killed.  Refused at the first
    declaration, before sympy made a single one of its 100,001 symbols (counted, not
    timed)."""
    made = []
    dynamicsymbols = spv.dynamicsymbols

    def counting(names, *args, **kwargs):
        out = dynamicsymbols(names, *args, **kwargs)
        made.append(len(out) if isinstance(out, (list, tuple)) else 1)
        return out

    counting._t, counting._str = dynamicsymbols._t, dynamicsymbols._str
    monkeypatch.setattr(spv, "dynamicsymbols", counting)
    assert main(["generate", "n_link_cart", "-O", "n=100000", "-o", "/nonexistent/x"]) \
        == EXIT_MODEL
    err = capsys.readouterr().err
    assert "--force" in err and "100001" in err
    assert made == []


def test_size_guard_can_be_forced():
    with pytest.raises(ModelSizeError):
        Model("big").speeds(f"u:{MAX_SPEEDS + 1}")
    m = Model("big", force=True)
    assert len(m.speeds(f"u:{MAX_SPEEDS + 1}")) == MAX_SPEEDS + 1
    m = Model("big2")
    m.speeds(f"u:{MAX_SPEEDS}")
    with pytest.raises(ModelSizeError, match="force=True"):
        m.speeds("extra")
    m = Model("many")
    N = m.newtonian()
    for i in range(MAX_BODIES):
        m.particle(f"p{i}", m.origin, 1.0)
    with pytest.raises(ModelSizeError, match="particles and bodies"):
        m.body("one_more", N, 1.0, (1, 1, 1), m.origin)
    scene = load_scene("n_link_cart", n=MAX_SPEEDS, force=True)
    assert len(scene.model.speeds_) == MAX_SPEEDS + 1
    with pytest.raises(ModelSizeError):
        load_scene("n_link_cart", n=MAX_SPEEDS)


def test_size_guard_for_derived_equations(monkeypatch):
    """Equations from elsewhere (from_sympy) are checked when a scene holds them."""
    import mbgen.model.limits
    from mbgen import derive
    from mbgen.model.limits import allow_large_models

    eq = derive(pendulum())
    assert Scene(name="small", model=eq).model is eq
    monkeypatch.setattr(mbgen.model.limits, "MAX_SPEEDS", 0)  # the pendulum's 1 speed is "too many"
    with pytest.raises(ModelSizeError, match="1 speeds, more than 0"):
        Scene(name="big", model=eq)
    with allow_large_models():
        assert Scene(name="big", model=eq).model is eq
