"""Checks shared by several test files: seeded random states, closeness relative to the
reference's size, and generated C compiled strictly as C99 and C++11."""

import shutil
import subprocess

import numpy as np

#: The C and C++ compilers the strict compile uses.
CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++") or shutil.which("c++")


def random_states(n: int, k: int = 5, seed: int = 0, scale: float = 1.0) -> np.ndarray:
    """``(k, n)`` states uniform in ``[-scale, scale]``, seeded (row by row the same numbers
    as ``k`` draws of ``n``)."""
    return np.random.default_rng(seed).uniform(-scale, scale, (k, n))


def close(a, b, rtol: float = 1e-12) -> bool:
    """``max|a - b| <= rtol * max(1, max|b|)``: relative to the reference's size, absolute
    near zero."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and \
        bool(np.max(np.abs(a - b)) <= rtol * max(1.0, np.max(np.abs(b))))


def assert_close(a, b, rtol: float = 1e-9) -> None:
    """:func:`close`, or an AssertionError that shows both."""
    assert close(a, b, rtol), (np.asarray(a), np.asarray(b))


def assert_compiles_strictly(files: dict, prefix: str, folder) -> None:
    """``files`` written into ``folder``; ``<prefix>.c`` compiles without a word as C99 and as
    C++11 under ``-pedantic -Wall -Wextra -Werror -Wshadow -O2``."""
    for name, text in files.items():
        (folder / name).write_text(text)
    for tool, flags in ((CC, ["-std=c99"]), (CXX, ["-x", "c++", "-std=c++11"])):
        done = subprocess.run([tool, *flags, "-pedantic", "-Wall", "-Wextra", "-Werror",
                               "-Wshadow", "-O2", "-c", f"{prefix}.c", "-o", "m.o"], cwd=folder,
                              capture_output=True, text=True)
        assert done.returncode == 0 and not done.stderr, done.stderr
