"""Names that reach generated code, and the one rule every user-given name follows.

The name rule
-------------
Every name a user gives -- a model, frame, point, particle, body, coordinate,
speed, constant, input, prescribed motion, spring, joint, constraint or scene
name -- is checked once, where it enters (:func:`check_name`), against one rule:

    an ASCII letter, then ASCII letters, digits and ``_``; at most
    :data:`MAX_NAME_LENGTH` (64) characters.

So a name can never carry quotes, comment markers, path separators, control or
non-ASCII characters into a generated file or a file name.  A name that breaks
the rule is a :class:`~mbgen.errors.ModelError` that names it and says how to
fix it.  Names that are C, C++ or Python keywords (``int``, ``lambda``) are
allowed for symbols (the generated code renames them, ``int_``) but not for
the model, whose name prefixes every C symbol.

Symbol names of a model appear in generated C and Python (as local variable
names and in comments), and the model name is the prefix of every C symbol.
:func:`identifier` turns names (including those of sympy models imported with
:func:`mbgen.from_sympy`, which never passed through :func:`check_name`) into
identifiers that are valid in C99, C++ and Python, deterministically.

A name that is not known -- a scene field's, an expression's symbol, an input
table's column, a state, parameter or input given by name -- is refused with the
closest known names, by one rule (:func:`did_you_mean`).
"""

from __future__ import annotations

import difflib
import keyword
import re
from collections.abc import Iterable

from .errors import ModelError

#: Reserved words of C99 and C++ (the generated header is also valid C++).
C_KEYWORDS = frozenset(
    """
    auto break case char const continue default do double else enum extern
    float for goto if inline int long register restrict return short signed
    sizeof static struct switch typedef union unsigned void volatile while
    _Bool _Complex _Imaginary
    alignas alignof and and_eq asm bitand bitor bool catch char16_t char32_t
    class compl constexpr const_cast decltype delete dynamic_cast explicit
    export false friend mutable namespace new noexcept not not_eq nullptr
    operator or or_eq private protected public reinterpret_cast static_assert
    static_cast template this thread_local throw true try typeid typename using
    virtual wchar_t xor xor_eq
    """.split()
)

#: Names used by the generated code itself or by the C library it includes (every output's
#: array, :data:`mbgen.abi.OUTPUT_INFO`, among them: tests/codegen/test_outputs.py).
RESERVED = frozenset(
    """
    t x p r out status math np numpy i j k n s d L b A G DT result
    dxdt M F energy J Jp dfdt positions velocities reactions Jr lam fh dfh
    Jc Jt CJ CB CD CW CV CG DC DL LAM PM PP
    sqrt sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh exp exp2 expm1
    log log2 log10 log1p pow fabs abs floor ceil fmod fmin fmax hypot cbrt erf erfc
    tgamma lgamma isfinite isnan isinf copysign round trunc sign
    min max float int len range sum list tuple dict set print object type
    """.split()
)

#: Longest name a user may give (C99 guarantees 63 significant characters; files stay short).
MAX_NAME_LENGTH = 64

NAME_RULE = (f"an ASCII letter followed by ASCII letters, digits or '_', at most "
             f"{MAX_NAME_LENGTH} characters")

_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")


def _shown(name) -> str:
    text = repr(name)
    return text if len(text) <= 80 else f"{text[:60]}...' ({len(str(name))} characters)"


