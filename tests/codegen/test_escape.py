"""Hostile text cannot escape where the generator writes it.

Python docstrings, strings and comments, C comments and string literals, XML attributes
and text round-trip every hostile text; a model name or a scene file name and
description made of code generate Python that runs nothing and C that compiles.
"""

import ast
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from mbgen.codegen import escape
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.python import python_model
from models import pendulum, scene_file

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


def test_hostile_equations_name_generates_python_that_runs_nothing(tmp_path, monkeypatch):
    """Issue 9.1: a name with \"\"\" ended the module docstring; importing ran the code."""
    monkeypatch.chdir(tmp_path)
    hostile = 'x"""; open("PWNED", "w").write("1"); """ */ int pwned; /* \n'
    result = run(pendulum(), build=False, name=hostile,
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


def test_hostile_scene_file_name_and_description(tmp_path, monkeypatch):
    """Issue 9.1: a scene file whose name holds \"\"\" made code of the generated Python; a
    description with */ ended the C comment of example.c."""
    from mbgen.codegen.targets.example import render_example

    monkeypatch.chdir(tmp_path)
    path = scene_file(tmp_path, '"""; open("PWNED", "w"); """.py',
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
