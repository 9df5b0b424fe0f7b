"""FMI 2.0 export: a scene as a Functional Mock-up Unit (model exchange and co-simulation).

``export_fmu(scene, "out/")`` (``mbgen fmu SCENE -o DIR``) runs the pipeline with the
step API target, renders the FMU's texts (:func:`mbgen.codegen.targets.fmu.fmu_files`:
what the model description lists, how the glue steps), compiles them and writes the
zip (:mod:`mbgen.build.fmu`)::

    <prefix>.fmu
        modelDescription.xml            variables, capabilities, model structure
        sources/<prefix>.h, .c          the model (with the step API target)
        sources/<prefix>_fmi2.h         FMI 2.0 types (written from the standard)
        sources/<prefix>_fmu.c          the FMI functions (templates/fmu/fmu.c.j2)
        binaries/<platform>/<prefix>.so|.dylib|.dll   built here with the C compiler
"""

from __future__ import annotations

from pathlib import Path

from .build.fmu import build_binary, write_fmu
from .codegen.targets import Targets
from .codegen.targets.fmu import fmu_files
from .pipeline import run


def export_fmu(scene, output_dir, *, name: str | None = None) -> Path:
    """Write ``<output_dir>/<prefix>.fmu`` for ``scene`` (a Scene); returns its path.

    The FMU holds the scene's outputs (its fixed parameters baked in) plus the
    step API; see :mod:`mbgen.codegen.targets.fmu` for what the model description lists.
    """
    result = run(scene, build=False, name=name, targets=Targets(step=True))
    files = fmu_files(scene, result.kernel, result.rendered)
    prefix = result.rendered.prefix
    return write_fmu(output_dir, prefix, files, build_binary(files, prefix))


__all__ = ["export_fmu"]
