"""One rule for every name a user gives, and scene names that exist in the model.

Models, frames, points, bodies, symbols, line elements, joints, constraints and
prescribed motions: an ASCII letter first, bounded length, a named error otherwise;
a scene name or C prefix is never a path; a scene's fields name what the model has,
with a "did you mean".
"""

import pytest

from mbgen import Model, Scene
from mbgen.errors import ModelError, SceneError
from mbgen.model.builder import t
from models import pendulum

# (symbols are declared in sympy's syntax, where a space separates names: "x y" is two
# valid names there, and "" none -- both covered by the other kinds)
BAD_NAMES = ['a"b', "../x", "1x", "caf\u00e9", "a*/b", "x" * 65, "n" * 5000]
KINDS = ["model", "frame", "point", "particle", "body", "coordinate", "speed", "constant",
         "input", "spring", "joint", "constraint", "prescribed"]


@pytest.mark.parametrize("what,bad", [(w, b) for w in KINDS for b in BAD_NAMES] +
                         [(w, b) for w in KINDS[:5] + KINDS[9:] for b in ("", "x y")])
def test_every_user_name_follows_one_rule(what, bad):
    m = Model("ok") if what != "model" else None
    noun = {"spring": "line element", "prescribed": "prescribed motion"}.get(what, what)
    with pytest.raises(ModelError, match=f"the {noun} name") as info:
        if what == "model":
            Model(bad)
        elif what in ("coordinate", "speed", "constant", "input"):
            getattr(m, what + "s")(bad)
        else:
            q, = m.coordinates("q")
            u, = m.speeds("u")
            N = m.newtonian()
            if what == "frame":
                m.rotate(N, bad, 3, q)
            elif what == "point":
                m.point(bad, m.origin, q * N.x)
            elif what == "particle":
                m.particle(bad, m.point("P", m.origin, q * N.x), 1.0)
            elif what == "body":
                m.body(bad, m.rotate(N, "B", 3, q), 1.0, (1, 1, 1), m.origin)
            elif what == "spring":
                m.spring(bad, m.point("P", m.origin, q * N.x), m.origin, 1.0)
            elif what == "joint":
                m.particle("bob", m.point("P", m.origin, q * N.x), 1.0)
                m.joint("bob", name=bad)
            elif what == "constraint":
                m.nonholonomic([u], [u], names=[bad])
            elif what == "prescribed":
                m.prescribed(bad, 2 * t)
    assert "ASCII letter" in str(info.value)


def test_five_thousand_character_name_is_a_model_error_not_oserror():
    """Issue 9.9: a 5,000-character name ended in OSError: File name too long."""
    with pytest.raises(ModelError, match="too long.*5000 characters|5000 characters.*too long"):
        Model("n" * 5000)


def test_symbol_names_with_odd_characters_are_refused_where_declared():
    m = Model("ok")
    for empty in ("", " ", ","):
        with pytest.raises(ModelError, match="no coordinate names"):
            m.coordinates(empty)
    for bad in ('a"b', "x-y", "\u03b8"):
        with pytest.raises(ModelError, match=repr(bad).strip("'")):
            m.constants(bad)


@pytest.mark.parametrize("bad", ["../../x", "/tmp/abs", "a b", "x" * 65])
def test_scene_name_cannot_be_a_path(bad):
    """Issue 9.6: Scene(name='../../x') made generate write outside its folder."""
    with pytest.raises(SceneError, match="scene name"):
        Scene(name=bad, model=pendulum())
    with pytest.raises(SceneError, match="C prefix name"):
        Scene(name="ok", model=pendulum(), prefix=bad)


@pytest.mark.parametrize("field,value,hint", [("parameters", {"gg": 1.0}, "did you mean 'g'"),
                                              ("fixed", {"ll": 1.0}, "did you mean 'l'"),
                                              ("initial_state", {"q1": 0.1}, "did you mean 'q'"),
                                              ("inputs", ("F",), "not an input"),
                                              ("points", ("PP",), "did you mean 'P'")])
def test_scene_names_that_do_not_exist(field, value, hint):
    """Issue 11: a scene naming a symbol that does not exist passed until a later command."""
    with pytest.raises(SceneError, match=hint):
        Scene(name="p", model=pendulum(), **{field: value})
