"""The layout: the single source of symbol order.

Every array that crosses a boundary (the state ``x``, the parameters ``p``, the
inputs ``r``, the outputs) is ordered by one :class:`Layout`.  Generated C,
generated Python, the lambdified reference and the runtime wrappers all read
their order from here, so they cannot disagree.

Arrays
------
``x`` : shape (n_q + n_u,)
    ``[q_1 .. q_nq, u_1 .. u_nu]``
``p`` : shape (n_p,)
    constant parameters in declaration order
``r`` : shape (n_r,)
    inputs (applied forces/torques given at run time), in declaration order
``dxdt`` : shape (n_q + n_u,)
    ``[q', u']``

A constrained model's *dependent speeds* (``dependent_speeds``) are symbols of
the equations but not states: the generated code computes them from the
constraints.  ``M`` and ``F`` are ordered ``speeds + dependent_speeds``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import sympy as sm

from ..errors import ModelError
from ..names import unique_identifiers


@dataclass(frozen=True)
class Layout:
    """Order of coordinates, speeds, parameters and inputs (all plain sympy Symbols)."""

    coordinates: tuple[sm.Symbol, ...]
    speeds: tuple[sm.Symbol, ...]
    parameters: tuple[sm.Symbol, ...] = ()
    inputs: tuple[sm.Symbol, ...] = ()
    time: sm.Symbol = sm.Symbol("t")
    dependent_speeds: tuple[sm.Symbol, ...] = ()

    def __post_init__(self):
        every = self.states + self.parameters + self.inputs + (self.time,) + self.dependent_speeds
        names = [str(s) for s in every]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ModelError(f"symbol name(s) {sorted(dup)} used twice in the layout; "
                             f"every coordinate, speed, parameter and input needs its own name")
        unique_identifiers(names)  # raises on identifiers that collide after sanitising
        if not self.speeds:
            raise ModelError("a model needs at least one generalized speed")

    # sizes --------------------------------------------------------------
    @property
    def n_q(self) -> int:
        return len(self.coordinates)

    @property
    def n_u(self) -> int:
        return len(self.speeds)

    @property
    def n_x(self) -> int:
        return self.n_q + self.n_u

    @property
    def n_d(self) -> int:
        """Number of dependent speeds (computed from constraints, not states)."""
        return len(self.dependent_speeds)

    @property
    def all_speeds(self) -> tuple[sm.Symbol, ...]:
        """Independent then dependent speeds: the order of ``M`` and ``F``."""
        return self.speeds + self.dependent_speeds

    @property
    def n_p(self) -> int:
        return len(self.parameters)

    @property
    def n_r(self) -> int:
        return len(self.inputs)

    @property
    def states(self) -> tuple[sm.Symbol, ...]:
        return self.coordinates + self.speeds

    # names ----------------------------------------------------------------
    @property
    def state_names(self) -> tuple[str, ...]:
        return tuple(str(s) for s in self.states)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(str(s) for s in self.parameters)

    @property
    def input_names(self) -> tuple[str, ...]:
        return tuple(str(s) for s in self.inputs)

    @property
    def derivative_names(self) -> tuple[str, ...]:
        return tuple(f"{s}'" for s in self.states)

    @cached_property
    def identifiers(self) -> dict[sm.Symbol, str]:
        """Symbol -> identifier valid in C, C++ and Python (sanitised, unique)."""
        every = self.states + self.parameters + self.inputs + (self.time,)
        return dict(zip(every, unique_identifiers([str(s) for s in every])))

    def arrays(self) -> dict[sm.Symbol, tuple[str, int]]:
        """Symbol -> (array name, index): ``x`` for states, ``p``, ``r``."""
        out = {s: ("x", i) for i, s in enumerate(self.states)}
        out.update({s: ("p", i) for i, s in enumerate(self.parameters)})
        out.update({s: ("r", i) for i, s in enumerate(self.inputs)})
        return out

    def symbols(self) -> frozenset:
        """Every symbol the equations may contain."""
        return frozenset(self.states + self.parameters + self.inputs + (self.time,)
                         + self.dependent_speeds)
