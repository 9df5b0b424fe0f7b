"""Exceptions raised by mbgen, and the exit code of each on the command line.

Every error names the problem and what to do about it.  They all derive from
:class:`MbgenError`, so a caller can catch the family with one clause; each
also derives from the matching built-in (``ValueError``, ``TypeError``,
``ArithmeticError``, ...) so code that already catches those keeps working.

Exit codes
----------
Each class carries ``exit_code``: what ``mbgen`` exits with when the error ends a
command (``mbgen: <heading>: <message>`` on stderr).  A subclass inherits its
parent's code unless it sets its own.

0 (:data:`EXIT_OK`)
    success.
1 (:data:`EXIT_CHECK`)
    a check failed: :class:`CheckFailed` (errors above tolerance, golden files out
    of date).
2 (:data:`EXIT_USAGE`)
    usage -- a mistake in what the user asked for, fixed by asking differently:
    :class:`UsageError` (a bad argument, an output path that is a file or cannot be
    written), :class:`UnknownNameError`, :class:`CacheError`, :class:`MissingExtraError`,
    :class:`BenchmarkError`, and an output folder that cannot take a generation:
    :class:`OutputPathError` (a file, the golden tree, not writable),
    :class:`OutputConflictError` (a file of the user's in the way) and
    :class:`OutputBusyError` (another generation holds the folder); also (not an mbgen
    error) a file or folder that cannot be written or read (``OSError``).
3 (:data:`EXIT_MODEL`)
    bad model or scene -- what the scene or model file states: :class:`ModelError` and
    its subclasses (the URDF errors among them: :class:`UrdfError`), :class:`SceneError`
    (an unknown scene name, a scene file that does not exist or fails, a bad ``-O``
    option).
4 (:data:`EXIT_BUILD`)
    the C compiler failed: :class:`BuildError`.
5 (:data:`EXIT_NUMERIC`)
    numerical failure: :class:`MbgenError` itself and every class not named above
    (a singular mass matrix or constraint Jacobian, a non-finite result, an
    integrator failure, an inconsistent state, a bad runtime argument).
6 (:data:`EXIT_INCONCLUSIVE`)
    check inconclusive: :class:`CheckInconclusive` (nothing was compared: every
    sample failed in every back end; or the differences lie within the reference's
    own rounding); ``mbgen stress`` when its only failures are the harness's (a run
    stopped at the suite's budget), which say nothing about the model.

:class:`StiffnessWarning` and :class:`ModelWarning` are warnings, not errors: they never end
a command.

A new error derives from the matching class here (and built-in), sets ``exit_code``
when it differs from its parent's, and gets its row in ``EXIT_CODES`` of
``tests/test_errors.py`` (``test_every_error_has_its_exit_code`` fails otherwise).
"""

from __future__ import annotations

EXIT_OK, EXIT_CHECK, EXIT_USAGE, EXIT_MODEL, EXIT_BUILD, EXIT_NUMERIC = 0, 1, 2, 3, 4, 5
EXIT_INCONCLUSIVE = 6


class MbgenError(Exception):
    """Base class of every error raised by mbgen."""

    exit_code = EXIT_NUMERIC


class ModelError(MbgenError, ValueError):
    """A model is malformed: an unknown symbol, a body without inertia, ..."""

    exit_code = EXIT_MODEL


class ModelSizeError(ModelError):
    """A model is far larger than mbgen can derive and compile in reasonable time.

    Raised while the model is built, before any derivation starts
    (:data:`mbgen.model.limits.MAX_SPEEDS`, :data:`mbgen.model.limits.MAX_BODIES`); pass
    ``force=True`` (``--force`` on the command line) to go on anyway.
    """


class NonFiniteConstantError(ModelError):
    """Code would be generated with an ``inf``, ``nan`` or ``zoo`` constant in it.

    Raised by the C and Python printers (:mod:`mbgen.codegen.printing`) instead of
    printing a bare ``inf`` (which does not compile) or a NaN.
    """


class UrdfError(ModelError):
    """A URDF file cannot become a model (:func:`mbgen.from_urdf`); the message names the
    file, the link or joint, and the fix.  Nothing is built: every check runs first."""


class UrdfSyntaxError(UrdfError):
    """A URDF file that is not safe, well-formed URDF XML: too large, a DOCTYPE or entity
    declaration (refused, never expanded), malformed XML, a missing attribute or a value
    that is not a finite number."""


class UrdfInertiaError(UrdfError):
    """A link's ``<inertial>`` is not physical: a missing or negative mass, or an inertia
    that is not positive semidefinite or breaks the triangle inequality; or a moving joint
    with no mass or inertia anywhere below it."""


