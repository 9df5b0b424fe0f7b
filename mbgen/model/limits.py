"""The size guard: models too large to derive and compile in reasonable time are refused.

A model may have at most :data:`MAX_SPEEDS` generalized coordinates (and as
many speeds) and :data:`MAX_BODIES` particles and rigid bodies, unless it is built with
``Model(name, force=True)`` or inside :func:`allow_large_models` (which
``load_scene(..., force=True)`` and ``--force`` use).  A refusal is a
:class:`~mbgen.errors.ModelSizeError` that says what the size would cost and
how to force it.
"""

from __future__ import annotations

import contextvars
import re
from contextlib import contextmanager

from ..errors import ModelSizeError

#: Most generalized speeds a model may have without ``force=True``.  Kane's
#: equations of n speeds have ~n^2 mass-matrix entries; measured on the n-link
#: cart (``mbgen.scenes.n_link_cart``): 64 links, 29,000 operations after CSE and
#: 10 s from model to rendered code, growing as ~n^2.5 -- so 200 speeds take
#: minutes, and 100,000 would take years.
MAX_SPEEDS = 200
#: Most particles and rigid bodies a model may have without ``force=True``.
MAX_BODIES = 1000

_COST = ("measured: 64 speeds take 10 s from model to code and the time grows as about "
         "n^2.5")
_FORCE_HINT = ("If you really mean it, build it with Model(name, force=True), load the scene "
               "with load_scene(..., force=True), or pass --force on the command line.")

_FORCE_SIZE: contextvars.ContextVar[bool] = contextvars.ContextVar("mbgen_force_size",
                                                                  default=False)


def guard_range(names: str, what: str) -> None:
    """Refuse ``'u:100001'`` before sympy creates 100,001 symbols (unless forced)."""
    if _FORCE_SIZE.get():
        return
    for a, b in re.findall(r"(\d*):(\d+)", names):
        count = int(b[:12]) - int(a[:12] or 0)
        if count > MAX_SPEEDS:
            raise ModelSizeError(f"{names!r} declares {count} {what}s; a model with more than "
                                 f"{MAX_SPEEDS} speeds cannot be derived and compiled in "
                                 f"reasonable time ({_COST}). {_FORCE_HINT}")


def size_forced() -> bool:
    """True inside :func:`allow_large_models` (e.g. while ``load_scene(..., force=True)`` runs)."""
    return _FORCE_SIZE.get()


def check_size(n_speeds: int, what: str) -> None:
    """Refuse ``n_speeds`` above :data:`MAX_SPEEDS` unless forced (:class:`ModelSizeError`)."""
    if n_speeds > MAX_SPEEDS and not size_forced():
        raise ModelSizeError(f"{what} has {n_speeds} speeds, more than {MAX_SPEEDS}: far past "
                             f"what mbgen derives and compiles in reasonable time ({_COST}). "
                             f"{_FORCE_HINT}")


@contextmanager
def allow_large_models():
    """Within this block, models larger than :data:`MAX_SPEEDS` / :data:`MAX_BODIES` are built."""
    token = _FORCE_SIZE.set(True)
    try:
        yield
    finally:
        _FORCE_SIZE.reset(token)


def check_count(model: str, count: int, what: str, limit: int, forced: bool = False) -> None:
    """Refuse model ``model`` growing to ``count`` ``what`` above ``limit`` unless forced."""
    if count > limit and not (forced or _FORCE_SIZE.get()):
        raise ModelSizeError(f"model {model!r} would have {count} {what}, more than "
                             f"{limit}: far past what mbgen derives and compiles in "
                             f"reasonable time ({_COST}). {_FORCE_HINT}")


__all__ = ["MAX_SPEEDS", "MAX_BODIES", "allow_large_models", "check_count", "check_size",
           "guard_range", "size_forced"]
