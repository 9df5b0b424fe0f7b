"""Hostile and careless input on the way in: names, text, expression strings, numbers, paths.

Every test here names the defect it guards (issue 9 / issue 11); each failed
on the code before the fix (see the commit history).
"""

import ast
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import sympy as sm

from mbgen import Model, Scene
from mbgen.codegen import escape
from mbgen.verify import golden
from mbgen.cli import EXIT_MODEL, EXIT_OK, main
from mbgen.errors import ModelError, ModelSizeError, SceneError
from mbgen.model.kinematics import vec
from mbgen.model.builder import t
from mbgen.model.limits import MAX_BODIES, MAX_SPEEDS
from mbgen.pipeline import run
from mbgen.run.python import python_model
from mbgen.codegen.printing import (CPrinter, NonFiniteConstantError, PyPrinter, power_form,
                                    printed_base_count)
from mbgen.model.scene import load_scene

HOSTILE = [
    '"""; open("PWNED", "w"); """',
    "*/ int pwned; /*",
    "a\nb\r\nc\\",
    "nul\x00byte\x07bell",
    "caf\u00e9 \u03b8 \U0001f600 \ud800",
    "??/ trigraph ??= and a trailing backslash \\",
    "'quotes' \"double\" `back` <xml> & </xml>",
    "x" * 10_000,
]


# ----------------------------------------------------------------- item 1: escaping
@pytest.mark.parametrize("text", HOSTILE, ids=range(len(HOSTILE)))
def test_py_docstring_round_trips_and_cannot_end_the_docstring(text):
    source = f'"""{escape.py_docstring(text)}"""\nx = 1\n'
    tree = ast.parse(source)
    assert len(tree.body) == 2 and ast.get_docstring(tree, clean=False) == text
    assert source.isascii() and "\n" not in escape.py_docstring(text)


@pytest.mark.parametrize("text", HOSTILE, ids=range(len(HOSTILE)))
def test_py_string_py_list_and_py_comment(text):
    assert ast.literal_eval(escape.py_string(text)) == text
    assert ast.literal_eval(escape.py_list([text, "b"])) == [text, "b"]
    comment = escape.py_comment(text)
    tree = ast.parse(f"# {comment}\nx = 1\n")
    assert len(tree.body) == 1 and "\n" not in comment and "\r" not in comment
    assert comment.isascii()


@pytest.mark.parametrize("text", HOSTILE, ids=range(len(HOSTILE)))
def test_xml_attr_and_text_parse_back(text):
    attr, body = escape.xml_attr(text), escape.xml_text(text)
    root = ET.fromstring(f'<a v="{attr}" w=\'{attr}\'>{body}</a>')
    assert root.get("v") == root.get("w") == (root.text or "")
    assert len(root) == 0 and attr.isascii()
    carried = all(" " <= c <= "~" or (ord(c) >= 0x80 and not 0xD800 <= ord(c) <= 0xDFFF)
                  for c in text)
    assert (root.get("v") == text) == carried  # what XML 1.0 can carry comes back exactly


def test_c_comment_and_c_string_compile_and_round_trip(tmp_path):
    """Every hostile text inside a C comment and as a string literal: warning-free C99, and
    the literal's bytes are the text's UTF-8 bytes."""
    lines = ["#include <stdio.h>", "#include <string.h>"]
    for i, text in enumerate(HOSTILE):
        lines.append(f"/* {escape.c_comment(text)} */")
        lines.append(f"// {escape.c_comment(text)}")
        lines.append(f"static const char s{i}[] = {escape.c_string(text[:4000])};")
    lines.append("int main(void) {")
    for i in range(len(HOSTILE)):
        lines.append(f"    fwrite(s{i}, 1, sizeof s{i} - 1, stdout); fputc(0x1e, stdout);")
    lines.append("    return 0;\n}")
    src = tmp_path / "esc.c"
    src.write_text("\n".join(lines) + "\n", encoding="ascii")
    exe = tmp_path / "esc"
    subprocess.run(["cc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-o", str(exe),
                    str(src)], check=True, capture_output=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True).stdout.split(b"\x1e")[:-1]
    assert out == [t[:4000].encode("utf-8", "surrogatepass") for t in HOSTILE]