class UrdfStructureError(UrdfError):
    """The links and joints do not form one tree: a link with two parents, a cycle, no root
    or several, a joint naming a link that does not exist, or names that collide."""


class UrdfUnsupportedError(UrdfError):
    """A URDF feature mbgen does not model: a mimic joint, or a joint type other than
    revolute, continuous, prismatic and fixed (floating, planar, unknown types)."""


class MjcfError(ModelError):
    """A MuJoCo model cannot become a model (:func:`mbgen.from_mjcf`): MuJoCo could not
    compile the file, or it holds forces mbgen does not model (gravity compensation, fluid
    forces, tendon springs and dampers, springs on ball and free joints); the message says
    which."""


class SceneError(MbgenError, ValueError):
    """A scene cannot be found or loaded, or an option is invalid."""

    exit_code = EXIT_MODEL


class OutputBusyError(MbgenError, RuntimeError):
    """Another generation is writing the same output folder (it holds the folder's lock)
    and did not finish within the wait (:data:`mbgen.fileio.LOCK_WAIT`); nothing is written."""

    exit_code = EXIT_USAGE


class BuildError(MbgenError, RuntimeError):
    """The C compiler failed; the message carries the compiler's own output."""

    exit_code = EXIT_BUILD


class CacheError(BuildError):
    """The cache of compiled modules cannot be used: ``$MBGEN_CACHE_DIR`` (or every
    fallback folder) cannot be created or written, others could write it, or the disk
    is full.  The message names the folder and the fix."""

    exit_code = EXIT_USAGE


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

    exit_code = EXIT_CHECK


class ArgumentError(MbgenError, ValueError):
    """An argument of a runtime call is invalid: a wrong shape or length, a number that
    cannot be a double (``t=10**400``), a tolerance or step that is not a positive finite
    number, a step limit out of range, ...  The message names the argument and the fix."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument has the wrong type: a complex or string time, a complex or object array,
    ``None`` where a number is required.  Also a ``TypeError``."""


class CheckInconclusive(CheckFailed):
    """A verification compared nothing: every sample failed in every back end (a zero
    mass, a NaN parameter, a singular mass matrix everywhere), or no samples were asked
    for; or it differed only where the reference's own rounding could explain it (an
    ill-conditioned state).  Not a pass: ``mbgen check`` exits with its own code (6)."""

    exit_code = EXIT_INCONCLUSIVE


class UnknownNameError(MbgenError, ValueError):
    """A parameter, input or state given by a name the model does not have (or a
    needed name left out); the message lists the closest names ("did you mean")."""

    exit_code = EXIT_USAGE


class UsageError(MbgenError, ValueError):
    """A command-line mistake found after parsing: an output path that is a file, a
    folder that cannot be written, an unknown integration method, ...
    (``mbgen: error: ...``, exit code 2)."""

    exit_code = EXIT_USAGE


class OutputPathError(UsageError, SceneError):
    """An output folder cannot take a generation: it is a file, it is the checked-in golden
    tree, it or its parent cannot be written, it holds what cannot be carried into the
    new generation (a named pipe), or its manifest is damaged.  Nothing is written; the
    message names the path and the fix.  A usage error (exit 2); also a
    :class:`SceneError`, what these were before, so code catching that keeps working."""


class OutputConflictError(OutputPathError):
    """A generation would replace a file of the user's: one mbgen did not write, or one it
    wrote and the user changed since (the folder's manifest records each file's SHA-256).
    Nothing is written; the message names the files and the fix (``--overwrite``, or
    another output folder).  A usage error (exit 2): the files are fine, the output
    folder was the wrong choice."""


class MissingExtraError(MbgenError, ImportError):
    """An optional dependency is not installed; the message names the extra that has it."""

    exit_code = EXIT_USAGE


class BenchmarkError(MbgenError, RuntimeError):
    """A benchmark could not run: a missing optional dependency or a driver that failed."""

    exit_code = EXIT_USAGE


class StiffnessWarning(RuntimeWarning):
    """An explicit method's steps are held down by stability, not accuracy."""


class ModelWarning(UserWarning):
    """A model file loaded, but not all of it as written: what mbgen accepted against its
    rules (a URDF inertia that breaks the triangle inequality) or drops (an MJCF file's
    contacts, limits, equality constraints, actuators it does not read).  One warning per
    load names each; ``strict`` loading or ``-W error::mbgen.errors.ModelWarning`` refuses."""
