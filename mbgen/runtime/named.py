"""Numbers by name: parameters, inputs and states given as mappings.

Every runtime call takes ``p``, ``r`` and ``x`` either as arrays in the
model's order (:class:`~mbgen.symbolic.layout.Layout`; the fast path, untouched) or as a
mapping by name::

    model.rhs(0.0, {"q1": 0.1}, p={"c": 0.5})          # other states 0, other p: defaults
    model.integrate("dopri5", t, x0, p={"m": [1.0, 2.0, 3.0]})   # a batch of 3

A name the model does not have is an :class:`~mbgen.errors.UnknownNameError`
with the closest names ("did you mean").  A name left out takes

* ``p``: the model's default (the scene's ``parameters``, a PyDy System's
  ``constants``); a parameter without a default must be given;
* ``r``: 0 (an input not driven);
* ``x``: 0, as a scene's ``initial_state``.

A value may be a number or a 1-D sequence of ``k`` numbers; any sequence makes
the result a ``(k, n)`` batch (numbers are repeated over the batch).  A number is
real: a Python or NumPy integer or float, or any other ``numbers.Real`` (a
``Fraction``).  ``None``, a complex, a string, a bool or anything else is an
:class:`~mbgen.errors.ArgumentTypeError` (a ``TypeError``) naming the entry: never a
NaN, a real part, or a number parsed from text.

:class:`InputTable` is a piecewise-linear input ``r(t)``: the generated C
integrators interpolate it at every stage time (no Python in the loop), the
solve_ivp paths call it.  :func:`read_input_csv` reads one from a CSV file (the
command line's ``-r F=table.csv``), :func:`merge_inputs` puts constant inputs and
tables with different times into one table.

The CSV format of an input table::

    t,F            # a header: the time column (t or time), then one input per column
    0,0
    1,2.5          # one row per time, times strictly increasing
    3,2.5

Values are linear between rows and held at the first and last row outside them.
Blank lines and lines starting with ``#`` are skipped; a mistake is a
:class:`~mbgen.errors.UsageError` naming the file, the line and the fix.
"""

from __future__ import annotations

import csv
import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ArgumentError, ArgumentTypeError, UnknownNameError, UsageError
from ..names import did_you_mean


def check_names(given, names: Sequence[str], what: str, model: str = "") -> None:
    """Raise :class:`UnknownNameError` for the first of ``given`` not in ``names``."""
    known = set(names)
    for key in given:
        if key not in known:
            owner = f" of {model!r}" if model else ""
            listing = ", ".join(names) if names else "none"
            raise UnknownNameError(f"{key!r} is not one of the {what}{owner}"
                                   f"{did_you_mean(key, names)} ({what}: {listing})")


def real_values(value, what: str) -> np.ndarray:
    """``value`` (a real number or a sequence of them, nested or not) as a float64 array of its
    shape.

    Raises ArgumentTypeError naming ``what`` for anything not real (``None``, complex,
    str, bool, ...) and ArgumentError for an integer too large for a double.
    """
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):   # ragged sequences and the like
        a = None
    if a is not None and a.dtype.kind in "iuf" and isinstance(value, (list, tuple)):
        a = np.asarray(value, dtype=object)   # the items themselves: numpy makes [1.0, True] floats
    if a is None or a.dtype.kind not in "iufO" or a.dtype.kind == "O" and not all(
            isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) for v in a.flat):
        raise ArgumentTypeError(f"{what} must be a real number or a sequence of them; "
                                f"got {value!r:.80}")
    try:
        return a.astype(np.float64)
    except OverflowError:
        raise ArgumentError(f"{what} holds a number too large for a double: "
                            f"{value!r:.40}") from None