def check_name(name, what: str) -> str:
    """Return ``name`` if it follows the name rule (see the module docstring), else raise.

    ``what`` says what is being named (``"frame"``, ``"model"``, ...) for the message.

    Raises
    ------
    ModelError
        Naming the offending name, what it names, the rule and a suggested fix.
    """
    if not isinstance(name, str):
        raise ModelError(f"the {what} name must be a string, got {type(name).__name__} "
                         f"{_shown(name)}")
    if len(name) > MAX_NAME_LENGTH:
        raise ModelError(f"the {what} name {_shown(name)} is too long: a name is {NAME_RULE}; "
                         f"shorten it")
    if not _NAME.match(name):
        fixed = re.sub(r"[^A-Za-z0-9_]", "_", name.encode("ascii", "replace").decode())
        fixed = fixed if fixed[:1].isalpha() else "n_" + fixed
        raise ModelError(f"the {what} name {_shown(name)} is not allowed: a name is {NAME_RULE}; "
                         f"rename it, e.g. {fixed[:MAX_NAME_LENGTH]!r}")
    return name


def did_you_mean(name, names: Iterable) -> str:
    """``"; did you mean 'c'?"`` (``"; did you mean 'a' or 'b'?"``) for the known ``names``
    closest to the unknown ``name``; ``""`` when none is close.

    Compared without case, so ``'f'`` finds ``'F'`` (a name typed in a shell); up to three,
    the closest first, each at least half alike (:func:`difflib.get_close_matches`
    with ``cutoff=0.5``).  Every "did you mean" of mbgen follows this rule.
    """
    lower: dict[str, str] = {}
    for n in names:
        lower.setdefault(str(n).lower(), str(n))
    close = difflib.get_close_matches(str(name).lower(), list(lower), n=3, cutoff=0.5)
    if not close:
        return ""
    return "; did you mean " + " or ".join(repr(lower[c]) for c in close) + "?"


def model_prefix(name: str) -> str:
    """Return the C prefix for a model called ``name``.

    Characters that cannot appear in a C identifier become ``_``.  A name that
    is a C, C++ or Python keyword is refused rather than renamed, because the
    prefix is the public face of the generated ABI.

    Raises
    ------
    ModelError
        If ``name`` is empty, a keyword, or starts with a digit.
    """
    if not isinstance(name, str) or not name.strip():
        raise ModelError("the model name must be a non-empty string, e.g. Model('pendulum')")
    prefix = re.sub(r"[^A-Za-z0-9_]", "_", name.strip())
    if prefix[0].isdigit():
        raise ModelError(f"model name {name!r} starts with a digit; C identifiers cannot. "
                         f"Rename it, e.g. 'm_{prefix}'.")
    if prefix in C_KEYWORDS or keyword.iskeyword(prefix):
        raise ModelError(f"model name {name!r} is a C/C++/Python keyword and cannot prefix "
                         f"generated symbols; rename it, e.g. '{prefix}_model'.")
    if prefix.startswith("__"):
        raise ModelError(f"model name {name!r} starts with '__', which C reserves; rename it.")
    return prefix


def identifier(name: str) -> str:
    """Turn a symbol name into an identifier valid in C99, C++ and Python.

    ``theta.1`` becomes ``theta_1``, a keyword such as ``int`` or ``lambda``
    becomes ``int_``, a leading digit gets a ``s_`` prefix.  Names that clash
    with the generated code's own locals get a trailing ``_``.
    """
    ident = re.sub(r"[^A-Za-z0-9_]", "_", str(name))
    if not ident or ident[0].isdigit():
        ident = "s_" + ident
    while (ident in C_KEYWORDS or keyword.iskeyword(ident) or ident in RESERVED
           or ident.startswith("__")):
        ident = ident.lstrip("_") + "_" if ident.startswith("__") else ident + "_"
    return ident


def unique_identifiers(names: list[str]) -> list[str]:
    """Sanitise ``names`` with :func:`identifier`, refusing collisions.

    Raises
    ------
    ModelError
        If two different names map to the same identifier (``a.b`` and ``a_b``).
    """
    out = [identifier(n) for n in names]
    seen: dict[str, str] = {}
    for original, ident in zip(names, out):
        if ident in seen and seen[ident] != original:
            raise ModelError(f"symbols {seen[ident]!r} and {original!r} both become the C "
                             f"identifier {ident!r}; rename one of them.")
        seen[ident] = original
    return out

