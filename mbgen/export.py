"""Exports: a scene's generated files in a folder (:func:`generate`), an FMU (:func:`export_fmu`).

``generate(scene, targets=["c", "python", "step"], output_dir="out/")`` (``mbgen generate
SCENE --target c,python,step -o out/``) runs the pipeline once, with what the targets need
rendered (the step API for ``step`` and ``fmu``), and asks every target named for what it
writes (:data:`mbgen.codegen.targets.TARGETS`, one row each)::

    c          <prefix>.h, <prefix>.c       the outputs in C (and the step API, the
                                            integrators the outputs name, in them)
    python     <prefix>.py                  the same functions in Python
    step       (in <prefix>.h, .c)          the step API; needs c
    batch      <prefix>_batch.c             the Python extension's batch loops; needs c
    example    example.c                    a main() running the first integrator; needs c
    fmu        <prefix>.fmu                 an FMI 2.0 FMU (model exchange and
                                            co-simulation), compiled here

The text files go into the folder as one generation (:func:`mbgen.fileio.write_generated`:
a lock, the files written aside and swapped in, a manifest; a file the user changed is
never overwritten unless ``overwrite``); an archive (the FMU) is written whole by its target
beside them.  :func:`export_fmu` is ``generate(scene, ["fmu"], output_dir)``, which writes
the ``.fmu`` alone (no manifest), as ``mbgen fmu SCENE -o DIR``.

FMU layout (:mod:`mbgen.codegen.targets.fmu`, :mod:`mbgen.build.fmu`)::

    <prefix>.fmu
        modelDescription.xml            variables, capabilities, model structure
        sources/<prefix>.h, .c          the model (with the step API target)
        sources/<prefix>_fmi2.h         FMI 2.0 types (written from the standard)
        sources/<prefix>_fmu.c          the FMI functions (templates/fmu/fmu.c.j2)
        binaries/<platform>/<prefix>.so|.dylib|.dll   built here with the C compiler
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .codegen.targets import DEFAULT, Job, select, switches
from .errors import UsageError
from .fileio import Generation, plain_name, write_generated
from .pipeline import PipelineResult, run

#: Where :func:`generate` (``mbgen generate SCENE``) writes without an ``output_dir``:
#: ``./mbgen-out/SCENE/`` (never the checked-in golden tree ``generated/``).
DEFAULT_OUTPUT = Path("mbgen-out")


@dataclass(frozen=True)
class Generated:
    """What :func:`generate` wrote.

    Attributes
    ----------
    folder : Path
        The output folder.
    files : tuple of Path
        Every text file of the generation, by name (written, or already up to date).
    generation : Generation or None
        What the generation did (:class:`mbgen.fileio.Generation`: ``changed``,
        ``removed``, ``kept``, ``remarks()``); None when no text file was asked for.
    archives : tuple of (Path, str)
        Each archive written (the FMU) and what it is.
    targets : tuple of str
        The targets written, in the registry's order (those asked for and those they need).
    result : PipelineResult
        The pipeline's result (not built): equations, kernel, rendered texts.
    """

    folder: Path
    files: tuple
    generation: Generation | None
    archives: tuple
    targets: tuple
    result: PipelineResult

    @property
    def written(self) -> tuple:
        """The text files that got new content."""
        return tuple(self.generation.changed) if self.generation else ()


def generate(scene, targets: Iterable[str] | str | None = None, output_dir=None, *,
             outputs=None, inputs: Any = None, name: str | None = None, sliced: bool = True,
             overwrite: bool = False, stage: Callable[[str], None] | None = None) -> Generated:
    """Write what ``targets`` produce for ``scene`` into ``output_dir``.

    Parameters
    ----------
    scene : Scene
    targets : iterable of str, or a comma-separated str, optional
        Names of :data:`mbgen.codegen.targets.TARGETS` rows: ``c``, ``python``, ``step``,
        ``batch``, ``example``, ``fmu`` (with the targets each needs).  Default
        ``c, python, example`` (``example`` only when the outputs have an integrator) and
        the targets the scene switches on (``Scene(targets=Targets(step=True))``).
    output_dir : path, optional
        Default ``mbgen-out/<scene name>``.
    outputs : iterable of Output or names, optional
        Default: the scene's.
    inputs : array, InputTable or callable, optional
        What ``example.c`` runs with: the inputs in the generated model's order, or a
        function of its :class:`~mbgen.Layout` returning them (default zeros).
    name : str, optional
        The C prefix (default: the scene's).
    sliced : bool
        ``False`` ignores the scene's fixed parameters and input selection.
    overwrite : bool
        Replace files of the user's in the way (see :func:`mbgen.fileio.write_generated`).
    stage : callable, optional
        Called with each pipeline stage's name as it starts (progress lines).

    Returns
    -------
    Generated

    Raises
    ------
    UsageError
        An unknown target; a target asked for by name that the outputs cannot have
        (``example`` without an integrator); ``inputs`` that no target written takes.
    """
    asked = select(targets) if targets is not None else ()
    rows = asked or select(DEFAULT)
    if inputs is not None and not any(t.takes_inputs for t in rows):
        raise UsageError("-r sets the inputs of example.c, which is not among the targets "
                         "(add example to --target)")
    result = run(scene, outputs, build=False, name=name, sliced=sliced, stage=stage,
                 targets=switches(rows, scene.targets))
    kernel = result.kernel
    for t in rows:
        reason = t.unavailable(kernel)
        if reason and t in asked:
            raise UsageError(f"target {t.name!r}: {reason}")
    rows = tuple(t for t in rows if not t.unavailable(kernel))
    if inputs is not None and not any(t.takes_inputs for t in rows):
        raise UsageError("-r sets the inputs of example.c, which this generation does not "
                         "have (no integrator among its outputs); add one, e.g. --outputs "
                         "rhs,dopri5")
    if callable(inputs):
        inputs = inputs(kernel.layout)
    job = Job(scene, kernel, result.rendered, inputs)
    folder = Path(output_dir) if output_dir is not None else \
        DEFAULT_OUTPUT / plain_name(scene.name, "scene name")
    files = {n: text for t in rows for n, text in t.export(job).items()}
    done = write_generated(folder, files, overwrite=overwrite) if files else None
    archives = tuple((path, t.note) for t in rows
                     for path in [t.archive(job, folder)] if path is not None)
    return Generated(folder, tuple(folder / n for n in sorted(files)), done, archives,
                     tuple(t.name for t in rows), result)


def export_fmu(scene, output_dir, *, name: str | None = None) -> Path:
    """Write ``<output_dir>/<prefix>.fmu`` for ``scene`` (a Scene); returns its path.

    The FMU holds the scene's outputs (its fixed parameters baked in) plus the
    step API; see :mod:`mbgen.codegen.targets.fmu` for what the model description lists.
    ``generate(scene, ["fmu"], output_dir)`` does the same.
    """
    [(path, _)] = generate(scene, ["fmu"], output_dir, name=name).archives
    return path


__all__ = ["generate", "Generated", "export_fmu", "DEFAULT_OUTPUT"]
