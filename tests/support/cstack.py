"""Stack use of generated C: gcc's ``-fstack-usage`` per function and the deepest call chain.

``stack_usage(cc, folder, files, opt)`` compiles the files and returns ``{function: bytes}``
(a clone such as ``f.constprop.0`` counts for ``f``; unbounded use fails);
``call_graph(source)`` reads which generated function calls which;
``deepest(fn, usage, graph)`` is the largest sum of frames along a chain from ``fn``;
``assert_within_stack_bounds(rendered, folder)`` checks a rendered model against its header's
bounds (and that it compiles strictly).
"""

import re
import subprocess

from checks import CC, assert_compiles_strictly


def stack_usage(cc, tmp_path, files, opt):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    src = next(n for n in files if n.endswith(".c"))
    subprocess.run([cc, "-std=c99", opt, "-fstack-usage", "-c", src, "-o",
                    src.replace(".c", ".o")], cwd=tmp_path, check=True)
    usage = {}
    for line in (tmp_path / src.replace(".c", ".su")).read_text().splitlines():
        m = re.match(r".*:\d+:\d+:(\w+)(?:\.\w+)*\s+(\d+)\s+([\w,]+)", line)
        assert m and m.group(3) in ("static", "dynamic,bounded"), line   # never unbounded
        # a clone (f.constprop.0) counts for f
        usage[m.group(1)] = max(usage.get(m.group(1), 0), int(m.group(2)))
    return usage


def call_graph(source):
    """``{function: names of the functions its body calls}`` from the generated C."""
    bodies = re.findall(r"^(?:static )?(?:int|void|double) (\w+)\([^)]*\)\n\{\n(.*?)^\}",
                        source, re.M | re.S)
    names = {n for n, _ in bodies}
    return {n: {c for c in re.findall(r"\b(\w+)\(", body) if c in names and c != n}
            for n, body in bodies}


def deepest(fn, usage, graph):
    return usage[fn] + max((deepest(c, usage, graph) for c in graph[fn]), default=0)


def assert_within_stack_bounds(rendered, folder):
    """No warning as strict C99 and C++11; gcc's stack use (``-O0``) under the bounds the
    header states, along every call chain."""
    assert_compiles_strictly(rendered.files, rendered.prefix, folder)
    usage = stack_usage(CC, folder, rendered.files, "-O0")
    graph = {f: {c for c in cs if c in usage} for f, cs in call_graph(rendered.source).items()}
    for fn, bound in dict(rendered.stack_bounds).items():
        assert deepest(fn, usage, graph) <= bound, (fn, deepest(fn, usage, graph), bound)
