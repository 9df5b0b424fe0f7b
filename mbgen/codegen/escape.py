"""User text into generated files: one small escaping function per context.

Every piece of text a user controls (a model, point or symbol name, a scene's
description, a file path) that reaches a generated file goes through exactly
one of these functions, chosen by where it lands.  Each returns ASCII only,
on one line, and can neither end the construct it sits in nor start a new one:

==================  ==========================================================
``c_comment``       inside ``/* ... */`` (and ``//``) comments
``c_string``        a C string literal, quotes included
``py_comment``      after ``#`` in Python
``py_docstring``    inside a triple-quoted Python docstring
``py_string``       a Python string literal, quotes included
``py_list``         a Python list literal of strings
``xml_attr``        an XML attribute value, quotes excluded
``xml_text``        XML character data
==================  ==========================================================

Control characters (NUL, newlines, ...) and non-ASCII characters become
visible escapes (``\\x00``, ``\\u00e9``), so what the user typed can still be
read in the generated file.  Identifiers are not escaped but checked, where
names enter (:mod:`mbgen.names`).
"""

from __future__ import annotations

__all__ = ["c_comment", "c_string", "py_comment", "py_docstring", "py_list", "py_string",
           "xml_attr", "xml_text", "FILTERS"]


def _visible(ch: str) -> str:
    """Escape one control or non-ASCII character as ``\\xNN``, ``\\uNNNN`` or ``\\UNNNNNNNN``."""
    code = ord(ch)
    if code < 0x100:
        return f"\\x{code:02x}"
    if code < 0x10000:
        return f"\\u{code:04x}"
    return f"\\U{code:08x}"


def _ascii_line(text, extra: dict[str, str]) -> str:
    out = []
    for ch in str(text):
        if ch in extra:
            out.append(extra[ch])
        elif " " <= ch <= "~":
            out.append(ch)
        else:
            out.append(_visible(ch))
    return "".join(out)


def c_comment(text) -> str:
    """``text`` for a C comment: no ``*/`` or ``/*`` can form, no line break, ASCII only.

    A backslash becomes the visible ``\\x5c``, so that no backslash can end
    the line and splice the next one into a ``//`` comment (``\\\\`` would: the
    second backslash still precedes the newline), and ``?`` before ``?`` is
    broken up so that no trigraph (``??/`` is a backslash) forms.
    """
    s = _ascii_line(text, {"\\": "\\x5c"})
    s = s.replace("*/", "*\\/").replace("/*", "/\\*")
    return s.replace("??", "?\\?")


def c_string(text) -> str:
    """``text`` as a C string literal (with its quotes); also valid C++.

    Newline and tab are written ``\\n`` and ``\\t``; other control and
    non-ASCII characters as UTF-8 bytes in fixed-width octal escapes (a hex
    escape would swallow a following hex digit).  A ``%`` is kept: a string
    used as a ``printf`` format must be passed through ``.replace("%", "%%")``
    first.  C99 compilers need only accept literals of 4095 characters
    (``-pedantic`` warns past that), so keep long text out of string literals.
    """
    out = []
    for ch in str(text):
        if ch in '\\"?':
            out.append("\\" + ch)
        elif ch in _C_NAMED:
            out.append(_C_NAMED[ch])
        elif " " <= ch <= "~":
            out.append(ch)
        else:
            out.extend(f"\\{b:03o}" for b in ch.encode("utf-8", "surrogatepass"))
    return '"' + "".join(out) + '"'


_C_NAMED = {"\n": "\\n", "\t": "\\t"}


def py_comment(text) -> str:
    """``text`` for a Python ``#`` comment: one line, ASCII only."""
    return _ascii_line(text, {"\\": "\\\\"})


def py_docstring(text) -> str:
    """``text`` for the inside of a (non-raw) triple-quoted docstring.

    Backslashes and double quotes are escaped, so ``\"\"\"`` cannot end the
    docstring, and the line cannot end in a backslash.
    """
    return _ascii_line(text, {"\\": "\\\\", '"': '\\"'})


def py_string(text) -> str:
    """``text`` as a Python string literal (with its quotes), ASCII only."""
    return ascii(str(text))


def py_list(texts) -> str:
    """``texts`` (strings) as a Python list literal, ``['a', 'b']``, each item by
    :func:`py_string`."""
    return "[" + ", ".join(py_string(t) for t in texts) + "]"


def xml_attr(text) -> str:
    """``text`` for an XML attribute value in double or single quotes (XML 1.0).

    ``&``, ``<``, ``>`` and both quotes become entities, non-ASCII characters
    numeric references; characters XML 1.0 cannot carry at all (NUL and the
    other controls) become visible ``\\xNN`` text.
    """
    out = []
    for ch in str(text):
        if ch in _XML:
            out.append(_XML[ch])
        elif " " <= ch <= "~":
            out.append(ch)
        elif ord(ch) >= 0x80 and not 0xD800 <= ord(ch) <= 0xDFFF and ord(ch) not in (0xFFFE,
                                                                                     0xFFFF):
            out.append(f"&#x{ord(ch):x};")
        else:
            out.append(_visible(ch))
    return "".join(out)


_XML = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&apos;"}


def xml_text(text) -> str:
    """``text`` for XML character data (between tags); same rules as :func:`xml_attr`."""
    return xml_attr(text)


#: The functions above by name, as Jinja filters (``{{ name|c_comment }}`` in a template).
FILTERS = {f.__name__: f for f in (c_comment, c_string, py_comment, py_docstring, py_list,
                                   py_string, xml_attr, xml_text)}
