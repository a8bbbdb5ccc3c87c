"""Every gallery script (examples/gallery/plot_*.py, the site's gallery: docs/development.md) runs
as a test, so that a broken example fails ``make test`` without building the site.

Each script runs in this process (runpy, as ``__main__``) with the Agg backend, in an empty
temporary working directory: an example may read no file of the checkout. It must end in a figure:
a matplotlib Figure in its globals (what spherekin.plot returns) or an open pyplot figure.
"""

import ast
import runpy
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

GALLERY = Path(__file__).resolve().parents[1] / "examples" / "gallery"
SCRIPTS = sorted(GALLERY.glob("plot_*.py"))


def test_gallery_has_examples():
    assert len(SCRIPTS) >= 4, f"expected at least 4 gallery scripts in {GALLERY}, got {len(SCRIPTS)}"
    assert (GALLERY / "README.rst").is_file(), "sphinx-gallery needs the gallery's README.rst"


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_gallery_script_has_a_title(script):
    """sphinx-gallery takes the page title from the module docstring: a title line underlined with '='."""
    doc = ast.get_docstring(ast.parse(script.read_text()))
    assert doc, f"{script.name}: expected a module docstring with a title, got none"
    lines = doc.splitlines()
    assert len(lines) >= 2 and lines[1].strip() and set(lines[1].strip()) == {"="} \
        and len(lines[1].strip()) >= len(lines[0].strip()), \
        f"{script.name}: expected a title underlined with '=' (as long as the title), got {lines[:2]}"


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_gallery_script_runs_and_ends_in_a_figure(script, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    plt.close("all")
    try:
        names = runpy.run_path(str(script), run_name="__main__")
        figures = [v for v in names.values() if isinstance(v, Figure)] + plt.get_fignums()
        assert figures, f"{script.name}: expected it to end in a matplotlib figure, got none"
    finally:
        plt.close("all")
    assert list(tmp_path.iterdir()) == [], f"{script.name}: left files in its working directory"
