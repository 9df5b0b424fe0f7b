"""The generated Python back end: the rendered ``<prefix>.py`` run in this process.

:class:`PythonModel` has the :class:`~mbgen.runtime.base.ModelBase` interface; it needs no
compiler and gives the numbers of the C (to rounding).

:func:`python_model` executes the rendered module text in memory (no files written);
a batch of states ``(k, n_x)`` is evaluated item by item, as the C batch loop would.
"""

from __future__ import annotations

import builtins
import types

import numpy as np

from ..abi import Output, Rendered
from ..errors import MbgenError
from ..symbolic.layout import Layout
from .base import GeneratedModel
from .batch import batch_args, batch_times, is_batch


class PythonModel(GeneratedModel):
    """The generated Python module (``<prefix>.py``) behind the same interface."""

    backend = "python"

    def __init__(self, rendered, module, layout: Layout, defaults, outputs):
        super().__init__(rendered, module, layout, defaults, outputs)
        self._args = {Output(info.output): info.args for info in rendered.functions}

    def _evaluate(self, output, t, x, p, r):
        self._require(output)
        fn = getattr(self.module, output.value)
        takes = self._args[output]
        p_, r_ = (p if "p" in takes else None), (r if "r" in takes else None)
        if not all(v is None or type(v) is np.ndarray and v.ndim == 1 for v in (x, p_, r_)):
            if is_batch(x, p_, r_):  # as the C batch loop: item by item, the first failure raises
                return self._batch(output, fn, t, x, p_, r_)
        xa = self._x(x)
        args = [self._t(t), xa]
        if "p" in self._args[output]:
            args.append(self._p(p))
        if "r" in self._args[output]:
            args.append(self._r(r))
        return self._call(fn, output, args, t, xa)

    def _call(self, fn, output, args, t, xa):
        try:
            return fn(*args)
        except self.module.NotPositiveDefinite:
            self._fail(1, output.value, t, xa)
        except self.module.NonFinite:
            self._fail(2, output.value, t, xa)
        except getattr(self.module, "ConstraintSingular", ()):
            self._fail(7, output.value, t, xa)
        except getattr(self.module, "ContactSingular", ()):
            self._fail(9, output.value, t, xa)

    def _batch(self, output, fn, t, x, p, r):
        k, (xa, xs), (pa, ps), (ra, rs) = batch_args(self, x, p, r)
        ta, ts = batch_times(self, t, k)
        info = next(f for f in self.rendered.functions if Output(f.output) is output)
        out = np.empty((k,) + tuple(info.out_shape))
        for i in range(k):
            args = [float(ta[i * ts]), xa[i * (xs > 0)]]
            if "p" in self._args[output]:
                args.append(pa[i * (ps > 0)])
            if "r" in self._args[output]:
                args.append(ra[i * (rs > 0)])
            try:
                out[i] = self._call(fn, output, args, args[0], args[1])
            except MbgenError as exc:
                raise type(exc)(f"batch item {i} of {k}: {exc}") from None
        return out


def python_model(rendered: Rendered) -> PythonModel:
    """Load the generated Python module of ``rendered`` (no files written).

    The ABI layout, parameter defaults and outputs come from ``rendered``.
    """
    name = f"mbgen_generated_{rendered.prefix}"
    module = types.ModuleType(name)
    module.__file__ = f"<generated {rendered.prefix}.py>"
    exec(builtins.compile(rendered.python, module.__file__, "exec"), module.__dict__)
    return PythonModel(rendered, module, rendered.layout, rendered.defaults, rendered.outputs)


__all__ = ["PythonModel", "python_model"]
