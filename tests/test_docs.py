"""The documentation site: its links resolve, its reference is complete, and it builds.

The site is ``docs/`` (MyST Markdown pages, Sphinx, the furo theme; ``docs/conf.py``), and
README.md is its front page on GitHub.  Fast checks, no network and no Sphinx needed:

* every internal link of README.md and of every page (``[text](path.md#anchor)``, images
  included) names a file that exists and, where it has an anchor, a heading of that page
  (GitHub's and MyST's slug: lower case, punctuation dropped, spaces to hyphens);
* every page is in a ``toctree`` (a page in none cannot be found from the site's navigation);
* every public name of ``mbgen`` (``mbgen.__all__``) has an entry on an ``docs/api/`` page.

Slow: the whole site builds with ``sphinx-build -W -n --keep-going -b html`` (warnings and
unresolved references are errors) into a temporary folder, and the built pages hold what a
visitor looks for (the navigation, the API entry of ``mbgen.compile``, the gallery's
pictures); then headless Chromium opens the index, a tutorial, the API page of
``mbgen.compile`` and a search for ``from_urdf`` over HTTP on 127.0.0.1, with no console
error, and saves screenshots.  The build needs the ``docs`` extra (``pip install -e
'.[docs]'``), the browser Debian's ``chromium``; each is skipped with that note without it.
The code blocks of the pages run in ``tests/test_readme_blocks.py``.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

import mbgen

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md",
         *sorted(p for p in DOCS.rglob("*.md") if not p.relative_to(DOCS).parts[0].startswith("_"))]
FENCE = re.compile(r"^(```|~~~).*?^\1\s*$", re.MULTILINE | re.DOTALL)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
#: An API entry (autodoc or a py: directive) and the name it documents.
DOCUMENTED = re.compile(r"^\.\. (?:auto(?:class|function|exception|data)|py:\w+):: (\w+)",
                        re.MULTILINE)
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$", re.MULTILINE)
EXTERNAL = re.compile(r"^(https?|mailto|ftp):", re.IGNORECASE)


def _prose(text: str) -> str:
    """``text`` without fenced blocks and inline code (links there are not links)."""
    return INLINE_CODE.sub("", FENCE.sub("", text))


def slug(title: str) -> str:
    """The anchor GitHub and MyST (``myst_heading_anchors``) give a heading: its text without
    markup, lower case, characters other than word characters, ``-`` and spaces dropped,
    spaces turned into hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", title)     # a link keeps its text
    text = text.replace("`", "").replace("*", "")
    return re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """The heading anchors of ``page`` (duplicates get ``-1``, ``-2``, ... as on GitHub) and
    the ids of the API entries on it (``mbgen.Model``: the API pages document the names of
    ``mbgen``)."""
    text = page.read_text(encoding="utf-8")
    found: set[str] = {f"mbgen.{name}" for name in DOCUMENTED.findall(text)}
    for _, title in HEADING.findall(FENCE.sub("", text)):
        base, k = slug(title), 0
        name = base
        while name in found:
            k += 1
            name = f"{base}-{k}"
        found.add(name)
    return found


def links(page: Path) -> list[str]:
    """The link targets of ``page``'s prose."""
    return LINK.findall(_prose(page.read_text(encoding="utf-8")))


