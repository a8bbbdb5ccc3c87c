"""Shared plumbing of the paper figures: arguments, saving, and 3-D axes showing the unit sphere.

Not a figure itself (``make figures`` runs ``paper_figures/fig*.py`` and ``exp_*.py`` only). The sphere drawing
reuses the helpers of :mod:`spherekin.plot` (great-circle arcs, near/far splitting of curves,
joint dots, wireframe, view direction), so the figures look like ``spherekin solve --plot``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

from experiments import _common  # the shared argument parser

from spherekin.plot import (ZOOM, _draw_curve, _draw_point, _draw_sphere,  # noqa: E402
                            _view_direction, great_circle_arc, residual_text)

__all__ = ["HERE", "DPI", "parser", "experiment_data", "save", "save_numbers", "sphere_axes", "draw_arc", "draw_curve", "draw_point", "label_at",
           "view_for", "great_circle_arc", "polygon", "along", "away", "residual_phrase"]

#: Resolution of the PNG files: 150 dpi keeps 9-point labels sharp on screen and in the README.
DPI = 150
#: File metadata left out of the written figures: the matplotlib version (PNG "Software", PDF
#: "Creator"/"Producer") and the PDF's creation date. Without them the same drawing gives the same
#: bytes, so `make figures` leaves the committed PNGs unchanged unless a figure changed.
METADATA = {"png": {"Software": None}, "pdf": {"Creator": None, "Producer": None, "CreationDate": None}}
#: Labels are pushed this far outside the sphere (radial factor) so they do not sit on the arcs.
LABEL_RADIUS = 1.13


def parser(description: str):
    """experiments/_common.parser (--quick, --seed, --out-dir) with --out-dir defaulting to paper_figures/."""
    p = _common.parser(description)
    p.set_defaults(out_dir=HERE)
    return p


def experiment_data(name: str, path: Path | None = None) -> tuple[dict, bool]:
    """(data, quick) of experiments/<name>.py: ``path`` if given, else its latest run --
    experiments/results/<name>.json (``make experiments FULL=1``), else results/quick/<name>.json
    (``make experiments``), else a quick run made now (written to results/quick/). ``quick`` says
    the data is a quick run. The JSON files are generated and not committed; the committed PNGs of
    exp_convergence, exp_parameterizations, exp_scaling come from full runs, and :func:`save` never replaces them with a quick run's.
    """
    import importlib
    import json

    if path is not None:
        return json.loads(Path(path).read_text()), "quick" in Path(path).parts
    full, quick = _common.RESULTS / f"{name}.json", _common.RESULTS / "quick" / f"{name}.json"
    if full.exists():
        return json.loads(full.read_text()), False
    if not quick.exists():
        importlib.import_module(f"experiments.{name}").main(["--quick"])
    return json.loads(quick.read_text()), True


def save(fig, out_dir, name: str, *, quick: bool = False, dpi: float = DPI) -> list[Path]:
    """Write ``<out_dir>/<name>.png`` and ``.pdf`` (without METADATA: same drawing, same bytes); return
    both paths. A figure of ``quick`` data is not written over the committed figures of paper_figures/
    (they come from full runs): it goes to paper_figures/quick/ (not committed) instead, and a line says so."""
    out = Path(out_dir)
    if quick and out.resolve() == HERE:
        out = HERE / "quick"
        print(f"note: {name} is drawn from a quick run of its experiment; written to {out}/, not over the "
              f"committed figure (run 'make experiments FULL=1', then 'make figures', to redraw it)")
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for fmt in ("png", "pdf"):
        path = out / f"{name}.{fmt}"
        fig.savefig(path, format=fmt, dpi=dpi, metadata=METADATA[fmt])
        paths.append(path)
    print(f"wrote {paths[0]} and {paths[1]}")
    return paths


def save_numbers(out_dir, name: str, numbers: dict) -> Path:
    """Write ``<out_dir>/<name>.json``: the numbers a figure computed on the spot and its README section
    quotes (counts, not timings or rounding-level residuals, so a rerun writes the same bytes).

    The committed file is where paper_figures/README.md reads them from (tests/test_paper_figures.py
    compares the README's numbers with it); sorted keys and a trailing newline keep the bytes stable.
    """
    import json

    path = Path(out_dir) / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(numbers, indent=1, sort_keys=True) + "\n")
    print(f"wrote {path}")
    return path


def residual_phrase(residual: float) -> str:
    """"< 1e-12" (rounding noise, spherekin.plot.residual_text) or "= 3.1e-05", to follow "|F - I|" on a figure."""
    text = residual_text(residual)
    return text if text.startswith("<") else f"= {text}"


def view_for(points) -> tuple[np.ndarray, float, float]:
    """Viewing direction (towards the viewer) showing most of ``points`` (N, 3) on the near side."""
    return _view_direction(np.asarray(points, dtype=float).reshape(-1, 3))


def sphere_axes(fig, spec, view_elev_azim, title: str | None = None, pad: float = 2.0):
    """3-D axes on ``spec`` showing the unit sphere (wireframe, outline, x/y/z stubs), orthographic."""
    view, elev, azim = view_elev_azim
    ax = fig.add_subplot(spec, projection="3d", computed_zorder=False)
    ax.set_proj_type("ortho")
    ax.view_init(elev=elev, azim=azim)
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-1.0, 1.0)
    ax.set_box_aspect((1.0, 1.0, 1.0), zoom=ZOOM)
    ax.set_axis_off()
    _draw_sphere(ax, view)
    if title:
        ax.set_title(title, fontsize=10.5, pad=pad)
    return ax


def draw_arc(ax, p, q, view, colour, width=2.2, zorder=3):
    """The shorter great-circle arc p -> q: solid on the near side, dashed and faded on the far side."""
    pts = great_circle_arc(p, q)
    _draw_curve(ax, pts, view, colour, width, zorder)
    return pts


def draw_curve(ax, points, view, colour, width=1.2, zorder=3):
    _draw_curve(ax, np.asarray(points, dtype=float), view, colour, width, zorder)


def draw_point(ax, p, view, colour, marker="o"):
    _draw_point(ax, np.asarray(p, dtype=float), view, colour, marker)


def label_at(ax, p, text, view, colour="black", radius=LABEL_RADIUS, fontsize=9, **kw):
    """Text at the radial projection of p to ``radius`` (faded when p is on the far hemisphere)."""
    p = np.asarray(p, dtype=float)
    p = p / np.linalg.norm(p)
    far = float(p @ view) < 0.0
    ax.text(*(radius * p), text, color=colour, fontsize=fontsize, ha="center", va="center",
            alpha=0.55 if far else 1.0, zorder=40, **kw)


def angle_between(a, b) -> float:
    """Unsigned angle (radians) between two vectors."""
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def polygon(vertices) -> dict:
    """Sides, poles and exterior angles (radians) of the spherical polygon with vertices p_1..p_m.

    Side k is the shorter arc p_k -> p_k+1 (p_m+1 = p_1), its pole n_k = p_k x p_k+1 / |.|; the
    exterior angle at p_k is the signed angle about p_k (right-hand rule) from n_k-1 to n_k: the turn
    from the prolongation of the incoming side to the outgoing side, the convention of Eq. (1).
    """
    p = np.array(vertices, dtype=float)
    nxt = np.roll(p, -1, axis=0)
    cross = np.cross(p, nxt)
    sides = np.arctan2(np.linalg.norm(cross, axis=1), np.sum(p * nxt, axis=1))
    poles = cross / np.linalg.norm(cross, axis=1)[:, None]
    prev = np.roll(poles, 1, axis=0)                      # pole of the incoming side at p_k
    exterior = np.arctan2(np.sum(p * np.cross(prev, poles), axis=1), np.sum(prev * poles, axis=1))
    return dict(vertices=p, sides=sides, poles=poles, exterior=exterior, m=len(p))


def along(p, t, dist) -> np.ndarray:
    """The point reached from the unit vector p along the unit tangent t after ``dist`` radians."""
    return math.cos(dist) * np.asarray(p) + math.sin(dist) * np.asarray(t)


def away(p, centre, dist) -> np.ndarray:
    """The point ``dist`` radians from p along the tangent pointing away from ``centre`` (towards it if dist < 0)."""
    p = np.asarray(p, dtype=float)
    d = p - np.asarray(centre, dtype=float)
    d = d - (d @ p) * p
    return along(p, d / np.linalg.norm(d), dist)
