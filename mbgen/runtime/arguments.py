"""Argument checks of the runtime: numbers, vectors, output times and step limits.

Called off the fast path only (a call whose arguments are not already a float
``t`` and contiguous float64 arrays of the right length), so they may take
their time.  Each failure is an :class:`~mbgen.errors.ArgumentError` (a
``ValueError``) naming the argument, or an :class:`~mbgen.errors.ArgumentTypeError`
(also a ``TypeError``) for a value of the wrong kind.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..errors import ArgumentError, ArgumentTypeError

F64 = np.dtype(np.float64)
#: Largest ``max_steps`` the C integrators take (their ``long``; 64-bit Unix).
LONG_MAX = 2**63 - 1


def real_number(value, what: str) -> float:
    """``value`` as a double: a Python or NumPy real (or a 0-d real array).

    Raises ArgumentTypeError for a complex, string, ``None`` ... and ArgumentError for
    an integer or fraction too large for a double (``10**400``).
    """
    if value.__class__ is float:
        return value
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value[()]
    if not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{what} must be a real number (int, float or a NumPy real); "
                                f"got {type(value).__name__} {value!r:.80}")
    try:
        return float(value)
    except OverflowError:
        raise ArgumentError(f"{what} = {value!r:.40} is too large for a double "
                            f"(|value| > 1.8e308); pass a finite float") from None


def tolerance(value, what: str) -> float:
    """A tolerance: a finite real number >= 0 (ArgumentError naming ``what`` otherwise; NaN
    would accept anything, ``res > nan`` being false, and infinity everything)."""
    v = real_number(value, what)
    if not (math.isfinite(v) and v >= 0):
        raise ArgumentError(f"{what} must be a finite number >= 0; got {value!r:.40}")
    return v


def real_vector(value, n: int, what: str, names) -> np.ndarray:
    """``value`` as a new C-contiguous float64 array of shape ``(n,)``, or a named error."""
    try:
        a = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise ArgumentError(f"{what} must be a 1-D array of {n} numbers {list(names)}: "
                            f"{exc}") from None
    if a.dtype.kind not in "iuf":
        raise ArgumentTypeError(f"{what} must hold real numbers (float64); got dtype {a.dtype}")
    if a.shape != (n,):
        raise ArgumentError(f"{what} must have shape ({n},) for {list(names)}; got shape "
                            f"{a.shape}")
    return np.ascontiguousarray(a, dtype=F64)


def times(t_eval) -> np.ndarray:
    """Output times: a 1-D array of finite, strictly increasing reals (at most 2**31 - 1)."""
    try:
        t = np.asarray(t_eval)
    except Exception:
        raise ArgumentError(f"t_eval must be a 1-D array of increasing times; got "
                            f"{t_eval!r:.80}") from None
    if t.dtype.kind not in "iuf" and not (t.dtype.kind == "O" and t.size and all(
            isinstance(v, numbers.Real) for v in t.flat)):
        raise ArgumentTypeError(f"t_eval must hold real numbers; got dtype {t.dtype} "
                                f"({t_eval!r:.80})")
    try:
        t = t.astype(F64)
    except OverflowError:
        raise ArgumentError(f"t_eval holds a number too large for a double: {t_eval!r:.80}") \
            from None
    if t.ndim != 1 or t.size < 1:
        raise ArgumentError(f"t_eval must be a 1-D array of at least one time; got shape "
                            f"{t.shape}")
    if not np.all(np.isfinite(t)):
        raise ArgumentError("t_eval must hold finite times")
    if t.size > 2**31 - 1:
        raise ArgumentError("t_eval has too many times for the C integrator (int n_out)")
    with np.errstate(over="ignore"):  # [-1e308, 1e308]: the difference is inf, still > 0
        steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise ArgumentError(f"t_eval must be strictly increasing; t_eval[{i + 1}] = "
                            f"{t[i + 1]!r} follows t_eval[{i}] = {t[i]!r}")
    return t


def whole_number(value, name: str, low: int = 1, high: int | None = None) -> int:
    """``value`` as a whole number in ``[low, high]``, or an error naming ``name``.

    Raises
    ------
    ArgumentTypeError
        Not an integer (a float such as 2.5 or 2.0, a string, a bool).
    ArgumentError
        Out of range.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ArgumentTypeError(f"{name} must be a whole number (int); got "
                                f"{type(value).__name__} {value!r:.40}")
    if value < low:
        raise ArgumentError(f"{name}={value} must be at least {low}")
    if high is not None and value > high:
        raise ArgumentError(f"{name}={value:,} is more than {high:,}; ask for fewer")
    return int(value)


def step_count(value, what: str = "max_steps", limit: int = LONG_MAX) -> int:
    """A step limit: an integer (or integral float) in ``[0, limit]``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{what} must be an integer >= 0 (0: the default); got "
                                f"{type(value).__name__} {value!r:.40}")
    if isinstance(value, numbers.Integral):
        v = int(value)
    else:
        f = float(value)
        if not (np.isfinite(f) and f.is_integer()):
            raise ArgumentError(f"{what} must be an integer >= 0 (0: the default); got {value!r}")
        v = int(f)
    if not 0 <= v <= limit:
        raise ArgumentError(f"{what} must be in [0, {limit}] (0: the default); got {v}")
    return v


__all__ = ["F64", "LONG_MAX", "real_number", "real_vector", "times", "step_count", "tolerance",
           "whole_number"]