def broken_links(page: Path, root: Path = ROOT) -> list[str]:
    """``page: target (why)`` for each internal link of ``page`` that does not resolve
    (paths shown relative to ``root``)."""
    problems = []
    for target in links(page):
        if EXTERNAL.match(target):
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        where = f"{page.relative_to(root)}: {target}"
        if not dest.exists():
            problems.append(f"{where} (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            problems.append(f"{where} (no heading with anchor #{anchor} in "
                            f"{dest.relative_to(root)})")
    return problems


def test_slugs_follow_github():
    assert slug("Newton–Euler, joints and reaction forces") == \
        "newtoneuler-joints-and-reaction-forces"
    assert slug("In CasADi and JAX (`mbgen bench interop`)") == \
        "in-casadi-and-jax-mbgen-bench-interop"
    assert slug("Safety / input rules") == "safety--input-rules"
    assert slug("FMI 2.0 FMUs") == "fmi-20-fmus"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_internal_links_resolve(page):
    problems = broken_links(page)
    assert not problems, "\n".join(problems)


def test_the_link_checker_sees_a_broken_link(tmp_path):
    """A missing page and a missing heading are reported; code is not taken for links."""
    (tmp_path / "b.md").write_text("# B\n\n## A heading\n", encoding="utf-8")
    page = tmp_path / "a.md"
    page.write_text("[ok](b.md#a-heading) [gone](c.md) [bad anchor](b.md#nothing)\n"
                    "`[not a link](x.md)`\n```\n[nor this](y.md)\n```\n[site](https://x.org)\n",
                    encoding="utf-8")
    found = [p.split(": ", 1)[1] for p in broken_links(page, tmp_path)]
    assert found == ["c.md (no such file)", "b.md#nothing (no heading with anchor #nothing "
                                            "in b.md)"]


TOCTREE = re.compile(r"^```\{toctree\}\n(.*?)^```", re.MULTILINE | re.DOTALL)


def test_every_page_is_in_a_toctree():
    named = {DOCS / "index.md"}
    for page in PAGES[1:]:
        for body in TOCTREE.findall(page.read_text(encoding="utf-8")):
            for line in body.splitlines():
                line = line.strip()
                if line and not line.startswith(":"):
                    named.add((page.parent / f"{line}.md").resolve())
    orphans = [p.relative_to(ROOT).as_posix() for p in PAGES[1:] if p.resolve() not in named]
    assert not orphans, f"pages in no toctree (add them to one): {orphans}"


def test_every_public_name_is_in_the_reference():
    """Each name of ``mbgen.__all__`` has an entry on a page of docs/api/ (and no entry
    names something mbgen does not export)."""
    documented = set()
    for page in (DOCS / "api").glob("*.md"):
        documented |= set(DOCUMENTED.findall(page.read_text(encoding="utf-8")))
    public = set(mbgen.__all__) - {"__version__"}
    assert public - documented == set(), f"public names without an API entry: " \
                                         f"{sorted(public - documented)}"
    assert documented - public == set(), f"API entries of no public name: " \
                                         f"{sorted(documented - public)}"


def _docs_tools():
    for module in ("sphinx", "myst_parser", "furo", "numpydoc"):
        pytest.importorskip(module, reason=f"{module} is missing: the site needs the docs "
                                           f"extra, pip install -e '.[docs]'")


def build_site(out: Path) -> subprocess.CompletedProcess:
    """``python -m sphinx -W -n --keep-going -b html docs OUT`` in a child process."""
    return subprocess.run([sys.executable, "-m", "sphinx", "-W", "-n", "--keep-going", "-q",
                           "-b", "html", "-d", str(out / ".doctrees"), str(DOCS), str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=1200)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built once for the slow tests of this file (its folder)."""
    _docs_tools()
    out = tmp_path_factory.mktemp("site") / "html"
    proc = build_site(out)
    assert proc.returncode == 0, f"sphinx-build failed:\n{proc.stdout}\n{proc.stderr}"
    return out


@pytest.mark.slow
def test_the_site_builds_without_warnings(site):
    """The documented command builds the site (the fixture fails on any warning: a broken
    reference, a page in no toctree, a docstring that does not parse), and the pages hold
    what a visitor looks for."""
    index = (site / "index.html").read_text(encoding="utf-8")
    assert "Getting started" in index and 'class="sidebar-tree"' in index
    api = (site / "api" / "pipeline.html").read_text(encoding="utf-8")
    assert 'id="mbgen.compile"' in api
    gallery = (site / "gallery.html").read_text(encoding="utf-8")
    assert gallery.count("data:image/png;base64,") >= 5, "the gallery lost its pictures"
    for name in ("whipple", "four_bar", "spatial_arm"):
        assert f'id="scene-{name.replace("_", "-")}"' in gallery
    assert (site / "searchindex.js").is_file()


# ----------------------------------------------------------------- in a real browser
BROWSERS = ("chromium", "chromium-browser", "google-chrome")
#: Console messages that mean a page is broken (Chromium logs every console message at
#: INFO; these are the error kinds).
CONSOLE_ERROR = re.compile(r":CONSOLE[^\]]*\] \"(.*(?:Uncaught|Error|Failed|blocked|"
                           r"404|not found).*)\", source", re.IGNORECASE)


def _chromium() -> str:
    import os
    import shutil
    found = os.environ.get("MBGEN_CHROMIUM") or next(
        (shutil.which(b) for b in BROWSERS if shutil.which(b)), None)
    if not found:
        pytest.skip("no Chromium: install Debian's `chromium` (apt-get install -y chromium) "
                    "or set MBGEN_CHROMIUM to a Chromium executable")
    return found


@pytest.fixture(scope="module")
def served(site):
    """The built site over HTTP on 127.0.0.1 (Sphinx's search fetches pages, which a
    browser refuses for file:// URLs); the base URL."""
    import functools
    import http.server
    import threading

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    handler = functools.partial(Quiet, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    thread.join()


def browse(url: str, *flags: str) -> tuple[str, list[str]]:
    """Open ``url`` in headless Chromium (JavaScript run for up to 8 s of virtual time);
    ``(stdout, console errors)``."""
    proc = subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                           "--no-first-run", "--disable-extensions", "--enable-logging=stderr",
                           "--v=0", "--virtual-time-budget=8000", *flags, url],
                          capture_output=True, text=True, timeout=120)
    return proc.stdout, CONSOLE_ERROR.findall(proc.stderr)


@pytest.mark.slow
@pytest.mark.parametrize("page, expect", [
    ("index.html", ['class="sidebar-tree"', 'href="getting-started.html"',
                    'href="api/index.html"', 'href="tutorials/index.html"']),
    ("tutorials/robots.html", ["Bring a robot", 'class="sidebar-tree"']),
    ("api/pipeline.html", ['id="mbgen.compile"', "mbgen.compile"]),
    ("search.html?q=from_urdf", ['href="api/modelling.html#mbgen.from_urdf"']),
])
def test_pages_in_chromium(served, page, expect):
    """The page loads with no console error, its navigation is there after its scripts ran,
    and the search finds ``from_urdf``."""
    dom, errors = browse(f"{served}/{page}", "--dump-dom")
    assert not errors, f"{page}: console errors: {errors}"
    missing = [e for e in expect if e not in dom]
    assert not missing, f"{page}: not in the page as the browser built it: {missing}"


@pytest.mark.slow
def test_screenshots(served, tmp_path_factory):
    """Screenshots of the index and a tutorial, kept as the run's artefacts (pytest's
    temporary folder, ``docs-screenshots*``), and not blank."""
    folder = tmp_path_factory.mktemp("docs-screenshots")
    for page, name in (("index.html", "index.png"), ("tutorials/robots.html", "robots.png")):
        shot = folder / name
        browse(f"{served}/{page}", f"--screenshot={shot}", "--window-size=1280,900",
               "--hide-scrollbars")
        assert shot.is_file(), f"no screenshot of {page}"
        plt = pytest.importorskip("matplotlib.pyplot")
        pixels = plt.imread(shot)
        assert pixels.shape[:2] == (900, 1280) and pixels.std() > 0.05, f"{page}: blank"


#: Appended to a copy of `mbgen animate`'s page: show the frame named in the URL's query
#: (the player is matplotlib's: a global ``anim<id>`` object with ``set_frame``).
SHOW_FRAME = """<script>setTimeout(function () {
  var f = Number(new URLSearchParams(location.search).get("frame") || 0);
  for (var k in window) {
    if (k.indexOf("anim") === 0 && window[k] && window[k].set_frame) { window[k].set_frame(f); }
  }
}, 300);</script>
"""


@pytest.mark.slow
def test_the_animation_page_in_chromium(tmp_path, tmp_path_factory, monkeypatch):
    """The HTML page `mbgen animate` writes opens with no console error and draws its
    frames: two frames differ, pixel by pixel, in screenshots (kept as artefacts)."""
    browser = _chromium()
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from mbgen.cli import main as mbgen_main

    monkeypatch.chdir(tmp_path)
    assert mbgen_main(["animate", "disc_pendulum", "-o", "anim.html", "--frames", "20"]) == 0
    page = tmp_path / "anim.html"
    _, errors = browse(page.as_uri(), "--dump-dom")
    assert not errors, f"console errors on the animation page: {errors}"
    probe = tmp_path / "probe.html"
    probe.write_text(page.read_text(encoding="utf-8").replace("</body>", SHOW_FRAME + "</body>"),
                     encoding="utf-8")
    folder = tmp_path_factory.mktemp("docs-screenshots")
    shots = []
    for frame in (0, 12):
        shot = folder / f"animation_frame{frame}.png"
        subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                        "--hide-scrollbars", "--window-size=900,700",
                        "--virtual-time-budget=3000", f"--screenshot={shot}",
                        f"{probe.as_uri()}?frame={frame}"], capture_output=True, timeout=120)
        assert shot.is_file(), f"no screenshot of frame {frame}"
        shots.append(plt.imread(shot))
    assert shots[0].std() > 0.02, "the animation page is blank"
    changed = (abs(shots[0] - shots[1]).max(axis=-1) > 0.1).mean()
    assert changed > 0.001, f"frames 0 and 12 look the same ({changed:.2%} of pixels differ)"