def _pendulum(name="pendulum"):
    m = Model(name)
    q, = m.coordinates("q")
    m.speeds("u")
    l, g, mass = m.constants("l g m")
    N = m.newtonian()
    B = m.rotate(N, "B", 3, q)
    P = m.point("P", m.origin, -l * B.y)
    m.particle("bob", P, mass)
    m.gravity(-g * N.y)
    return m


def test_hostile_equations_name_generates_python_that_runs_nothing(tmp_path, monkeypatch):
    """Issue 9.1: a name with \"\"\" ended the module docstring; importing ran the code."""
    monkeypatch.chdir(tmp_path)
    hostile = 'x"""; open("PWNED", "w").write("1"); """ */ int pwned; /* \n'
    result = run(_pendulum(), build=False, name=hostile,
                 parameters={"l": 1.0, "g": 9.81, "m": 1.0})
    module = python_model(result.rendered)
    assert not (tmp_path / "PWNED").exists()
    assert ast.get_docstring(ast.parse(result.rendered.python)).startswith(
        f"{result.rendered.prefix}.py -- generated")
    assert module.rhs(0.0, [0.1, 0.0]).shape == (2,)
    assert result.rendered.header.split("*/", 1)[1].startswith("\n#ifndef")
    for name, text in result.rendered.files.items():
        (tmp_path / name).write_text(text)
    subprocess.run(["cc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror",
                    "-fsyntax-only", str(tmp_path / f"{result.rendered.prefix}.c")],
                   check=True, capture_output=True)


SCENE_FILE = '''
from mbgen import Model, Output, Scene

def scene():
    m = Model("pend")
    q, = m.coordinates("q")
    m.speeds("u")
    l, g, mass = m.constants("l g m")
    N = m.newtonian()
    B = m.rotate(N, "B", 3, q)
    P = m.point("P", m.origin, -l * B.y)
    m.particle("bob", P, mass)
    m.gravity(-g * N.y)
    return Scene(name="pend", model=m, parameters={"l": 1.0, "g": 9.81, "m": 1.0},
                 initial_state={"q": 0.1}, t_span=(0.0, 1.0), outputs=(Output.RHS, Output.DOPRI5),
                 description=DESCRIPTION)
'''


def _scene_file(folder: Path, file_name="pend.py", description="a pendulum"):
    path = folder / file_name
    path.write_text(f"DESCRIPTION = {description!r}\n" + SCENE_FILE, encoding="utf-8")
    return path


def test_hostile_scene_file_name_and_description(tmp_path, monkeypatch):
    """Issue 9.1: a scene file whose name holds \"\"\" made code of the generated Python; a
    description with */ ended the C comment of example.c."""
    from mbgen.codegen.targets.example import render_example

    monkeypatch.chdir(tmp_path)
    path = _scene_file(tmp_path, '"""; open("PWNED", "w"); """.py',
                       "*/ #error pwned /* \"\"\" \n\x00")
    scene = load_scene(str(path))
    result = run(scene, build=False)
    python_model(result.rendered)
    assert not (tmp_path / "PWNED").exists()
    files = dict(result.rendered.files, **{"example.c": render_example(scene, result.kernel)})
    out = tmp_path / "out"
    out.mkdir()
    for name, text in files.items():
        (out / name).write_text(text)
    subprocess.run(["cc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror",
                    "-fsyntax-only", str(out / "example.c")], check=True, capture_output=True)
    subprocess.run([sys.executable, "-c", "import pend"], cwd=out, check=True)
    assert not (out / "PWNED").exists() and not (tmp_path / "PWNED").exists()


# ---------------------------------------------------------------- item 2: name rule
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
        Scene(name=bad, model=_pendulum())
    with pytest.raises(SceneError, match="C prefix name"):
        Scene(name="ok", model=_pendulum(), prefix=bad)


