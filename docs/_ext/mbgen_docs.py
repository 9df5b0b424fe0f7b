"""Sphinx extension of mbgen's site: the "How to add" lists, the gallery, mbgen's references.

Three pieces, each small:

* ``{mbgen-howto} MODULE`` shows the "How to add ..." section of a module's docstring (every
  package of mbgen has one; ``tests/test_layout.py`` requires it), so the developer guide
  quotes the source instead of copying it.  Roles in it (``:mod:`x```) become code.
* ``{mbgen-gallery}`` writes one section per built-in scene (``mbgen scenes``): what it is,
  its options, and the size of its equations read from the checked-in header
  ``generated/<scene>/<scene>.h`` (coordinates, speeds, parameters, inputs, operations after
  CSE, which derivation and why), so the page costs no derivation at build time.  A scene
  listed in :data:`PLOTS` also gets a picture of a short run, drawn at build time from the
  checked-in generated *Python* module (no C compiler, no derivation: about 0.1 s each).
* a ``missing-reference`` handler for docstrings' cross-references into mbgen: a reference to
  a public name by its home path (``mbgen.runtime.compiled.CompiledModel.integrate``) resolves
  to the public page (``mbgen.CompiledModel.integrate``); a reference to an internal object
  that exists (``mbgen.model.limits.MAX_SPEEDS``, or a bare name of the docstring's own
  module) is shown as code, since the reference documents the public names only; a
  reference to something that does not exist stays a warning, so ``-n`` catches typos.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import directives
from docutils.statemachine import StringList
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

ROOT = Path(__file__).resolve().parents[2]
LOG = logging.getLogger(__name__)

# ------------------------------------------------------------------ How to add ...
_ROLE = re.compile(r":[\w:]+:`~?([^`]+)`")
_HEADING = re.compile(r"^(How to add[^\n]*)\n-{3,}\n", re.MULTILINE)
_NEXT_HEADING = re.compile(r"\n[^\n]+\n-{3,}\n")


def howto_section(module: str) -> tuple[str, str]:
    """``(title, body)`` of the "How to add" section of ``module``'s docstring, the roles
    turned into inline code (``:mod:`~a.b``` -> ````a.b````)."""
    doc = importlib.import_module(module).__doc__ or ""
    m = _HEADING.search(doc)
    if not m:
        raise ValueError(f"{module}'s docstring has no 'How to add' section")
    rest = doc[m.end():]
    end = _NEXT_HEADING.search(rest)
    body = rest[:end.start()] if end else rest
    return m.group(1).strip(), _ROLE.sub(lambda r: f"``{r.group(1)}``", body).strip("\n")


class HowTo(SphinxDirective):
    """``{mbgen-howto} mbgen.derivation``: the module's "How to add" list, with its title."""

    required_arguments = 1

    def run(self):
        module = self.arguments[0]
        title, body = howto_section(module)
        self.env.note_dependency(importlib.import_module(module).__file__)
        rubric = nodes.rubric(text=f"{title} ({module})")
        box = nodes.container(classes=["mbgen-howto"])
        self.state.nested_parse(StringList(body.splitlines(), source=module), 0, box)
        return [rubric, box]


# --------------------------------------------------------------------------- gallery
#: Scenes drawn at build time: (scene, end time of the run).  Every scene is cheap to run
#: from its generated Python; the list keeps the build short and the pictures telling.
PLOTS = {
    "bead_wire": 2.0, "bent_pipe": 3.0, "disc_pendulum": 10.0, "paraboloid": 6.0,
    "spherical_rod": 4.0, "spring_pendulum": 0.05, "torque_free": 10.0,
    "n_link_cart": 4.0, "spatial_arm": 2.0,
}
_DEFINE = re.compile(r"#define (\w+)_N_([QUXPR]) (\d+)")


def header_facts(scene: str) -> dict[str, str]:
    """What ``generated/<scene>/<scene>.h`` states about the scene's equations."""
    folder = ROOT / "generated" / scene
    (header,) = [p for p in folder.glob("*.h") if not p.name.endswith("_batch.h")][:1] or [None]
    if header is None:
        return {}
    text = header.read_text(encoding="utf-8")
    facts = {f"n_{k.lower()}": v for _, k, v in _DEFINE.findall(text)}
    for key in ("Derivation", "Operations", "Equations", "Constraints"):
        m = re.search(rf"^ \* {key}:\s+(.*)$", text, re.MULTILINE)
        if m:
            facts[key.lower()] = m.group(1).strip()
    facts["functions"] = ", ".join(sorted(set(re.findall(
        rf"^int {re.escape(header.stem)}_(\w+)\(", text, re.MULTILINE))))
    facts["header"] = header.relative_to(ROOT).as_posix()
    return facts


