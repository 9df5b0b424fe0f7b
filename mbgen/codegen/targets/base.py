"""What every target is: a small config object over its own template folder.

A target names its folder ``templates/<name>/`` and lists what it renders from there
(:meth:`Target.templates`): each template goes to a file, or to a section of the
model's files:

``HEADER``
    declarations added to ``<prefix>.h`` (and to the cffi cdef);
``SOURCE``
    code included into ``<prefix>.c`` (``templates/model/model.c.j2`` includes the
    active targets' sections in their order, never a template it knows by name);
``EXTENSION``
    code compiled into the Python extension only.

:func:`mbgen.codegen.render.render` asks each target whether it is wanted for a kernel
and the user's :class:`~mbgen.codegen.targets.Targets`, merges its :meth:`~Target.context`
into the model's and renders its templates.
"""

from __future__ import annotations

from ..templating import environment

#: Where a template's text goes besides a file of its own.
HEADER, SOURCE, EXTENSION = "header", "source", "extension"


class Target:
    """A target's configuration: its folder, its templates and their context.

    Attributes
    ----------
    name : str
        Its template folder ``templates/<name>/``.
    files : tuple of (str, str)
        ``(template in the folder, where)``; ``where`` is :data:`HEADER`, :data:`SOURCE`,
        :data:`EXTENSION` or a file name (``{prefix}`` is the model's prefix).
    status_codes : tuple
        ``(name, value, meaning)`` of the status codes its C returns (``#define``\\ d
        in the header once, whichever targets share them).
    """

    name: str = NotImplemented
    files: tuple = ()
    status_codes: tuple = ()

    def templates(self, prefix: str) -> list[tuple[str, str]]:
        """``(template, where)`` of everything it renders for the model ``prefix``."""
        return [(f"{self.name}/{template}", where.format(prefix=prefix))
                for template, where in self.files]

    def wanted(self, kernel, targets) -> bool:
        """Whether it is rendered for ``kernel`` and the user's ``targets``."""
        return True

    def context(self, kernel, views: list[dict], prefix: str) -> dict:
        """Its part of the template context (``views``: the C functions' views)."""
        return {}

    def declarations(self, ctx: dict) -> list[str]:
        """C declarations for the header and the cdef: its ``HEADER`` templates rendered."""
        env = environment()
        return [env.get_template(template).render(ctx).strip()
                for template, where in self.templates(ctx["prefix"]) if where == HEADER]


__all__ = ["Target", "HEADER", "SOURCE", "EXTENSION"]