# ------------------------------------------------------------ item 3: no eval of user text
def _entry_points(m, code):
    """Every model method that takes a value, called with the string ``code``."""
    q, = m.coordinates("q")
    u, = m.speeds("u")
    k, = m.constants("k")
    N = m.newtonian()
    P = m.point("P", m.origin, q * N.x)
    return {
        "rotate angle": lambda: m.rotate(N, "B", 3, code),
        "particle mass": lambda: m.particle("bob", P, code),
        "body mass": lambda: m.body("rod", N, code, (1, 1, 1), P),
        "body inertia tuple": lambda: m.body("rod", N, 1.0, (code, 1, 1), P),
        "body inertia matrix": lambda: m.body("rod", N, 1.0,
                                              [[code, 0, 0], [0, 1, 0], [0, 0, 1]], P),
        "spring stiffness": lambda: m.spring("s", P, m.origin, code),
        "spring length": lambda: m.spring("s", P, m.origin, 1.0, natural_length=code),
        "damper damping": lambda: m.damper("d", P, m.origin, code),
        "prescribed": lambda: m.prescribed("theta", code),
        "kinematics": lambda: m.kinematics({q: code}),
        "kinematic_equations": lambda: m.kinematic_equations([code]),
        "vec": lambda: vec(N, [code, 0, 0]),
    }


ENTRY_POINTS = list(_entry_points(Model("probe"), "0"))


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_expression_strings_are_never_evaluated(entry, tmp_path):
    """Issue 9.2: sympify(str) evaluated user text; the code ran before any error."""
    target = tmp_path / "PWNED"
    code = f"__import__('builtins').open({str(target)!r}, 'w').write('x')"
    with pytest.raises(ModelError, match="pass a sympy expression|not an allowed function"):
        _entry_points(Model("m"), code)[entry]()
    assert not target.exists()


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_objects_whose_str_is_code_are_not_parsed(entry, tmp_path):
    """sympify(non-strict) falls back to parsing str(obj); strict sympify does not."""
    target = tmp_path / "PWNED"

    class Sneaky:
        def __str__(self):
            return f"__import__('builtins').open({str(target)!r}, 'w')"

    with pytest.raises(ModelError):
        _entry_points(Model("m"), Sneaky())[entry]()
    assert not target.exists()


def test_expression_strings_parse_to_the_models_symbols():
    m = Model("m")
    q, = m.coordinates("q")
    m.speeds("u")
    k, l = m.constants("k l")
    N = m.newtonian()
    B = m.rotate(N, "B", 3, "2*q + sin(k)/3")
    assert m.frames[B].angle == 2 * q + sm.sin(k) / 3
    P = m.point("P", m.origin, q * N.x)
    s = m.spring("s", P, m.origin, "k*l**2", natural_length="sqrt(l) - pi")
    assert s.stiffness == k * l ** 2 and s.natural_length == sm.sqrt(l) - sm.pi
    with pytest.raises(ModelError, match="did you mean 'k'"):
        m.damper("d", P, m.origin, "kk")


@pytest.mark.parametrize("text", ["10**10**10", "9**9**9**9", "sin(" * 150 + "k" + ")" * 150, "-" * 500 + "k",
                                  "1" * 20_000, "k" + "+k" * 6000])
def test_expression_strings_are_bounded(text):
    m = Model("m")
    m.constants("k")
    start = time.perf_counter()
    with pytest.raises(ModelError):
        m.prescribed("theta", text)
    assert time.perf_counter() - start < 5.0


# ------------------------------------------------------------- item 4: numbers where they enter
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
        Scene(name="p", model=_pendulum(), **{field: value})


@pytest.mark.parametrize("value", [float("inf"), float("nan"), sm.oo, sm.zoo, sm.Float("1e400")])
def test_model_numbers_are_finite(value):
    m = _pendulum()
    with pytest.raises(ModelError, match="finite"):
        m.spring("s", list(m.points)[-1], m.origin, value)


@pytest.mark.parametrize("printer", [CPrinter, PyPrinter])
@pytest.mark.parametrize("value", [sm.oo, -sm.oo, sm.zoo, sm.nan, sm.Float("inf"),
                                   sm.Float("1e400")])
def test_printers_never_emit_inf_or_nan(printer, value):
    x = sm.Symbol("x")
    with pytest.raises(NonFiniteConstantError, match="non-finite"):
        printer({x: "x"}).doprint(x + value if value is not sm.nan else value)


