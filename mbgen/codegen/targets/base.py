"""What every target is: a row of the registry, a small config object over its own template folder.

A target names its folder ``templates/<folder>/`` and lists what it renders from there
(:meth:`Target.templates`): each template goes to a file, or to a section of the
model's files:

``HEADER``
    declarations added to ``<prefix>.h`` (and to the cffi cdef);
``SOURCE``
    code included into ``<prefix>.c`` (``templates/model/model.c.j2`` includes the
    active targets' sections in their order, never a template it knows by name);
``EXTENSION``
    code compiled into the Python extension only.

Two phases use the rows, each by one loop over :data:`~mbgen.codegen.targets.TARGETS`:

* :func:`mbgen.codegen.render.render` (``Kernel -> Rendered``) asks each row whether it is
  :meth:`~Target.wanted` for a kernel and the user's :class:`~mbgen.codegen.targets.Targets`,
  merges its :meth:`~Target.context` into the model's, renders its templates, adds its
  :meth:`~Target.declarations` and its :meth:`~Target.stack_bounds` (the header's
  ``<PREFIX>_STACK_<FUNCTION>``, in the units of :mod:`mbgen.codegen.header`);
* :func:`mbgen.export.generate` (a scene into a folder) asks each row the user named for
  its :meth:`~Target.export` (text files of the generation) or its :meth:`~Target.archive`
  (a file it writes whole, the FMU), from the pipeline's result (:class:`Job`).

A row's C may call the runtime routines (:mod:`mbgen.codegen.targets.runtime`) it lists in
:attr:`~Target.requires`, and only those.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..templating import environment

#: Where a template's text goes besides a file of its own.
HEADER, SOURCE, EXTENSION = "header", "source", "extension"


@dataclass(frozen=True)
class Job:
    """What a target exports from: the scene and the pipeline's kernel and rendered bundle.

    Attributes
    ----------
    scene : mbgen.Scene
    kernel : mbgen.codegen.optimize.Kernel
    rendered : mbgen.abi.Rendered
        Rendered with the switches of every target asked for (the FMU's step API).
    inputs : array (n_r,), InputTable or None
        The inputs ``example.c`` runs with, in the kernel's input order (None: zeros).
    """

    scene: Any
    kernel: Any
    rendered: Any
    inputs: Any = None


class Target:
    """A target's configuration: its folder, its templates, their context and what it exports.

    Attributes
    ----------
    name : str
        Its name: ``mbgen generate --target NAME`` and ``mbgen.generate(targets=[NAME])``.
    folder : str
        Its template folder ``templates/<folder>/`` (default: its name).
    files : tuple of (str, str)
        ``(template in the folder, where)``; ``where`` is :data:`HEADER`, :data:`SOURCE`,
        :data:`EXTENSION` or a file name (``{prefix}`` is the model's prefix).
    status_codes : tuple
        ``(name, value, meaning)`` of the status codes its C returns (``#define``\\ d
        in the header once, whichever targets share them).
    requires : tuple of str
        The runtime routines its C calls (rows of
        :data:`mbgen.codegen.targets.runtime.ROUTINES`); its templates ask for them with
        ``runtime("<routine>")`` before the first call.
    needs : tuple of str
        Targets whose files are written with its own (the step API lives in ``c``'s files).
    uses : tuple of str
        Targets rendered into the model for it, without writing their files (the FMU's
        step API).
    chosen : bool
        Picked by name; False: it follows the outputs (the integrators).
    takes_inputs : bool
        It is what ``inputs`` (``-r``) set (``example.c``).
    note : str
        What its archive is, for the line that names it (``mbgen generate``, ``mbgen fmu``).
    bundled : bool
        Its files are rendered by :func:`~mbgen.codegen.render.render` into the pipeline's
        ``Rendered`` (the model's, which the build and the back ends read); other rows'
        file templates are rendered by :meth:`export` from a scene and that bundle.
    """

    name: str = NotImplemented
    folder: str = ""
    files: tuple = ()
    status_codes: tuple = ()
    requires: tuple = ()
    needs: tuple = ()
    uses: tuple = ()
    chosen: bool = True
    takes_inputs: bool = False
    note: str = ""
    bundled: bool = False

    @property
    def template_folder(self) -> str:
        """``templates/<this>/``: :attr:`folder`, else the name."""
        return self.folder or self.name

    def templates(self, prefix: str) -> list[tuple[str, str]]:
        """``(template, where)`` of everything it renders for the model ``prefix``."""
        return [(f"{self.template_folder}/{template}", where.format(prefix=prefix))
                for template, where in self.files]

    def wanted(self, kernel, targets) -> bool:
        """Whether :func:`~mbgen.codegen.render.render` renders it for ``kernel`` and the
        user's ``targets`` (False: a product, rendered from a scene by :meth:`export`)."""
        return True

    def context(self, kernel, views, prefix: str) -> dict:
        """Its part of the template context (``views``: the functions' views,
        :class:`mbgen.codegen.targets.model.Views`)."""
        return {}

    def declarations(self, ctx: dict) -> list[str]:
        """C declarations for the header and the cdef: its ``HEADER`` templates rendered."""
        env = environment()
        return [env.get_template(template).render(ctx).strip()
                for template, where in self.templates(ctx["prefix"]) if where == HEADER]

    def cdef(self, ctx: dict) -> list[str]:
        """Declarations of what it compiles into the Python extension (its cffi cdef)."""
        return []

    def stack_bounds(self, kernel, ctx: dict, known: dict[str, int]) -> dict[str, int]:
        """``{C function: bytes}`` of its public functions, callees included (``known``: the
        bounds of the rows before it, by C name; units: :mod:`mbgen.codegen.header`)."""
        return {}

    def unavailable(self, kernel) -> str | None:
        """Why it cannot be made for ``kernel`` (None: it can).  Asked for by name, that is an
        error; in the default set, it is left out."""
        return None

    def export(self, job: Job) -> dict[str, str]:
        """``{file name: text}`` it adds to the output folder's generation."""
        return {}

    def archive(self, job: Job, folder: Path) -> Path | None:
        """Write its archive into ``folder`` (whole, or not at all); its path (None: none)."""
        return None


__all__ = ["Target", "Job", "HEADER", "SOURCE", "EXTENSION"]