def vector(values: Mapping, names: Sequence[str], what: str, *,
           defaults: Mapping[str, float] | None = None, fill: float | None = None,
           model: str = "") -> np.ndarray:
    """``values`` by name -> array in ``names`` order: shape ``(n,)``, or ``(k, n)`` for a batch.

    Missing names take ``defaults[name]``, else ``fill``; with neither it is an
    error naming them.
    """
    names = tuple(names)
    check_names(values, names, what, model)
    defaults = defaults or {}
    columns, missing = [], []
    for n in names:
        if n in values:
            v = values[n]
        elif n in defaults:
            v = defaults[n]
        elif fill is not None:
            v = fill
        else:
            missing.append(n)
            continue
        a = real_values(v, f"{what} {n!r}")
        if a.ndim > 1:
            raise ArgumentError(f"{what} {n!r} must be a number or a 1-D sequence (a batch); "
                                f"got shape {a.shape}")
        columns.append(a)
    if missing:
        owner = f" {model!r}" if model else ""
        raise UnknownNameError(f"no value for {what} {missing}: the model{owner} has no default "
                               f"for them; give each by name")
    sizes = {a.shape[0] for a in columns if a.ndim == 1}
    if not sizes:
        return np.array(columns, dtype=np.float64).reshape(len(names))
    if len(sizes) > 1:
        raise ArgumentError(f"{what} by name: batch sequences differ in length {sorted(sizes)}")
    k = sizes.pop()
    return np.ascontiguousarray(np.stack([np.broadcast_to(a, (k,)) for a in columns], axis=1))


def states(model, x: Mapping) -> np.ndarray:
    """``x`` by state name (missing states 0)."""
    return vector(x, model.state_names, "states", fill=0.0, model=model.name)


def parameters(model, p: Mapping) -> np.ndarray:
    """``p`` by parameter name (missing parameters: the model's defaults)."""
    return vector(p, model.parameter_names, "parameters",
                  defaults=getattr(model, "parameter_defaults", None), model=model.name)


def inputs(model, r: Mapping) -> np.ndarray:
    """``r`` by input name (missing inputs 0)."""
    return vector(r, model.input_names, "inputs", fill=0.0, model=model.name)


def arrays(model, x, p, r):
    """``(x, p, r)`` with every mapping turned into its array (anything else unchanged)."""
    if isinstance(x, Mapping):
        x = states(model, x)
    if isinstance(p, Mapping):
        p = parameters(model, p)
    if isinstance(r, Mapping):
        r = inputs(model, r)
    return x, p, r


@dataclass(frozen=True, eq=False)
class InputTable:
    """A piecewise-linear input ``r(t)``: ``values[i]`` at ``times[i]``, held outside.

    Parameters
    ----------
    times : array_like, shape (k,)
        Strictly increasing, finite.
    values : array_like, shape (k, n_r), or mapping input name -> shape (k,)
        By name, inputs left out are 0 (resolved by :meth:`for_model`).

    ``table(t)`` (or ``table(t, x)``) is ``r(t)``, shape ``(n_r,)``, interpolated as
    :func:`numpy.interp` per input: usable as the input function of
    :func:`mbgen.runtime.simulate.simulate`; the C integrators do the same interpolation
    at every stage time.
    """

    times: np.ndarray
    values: object

    def __post_init__(self):
        t = real_values(self.times, "InputTable times")
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)):
            raise ValueError(f"InputTable times must be a 1-D array of finite times; got "
                             f"{self.times!r}")
        if np.any(np.diff(t) <= 0):
            raise ValueError("InputTable times must be strictly increasing")
        object.__setattr__(self, "times", np.ascontiguousarray(t))
        if isinstance(self.values, Mapping):
            for n, c in self.values.items():
                real_values(c, f"InputTable input {n!r}")
        else:
            v = real_values(self.values, "InputTable values")
            if v.ndim == 1:
                v = v[:, None]
            if v.ndim != 2 or v.shape[0] != t.size:
                raise ValueError(f"InputTable values must have shape ({t.size}, n_r), one row "
                                 f"per time; got {np.shape(self.values)}")
            if not np.all(np.isfinite(v)):
                raise ValueError("InputTable values must be finite")
            object.__setattr__(self, "values", np.ascontiguousarray(v))

    def for_model(self, model) -> InputTable:
        """This table with ``values`` as a ``(k, n_r)`` array in ``model``'s input order
        (``model``: anything with ``input_names``, a model or a ``Layout``)."""
        name = getattr(model, "name", "")
        if isinstance(self.values, Mapping):
            check_names(self.values, model.input_names, "inputs", name)
            k = self.times.size
            cols = []
            for n in model.input_names:
                c = real_values(self.values.get(n, np.zeros(k)), f"InputTable input {n!r}")
                if c.shape != (k,):
                    raise ValueError(f"InputTable input {n!r} must have one value per time "
                                     f"({k}); got shape {c.shape}")
                cols.append(c)
            return InputTable(self.times, np.stack(cols, axis=1).reshape(k, len(cols)))
        if self.values.shape[1] != len(model.input_names):
            raise ValueError(f"InputTable values have {self.values.shape[1]} columns; "
                             f"{name!r} has {len(model.input_names)} inputs "
                             f"{list(model.input_names)}")
        return self

    def __call__(self, t, x=None) -> np.ndarray:
        if isinstance(self.values, Mapping):
            raise TypeError("an InputTable by name must be resolved first: table.for_model(model)")
        t = float(t)
        return np.array([np.interp(t, self.times, col) for col in self.values.T])


