"""Numeric checks shared by several test files: seeded random states, closeness relative
to the reference's size."""

import numpy as np


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
