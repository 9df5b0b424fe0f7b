"""Exceptions raised by mbgen.

Every error names the problem and what to do about it.  They all derive from
:class:`MbgenError`, so a caller can catch the family with one clause; each
also derives from the matching built-in (``ValueError``, ``TypeError``,
``ArithmeticError``, ...) so code that already catches those keeps working.
"""

from __future__ import annotations


class MbgenError(Exception):
    """Base class of every error raised by mbgen."""


class ModelError(MbgenError, ValueError):
    """A model is malformed: an unknown symbol, a body without inertia, ..."""


class SceneError(MbgenError, ValueError):
    """A scene cannot be found or loaded, or an option is invalid."""


class BuildError(MbgenError, RuntimeError):
    """The C compiler failed; the message carries the compiler's own output."""


class SingularMassMatrixError(MbgenError, ArithmeticError):
    """The mass matrix is not positive definite at the given state.

    Raised by the compiled and generated right-hand sides when the ``L D L^T``
    factorisation of M(q, t) meets a pivot that is not positive (or NaN).
    """


class SingularConstraintError(MbgenError, ArithmeticError):
    """The constraint Jacobian of the dependent speeds is singular at the given state.

    A locked or singular configuration (a four-bar linkage at its dead point,
    a wheel whose contact cannot determine the chosen dependent speeds): the
    constraints do not determine the dependent speeds there.  C status
    ``<MODEL>_CONSTRAINT_SINGULAR``.
    """


class ConstraintError(MbgenError, ValueError):
    """A state violates the constraints and cannot be made consistent (Newton failed)."""


class NonFiniteResultError(MbgenError, ArithmeticError):
    """An output evaluated to NaN or infinity (e.g. a 1/cos(q) at gimbal lock)."""


class IntegrationError(MbgenError, ArithmeticError):
    """An integrator (C or solve_ivp) failed: step too small, step limit, singular matrix, ...

    ``status`` is the C status code (or None) and ``t`` the time reached.
    """

    def __init__(self, message: str, status: int | None = None, t: float | None = None):
        super().__init__(message)
        self.status = status
        self.t = t


class CheckFailed(MbgenError, AssertionError):
    """A verification found an error above its tolerance."""


class UnknownNameError(MbgenError, ValueError):
    """A parameter, input or state given by a name the model does not have (or a
    needed name left out); the message lists the closest names ("did you mean")."""


class UsageError(MbgenError, ValueError):
    """A command-line mistake found after parsing: an output path that is a file, a
    folder that cannot be written, an unknown integration method, ...
    (``mbgen: error: ...``, exit code 2)."""