#: The names the first column of an input table's CSV may have (any case).
TIME_COLUMNS = ("t", "time")


def read_input_csv(path) -> InputTable:
    """The :class:`InputTable` of a CSV file, by name: its columns after the time (see the
    module notes for the format).

    Raises
    ------
    UsageError
        The file cannot be read, its header does not start with ``t`` (or ``time``)
        and name its inputs once each, a row has the wrong number of cells, a cell is not
        a finite number, the times do not increase, or it has no rows.
    """
    path = Path(path)
    fix = "an input table is a CSV file whose header names the time, then the inputs (t,F)"
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise UsageError(f"input table {str(path)!r} cannot be read ({reason}); {fix}") from None
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise UsageError(f"input table {str(path)!r} is empty; {fix}")
    rows = csv.reader(line for _, line in lines)
    header = [cell.strip() for cell in next(rows)]
    where = f"{path}:{lines[0][0]}"
    if len(header) < 2 or header[0].lower() not in TIME_COLUMNS or not all(header[1:]):
        raise UsageError(f"{where}: the header {','.join(header)!r} must name the time first "
                         f"({' or '.join(TIME_COLUMNS)}), then each input (e.g. t,F)")
    twice = sorted({n for n in header[1:] if header[1:].count(n) > 1})
    if twice:
        raise UsageError(f"{where}: the header names {twice} twice; name each input once")
    data = []
    for (n, _), cells in zip(lines[1:], rows):
        where = f"{path}:{n}"
        if len(cells) != len(header):
            raise UsageError(f"{where}: {len(cells)} values where the header names "
                             f"{len(header)} columns ({','.join(header)})")
        try:
            values = [float(c) for c in cells]
        except ValueError:
            bad = next(c for c in cells if not _is_number(c))
            raise UsageError(f"{where}: {bad.strip()!r} is not a number") from None
        if not all(math.isfinite(v) for v in values):
            raise UsageError(f"{where}: every value must be a finite number")
        if data and not values[0] > data[-1][0]:
            raise UsageError(f"{where}: the time {values[0]!r} must be after the row before's "
                             f"{data[-1][0]!r} (times strictly increasing)")
        data.append(values)
    if not data:
        raise UsageError(f"input table {str(path)!r} has a header but no rows; {fix}")
    a = np.array(data)
    return InputTable(a[:, 0], {name: a[:, j] for j, name in enumerate(header[1:], 1)})


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def merge_inputs(given: Mapping[str, object]) -> dict[str, float] | InputTable:
    """Inputs by name, each a number or a ``(times, values)`` pair, as one value for ``r``.

    Numbers only: the mapping itself.  With a pair among them: one :class:`InputTable`
    by name on the union of the pairs' times, each pair interpolated there (exact: a
    piecewise-linear signal sampled at every knot of the union is the same signal) and
    each number held.
    """
    tables = {n: v for n, v in given.items() if isinstance(v, tuple)}
    if not tables:
        return dict(given)
    times = np.unique(np.concatenate([np.asarray(t, dtype=float) for t, _ in tables.values()]))
    return InputTable(times, {n: np.interp(times, *v) if isinstance(v, tuple)
                              else np.full(times.size, float(v)) for n, v in given.items()})


def driven(model, output, p: np.ndarray, r_of) -> Callable:
    """``f(t, x) = output(t, x, p, r_of(t, x))``: inputs as a function of time and state.

    An :class:`InputTable` is first put in the model's input order.  The
    inputs are validated at every call (a wrong length is an error), so this
    is slower than constant inputs: one Python call of ``r_of`` per evaluation.
    """
    if isinstance(r_of, InputTable):
        r_of = r_of.for_model(model)
    evaluate, check_r = model._evaluate, model._r

    def f(t, x):
        return evaluate(output, t, x, p, check_r(r_of(t, x)))

    return f


__all__ = ["InputTable", "TIME_COLUMNS", "arrays", "check_names", "did_you_mean", "driven",
           "inputs", "merge_inputs", "parameters", "read_input_csv", "real_values", "states",
           "vector"]