def test_power_rule_is_one_function():
    """printing.power_form decides; both printers and the CSE hoisting follow it."""
    from mbgen.codegen.cse import _repeats_base

    x = sm.Symbol("x")
    for exp in [sm.Integer(k) for k in range(-12, 13) if k] + \
               [sm.Rational(k, 2) for k in range(-21, 22, 2)] + [sm.Rational(1, 3), sm.Float(2.5)]:
        power = sm.Pow(x, exp, evaluate=False)
        for printer in (CPrinter({x: "x"}), PyPrinter({x: "x"})):
            text = printer.doprint(power)
            assert text.count("x") == printed_base_count(exp), (exp, text)
            assert ("pow(" in text) == (power_form(exp) is None), (exp, text)
        assert _repeats_base(exp) == (printed_base_count(exp) >= 2)


# ---------------------------------------------------------------- item 5: output paths
def test_generate_defaults_to_mbgen_out_and_never_the_golden_tree(tmp_path, monkeypatch, capsys):
    """Issue 11: generate defaulted to generated/SCENE and overwrote the golden files."""
    monkeypatch.chdir(tmp_path)
    assert main(["generate", "disc_pendulum"]) == EXIT_OK
    assert (tmp_path / "mbgen-out" / "disc_pendulum" / "disc_pendulum.h").is_file()
    assert not (tmp_path / "generated").exists()


def test_regeneration_removes_only_what_it_wrote(tmp_path, capsys):
    """Issue 11: a stale example.c was left behind by a regeneration."""
    out = tmp_path / "out"
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_OK
    assert (out / "example.c").is_file()
    (out / "notes.txt").write_text("mine")
    assert main(["generate", "disc_pendulum", "-o", str(out), "--outputs", "rhs"]) == EXIT_OK
    assert not (out / "example.c").exists()
    assert (out / "notes.txt").read_text() == "mine"
    assert "removed" in capsys.readouterr().out


def test_generate_does_not_overwrite_files_it_did_not_write(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "disc_pendulum.c").write_text("/* my own code */\n")
    assert main(["generate", "disc_pendulum", "-o", str(out)]) == EXIT_MODEL
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "disc_pendulum.c").read_text() == "/* my own code */\n"
    assert not (out / "disc_pendulum.h").exists()
    assert main(["generate", "disc_pendulum", "-o", str(out), "--overwrite"]) == EXIT_OK
    assert "my own code" not in (out / "disc_pendulum.c").read_text()


