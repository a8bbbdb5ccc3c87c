"""Sphinx configuration of spherekin's documentation site (``make docs``; docs/development.md).

The pages are MyST Markdown (the docs/*.md files are pages as they are); the API reference is
generated from the docstrings of the names each public module lists in ``__all__`` (autosummary, with
napoleon for numpydoc-style sections); the gallery runs examples/gallery/plot_*.py at build time.
"""

import importlib
import os
import inspect
import re
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))            # document the checkout's package, not an installed copy
sys.path.insert(0, str(DOCS / "_ext"))   # the gallery's scraper

import spherekin  # noqa: E402

project = "spherekin"
author = "The spherekin developers"
copyright = "2026, The spherekin developers"
release = version = spherekin.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
# _ext: Python; figures: images of the pages; gallery/api/generated: written by the build
exclude_patterns = ["_build", "_ext", "_templates", "figures", "gallery/*.md5"]

# MyST: heading anchors so that links such as results-format.md#what-count-proven-means resolve
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence", "dollarmath"]

# The API reference: one page per public module, its names from __all__ (docs/api.md). The stubs are
# written anew at every build: autosummary never removes the stub of a name that left an __all__, and a
# stale stub fails the build (-W) once the name is gone from its module.
autosummary_generate = True
shutil.rmtree(DOCS / "generated", ignore_errors=True)
#: The modules of the API reference: the names listed in api.md's autosummary (the one list).
API_MODULES = re.findall(r"^ {3}(spherekin[\w.]*)$", (DOCS / "api.md").read_text(), flags=re.M)


def _reexported(modules):
    """Per module, the classes of its ``__all__`` whose home is another documented module (e.g.
    spherekin.problem re-exports spherekin.systems' Strategy): documented there only, since a
    class documented twice is a duplicate-object warning (the template leaves them out)."""
    def under(home, name):
        return home == name or home.startswith(name + ".")

    out = {}
    for name in modules:
        module = importlib.import_module(name)
        for item in getattr(module, "__all__", ()):
            obj = getattr(module, item)
            home = getattr(obj, "__module__", "") or ""
            if inspect.isclass(obj) and not under(home, name) and any(
                    under(home, other) for other in modules if other not in (name, "spherekin")):
                out.setdefault(name, []).append(item)
    return out


autosummary_context = {"reexported": _reexported(API_MODULES)}
autosummary_ignore_module_all = False
autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_google_docstring = False
napoleon_numpy_docstring = True

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples" / "gallery"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",          # every script is run at build time
    "abort_on_example_error": True,         # a broken example fails the build
    "image_scrapers": ("spherekin_gallery.scrape_figures", "matplotlib"),   # ours first: it skips pyplot's figures while pyplot still holds them
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
}

#: Repository files included as pages (docs/paper/*.md): their links to one another become links
#: to those pages (they are written for GitHub, relative to the repository's files).
INCLUDED_PAGES = {"verification/REPORT.md": "paper/verification", "experiments/README.md": "paper/experiments",
                  "paper_figures/README.md": "paper/figures", "CHANGELOG.md": "changelog"}


def _link_included_pages(app, relative_path, parent_docname, content):
    """include-read: in an included repository file, a link to another included file -> its page, and a
    link to a data file beside it (``[numbers](exp_solutions.json)``) -> that file as seen from the page
    that includes it (MyST resolves a link against the including page, where the name alone is not found)."""
    for repo_path, page in INCLUDED_PAGES.items():
        pattern = r"\]\((?:\.\./)*" + re.escape(repo_path) + r"(#[^)]*)?\)"
        content[0] = re.sub(pattern, lambda m: f"](/{page}.md{m.group(1) or ''})", content[0])
    source = Path(app.srcdir, relative_path).resolve()
    page = INCLUDED_PAGES.get(source.relative_to(ROOT).as_posix()) if source.is_relative_to(ROOT) else None
    if page is None:
        return
    parent = Path(app.srcdir, page).parent              # the including page's folder (docs/paper)

    def beside(m):
        target = (source.parent / m.group(2)).resolve()
        if target.suffix in (".md", ".png", ".svg", ".pdf") or not target.is_file():
            return m.group(0)                 # pages and images are handled above and by :relative-images:
        return f"{{download}}`{m.group(1)} <{os.path.relpath(target, parent)}>`"

    content[0] = re.sub(r"\[`?([^\]`]+)`?\]\(([\w./-]+\.\w+)\)", beside, content[0])


def setup(app):
    app.connect("include-read", _link_included_pages)


html_theme = "alabaster"
html_title = f"spherekin {release}"
# the site's icon (a browser asks for one; without it every page logs a 404: tests/test_docs_site.py)
html_static_path = ["_static"]
html_favicon = "_static/favicon.svg"
# alabaster's 940 px cut the gallery's result tables (seen in headless Chromium's screenshots)
html_theme_options = {"page_width": "1180px"}