def _plot(scene_name: str, t_end: float) -> bytes | None:
    """A PNG of a short run of ``scene_name``, integrated from its checked-in generated
    Python (``generated/<scene>/<scene>.py``: no derivation, no compiler); None where
    matplotlib is missing."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    import importlib.util
    import inspect
    import io

    import numpy as np
    from scipy.integrate import solve_ivp

    import mbgen

    scene = mbgen.load_scene(scene_name)
    source = ROOT / "generated" / scene_name / f"{scene_name}.py"
    spec = importlib.util.spec_from_file_location(f"_gallery_{scene_name}", source)
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    x0 = [float(scene.initial_state.get(n, 0.0)) for n in gen.STATE_NAMES]
    args = {"p": list(getattr(gen, "DEFAULT_PARAMETERS", ())), "r": [0.0] * len(gen.INPUT_NAMES)}
    extra = [args[a] for a in list(inspect.signature(gen.rhs).parameters)[2:]]
    t = np.linspace(0.0, t_end, 400)
    sol = solve_ivp(lambda tt, x: gen.rhs(tt, x, *extra), (0.0, t_end), x0, t_eval=t,
                    method="DOP853", rtol=1e-8, atol=1e-10)
    fig, ax = plt.subplots(figsize=(6.4, 2.6), dpi=90)
    for k, name in enumerate(gen.STATE_NAMES[:gen.N_Q]):
        ax.plot(sol.t, sol.y[k], label=name, lw=1.2)
    ax.set_xlabel("t")
    ax.set_title(f"{scene_name}: the coordinates from the scene's start", fontsize=9)
    if gen.N_Q <= 8:
        ax.legend(fontsize=7, ncol=min(gen.N_Q, 4), loc="best")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


class Gallery(SphinxDirective):
    """``{mbgen-gallery}``: every built-in scene, with its size and (some) a picture."""

    option_spec = {"no-plots": directives.flag}

    def run(self):
        from mbgen.model.scene import builtin_names, load_scene, scene_options

        out: list[nodes.Node] = []
        for name in builtin_names():
            scene = load_scene(name)
            opts = scene_options(name)
            facts = header_facts(name)
            section = nodes.section(ids=[f"scene-{name.replace('_', '-')}"])
            section += nodes.title(text=name)
            section += nodes.paragraph(text=scene.description[:1].upper()
                                       + scene.description[1:] + ".")
            rows = [
                ("command", f"mbgen simulate {name}"),
                ("options", ", ".join(f"-O {k}={v}" for k, v in opts.items()) or "none"),
                ("state", _state_size(facts)),
                ("parameters, inputs", f"{facts.get('n_p', '?')}, {facts.get('n_r', '?')}"),
                ("operations", facts.get("operations", "?")),
                ("derivation", facts.get("derivation", "?")),
                ("generated functions", facts.get("functions", "?")),
                ("checked-in code", facts.get("header", "?")),
            ]
            section += _table(rows)
            if name in PLOTS and "no-plots" not in self.options:
                image = self._picture(name)
                if image is not None:
                    section += image
            out.append(section)
        return out

    def _picture(self, name: str):
        """An image node holding the run's PNG inline (a data URI: nothing is written
        into the source tree, and the page carries its pictures)."""
        import base64
        try:
            png = _plot(name, PLOTS[name])
        except Exception as exc:  # a picture is a plus; the page stands without it
            LOG.info(f"gallery: no picture of {name}: {exc}")
            return None
        if png is None:
            return None
        uri = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
        return nodes.image(uri=uri, alt=f"a run of {name}", candidates={"*": uri})


def _state_size(facts: dict[str, str]) -> str:
    """``n_x (coordinates n_q, independent speeds n_x - n_q)`` from the header's facts."""
    if "n_x" not in facts or "n_q" not in facts:
        return "?"
    n_x, n_q = int(facts["n_x"]), int(facts["n_q"])
    return f"{n_x} (coordinates {n_q}, independent speeds {n_x - n_q})"


def _table(rows):
    table = nodes.table(classes=["mbgen-scene"])
    group = nodes.tgroup(cols=2)
    table += group
    group += nodes.colspec(colwidth=25)
    group += nodes.colspec(colwidth=75)
    body = nodes.tbody()
    group += body
    for key, value in rows:
        row = nodes.row()
        row += nodes.entry("", nodes.paragraph(text=key))
        row += nodes.entry("", nodes.paragraph("", "", nodes.literal(text=value))
                           if key in ("command", "options", "checked-in code")
                           else nodes.paragraph(text=value))
        body += row
    return table


# ----------------------------------------------------------------- references
def _public() -> dict[str, str]:
    import mbgen
    return {name: module for module, names in mbgen._PUBLIC.items() for name in names}


def _exists(dotted: str) -> bool:
    """Whether ``dotted`` names a module or an attribute path inside one."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attr in parts[cut:]:
            if attr in getattr(obj, "__annotations__", {}) or attr in getattr(
                    obj, "__dataclass_fields__", {}):
                obj = None
                continue
            if obj is None or not hasattr(obj, attr):
                return obj is None
            obj = getattr(obj, attr)
        return True
    return False


_DOCSTRING_OF = re.compile(r"docstring of ([\w.]+)")


def _candidates(target: str, node) -> list[str]:
    """Where a docstring's reference may point: as written, and relative to the documented
    object's own module and class (docstrings name their neighbours bare: ``MAX_STEPS``)."""
    found = [target]
    if target.startswith("mbgen."):
        return found
    m = _DOCSTRING_OF.search(node.source or "")
    if m:
        parts = m.group(1).split(".")
        found += [".".join(parts[:k] + [target]) for k in range(len(parts) - 1, 0, -1)]
    else:  # an autosummary line: its object's module is not recorded; try the homes
        found += [f"{home}.{target}" for home in sorted(set(_public().values()))]
    return found


def resolve_mbgen(app, env, node, contnode):
    """``missing-reference``: public names by their home path resolve; internal names that
    exist show as code; the rest stay a warning."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"]
    public = _public()
    py = env.get_domain("py")
    for cand in _candidates(target, node):
        parts = cand.split(".")
        for k, part in enumerate(parts):
            if part in public and (k == 0 or ".".join(parts[:k]) in ("mbgen", public[part])):
                alias = "mbgen." + ".".join(parts[k:])
                if alias != target:
                    ref = py.resolve_xref(env, node["refdoc"], app.builder, node["reftype"],
                                          alias, node, contnode)
                    if ref is not None:
                        return ref
        if cand.startswith("mbgen") and _exists(cand):
            return contnode
    return None


def setup(app):
    app.add_directive("mbgen-howto", HowTo)
    app.add_directive("mbgen-gallery", Gallery)
    app.connect("missing-reference", resolve_mbgen)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