def test_generate_into_a_file_is_an_error(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    assert main(["generate", "disc_pendulum", "-o", str(target)]) == EXIT_MODEL
    assert "is a file" in capsys.readouterr().err


def test_header_bytes_do_not_depend_on_the_callers_folder(tmp_path, monkeypatch):
    """Issue 11: the header recorded the scene path as typed."""
    (tmp_path / "scenes").mkdir()
    path = _scene_file(tmp_path / "scenes")
    monkeypatch.chdir(tmp_path)
    a = run(load_scene("scenes/pend.py"), build=False).rendered.files
    monkeypatch.chdir(tmp_path / "scenes")
    b = run(load_scene("pend.py"), build=False).rendered.files
    c = run(load_scene(str(path)), build=False).rendered.files
    assert a == b == c
    assert "(pend.py)" in a["pend.h"] and str(tmp_path) not in a["pend.h"]


def test_golden_refuses_outside_a_checkout(tmp_path, monkeypatch, capsys):
    fake = tmp_path / "site-packages" / "mbgen" / "golden.py"
    monkeypatch.setattr(golden, "__file__", str(fake))
    assert main(["golden", "--scenes", "disc_pendulum"]) == EXIT_MODEL
    assert "source checkout" in capsys.readouterr().err
    assert not (tmp_path / "site-packages" / "generated").exists()


def test_golden_update_removes_stale_files(tmp_path):
    root = tmp_path / "generated"
    golden.update(root, ["disc_pendulum"])
    (root / "disc_pendulum" / "old.c").write_text("int stale;\n")
    assert any("unexpected" in d for d in golden.differences(root, ["disc_pendulum"]))
    golden.update(root, ["disc_pendulum"])
    assert not golden.differences(root, ["disc_pendulum"])


# --------------------------------------------------------- item 6: scene names exist in the model
@pytest.mark.parametrize("field,value,hint", [("parameters", {"gg": 1.0}, "did you mean 'g'"),
                                              ("fixed", {"ll": 1.0}, "did you mean 'l'"),
                                              ("initial_state", {"q1": 0.1}, "did you mean 'q'"),
                                              ("inputs", ("F",), "not an input"),
                                              ("points", ("PP",), "did you mean 'P'")])
def test_scene_names_that_do_not_exist(field, value, hint):
    """Issue 11: a scene naming a symbol that does not exist passed until a later command."""
    with pytest.raises(SceneError, match=hint):
        Scene(name="p", model=_pendulum(), **{field: value})


@pytest.mark.parametrize("command", [["generate"], ["check"], ["simulate"], ["linearize"]])
def test_every_command_validates_the_scene_at_load(command, tmp_path, capsys):
    path = _scene_file(tmp_path, "bad.py")
    path.write_text(path.read_text().replace('"l": 1.0', '"ll": 1.0'))
    start = time.perf_counter()
    assert main(command + [str(path)]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert err.startswith("mbgen: error:") and "'ll'" in err and "did you mean 'l'" in err
    assert time.perf_counter() - start < 10


# ---------------------------------------------------------------- item 7: size guards
def test_huge_model_is_refused_before_work_starts(capsys):
    """Issue 9.9: generate n_link_cart -O n=100000 ran until killed."""
    start = time.perf_counter()
    assert main(["generate", "n_link_cart", "-O", "n=100000", "-o", "/nonexistent/x"]) \
        == EXIT_MODEL
    assert time.perf_counter() - start < 10
    err = capsys.readouterr().err
    assert "--force" in err and "100001" in err


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

    eq = derive(_pendulum())
    assert Scene(name="small", model=eq).model is eq
    monkeypatch.setattr(mbgen.model.limits, "MAX_SPEEDS", 0)  # the pendulum's 1 speed is "too many"
    with pytest.raises(ModelSizeError, match="1 speeds, more than 0"):
        Scene(name="big", model=eq)
    with allow_large_models():
        assert Scene(name="big", model=eq).model is eq


@pytest.mark.parametrize("t_end", ["inf", "nan", "-1"])
def test_simulate_refuses_an_infinite_or_backward_span(t_end, capsys, tmp_path):
    """Issue 9.9: simulate --t-end inf ran until killed."""
    assert main(["simulate", "disc_pendulum", "--t-end", t_end, "--csv",
                 str(tmp_path / "x.csv")]) == EXIT_MODEL
    assert "--t-end" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()


def test_expression_parser_agrees_with_python_precedence():
    """Seeded random expressions of the whitelisted grammar: the ast-based parser gives
    sympy's own reading of the same text (precedence, -2**2, right-associative **, a/b/c)."""
    import random

    from mbgen.model.expressions import parse

    rng = random.Random(20261124)
    k, l = sm.symbols("k l")
    table = {"k": k, "l": l}
    atoms = ["k", "l", "2", "3", "0.5", "pi"]
    funcs = ["sin", "cos", "exp", "sqrt", "atan2"]

    def gen(depth):
        if depth == 0 or rng.random() < 0.25:
            return rng.choice(atoms)
        kind = rng.random()
        if kind < 0.55:
            op = rng.choice(["+", "-", "*", "/", "**"])
            right = rng.choice(["2", "3", "-1", "0.5"]) if op == "**" else gen(depth - 1)
            return f"{gen(depth - 1)} {op} {right}"
        if kind < 0.7:
            return f"-{gen(depth - 1)}"
        if kind < 0.85:
            return f"({gen(depth - 1)})"
        f = rng.choice(funcs)
        return f"{f}({gen(depth - 1)}, {gen(depth - 1)})" if f == "atan2" else \
            f"{f}({gen(depth - 1)})"

    checked = 0
    for _ in range(300):
        text = gen(4)
        try:
            expected = sm.sympify(text, locals=dict(table))  # our own generated text: safe
        except (ZeroDivisionError, ValueError, TypeError):
            continue
        if expected.has(sm.zoo, sm.oo, sm.nan):
            continue
        assert sm.simplify(parse(text, table) - expected) == 0, text
        checked += 1
    assert checked > 250
