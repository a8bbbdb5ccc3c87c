"""Plots of solved configurations: the mechanism drawn on the unit sphere, one panel per solution.

Every joint axis of a spherical mechanism passes through the centre O, so it meets the unit sphere
in a point, and every link (the rigid body between two consecutive joints) is drawn as the shorter
great-circle arc between those points; the arc's length is the link twist. This is the picture of
the paper's Fig. 2 (Gosselin platform), drawn here for each solution of the direct kinematics:

* the base: arcs between consecutive base joint axes (the first joint of each leg), near-black;
* each leg: arcs from its base axis through its intermediate axes to its platform axis (for a
  3-RRR u_i -> w_i -> v_i), one colour per leg;
* the platform: arcs between consecutive platform joint axes (the last joint of each leg), red;
* joint axes as dots (squares for actuated joints), over a light wireframe of the sphere.

Every panel is viewed from the same direction, the one (of a lattice of candidates) that shows
most of the drawn links of all panels well inside the near hemisphere, so the mechanism faces the
viewer; z points up. The view is orthographic, so the sphere's outline is the great circle normal
to that direction, and whatever lies on the far hemisphere is drawn dashed and faded (matplotlib's
3-D axes do not hide lines behind the sphere). A mechanism spread over more than a hemisphere (a
base all around the sphere, as in a symmetric 3-RRR) always has a part on the far side.

The current joint axes come from :meth:`SphericalMechanism.jacobians` (the columns of a leg's
Jacobian are its joint axes in the current configuration, base frame), so no kinematics is
repeated here. The figure is built on :class:`matplotlib.figure.Figure` (no pyplot, no global
state) and written with the Agg/PDF/SVG canvases. Not in the paper: plotting is a convenience.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from . import atomic
from .core.angles import wrap
from .mechanism.chains import perpendicular
from .mechanism.checks import check_unit_vector, parse_angle
from .mechanism.model import PARALLEL_TOL, SphericalMechanism
from .results import SolveReport

__all__ = [
    "plot_singular",
    "ARC_POINTS",
    "PLOT_FORMATS",
    "INPUTS_TOL",
    "great_circle_arc",
    "current_joint_axes",
    "plot_solutions",
    "plot_report",
    "check_plot_path",
    "plot_assembly_map",
    "plot_track",
    "plot_branches",
    "residual_text",
    "RESIDUAL_NOISE",
    "NO_ASSEMBLY_LABEL",
]

#: Points per link arc. Reason: a chord of an arc of at most pi split into 63 pieces deviates from
#: the circle by 1 - cos(pi / 126) = 3e-4 of the radius, below a tenth of a pixel at panel size.
ARC_POINTS = 64
#: Points per wireframe circle (same reason, for full circles).
WIRE_POINTS = 181
#: File formats written (by the file name's suffix): the ones matplotlib writes without extra
#: packages; PNG for viewing, PDF/SVG for papers.
PLOT_FORMATS = ("png", "pdf", "svg")
#: ``|input - input the report was solved at|`` (radians, modulo 2 pi) above which the inputs are
#: rejected. Reason: the solver records the very floats it was given (a degree -> radian
#: conversion repeated gives the same float); anything farther apart is another problem, whose
#: drawing would show legs that do not close.
INPUTS_TOL = 1e-9
#: Panels per row of the grid (four 3.4-inch panels make a 13.6-inch, ~1630-pixel-wide figure).
MAX_COLUMNS = 4
#: Size of one panel, of the header (figure title) and of the footer (legend), in inches, and the
#: resolution (dots per inch) of raster output.
PANEL_INCHES = 3.4
HEADER_INCHES = 0.9
DPI = 120
#: Legend layout (inches): one row of entries takes LEGEND_ROW_INCHES; an entry is its handle plus
#: about LEGEND_CHAR_INCHES per character at font size 9; the entries fill at most LEGEND_FILL of
#: the figure width; figures are at least MIN_COLUMNS panels wide so that titles and legend fit.
LEGEND_ROW_INCHES = 0.28
LEGEND_MARGIN_INCHES = 0.2
LEGEND_HANDLE_INCHES = 0.6
LEGEND_CHAR_INCHES = 0.075
LEGEND_FILL = 0.95
MIN_COLUMNS = 2
#: Zoom of the 3-D box in its panel: the unit sphere then fills about 90% of the panel.
ZOOM = 1.35
#: Candidate viewing directions (a Fibonacci lattice; neighbours ~4 deg apart, finer than needed
#: for a view) and the cosine above which a point counts as clearly on the near side (it is then
#: more than 12 deg inside the outline, where arcs are not foreshortened into slivers).
VIEW_CANDIDATES = 2000
VISIBLE_DOT = 0.2

#: Joint names are written this far (points) from their dot, and a dot counts as this half-width
#: (points) when labels avoid dots; two dots closer than that on screen share one label.
LABEL_GAP = 4.0
LABEL_DOT = 3.5
#: Colours: legs cycle through these (distinct from the base's black and the platform's red).
LEG_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:cyan", "tab:pink",
               "tab:olive")
#: Closure residuals below this are rounding noise of double precision (1e-16..1e-14 whose digits
#: depend on the CPU's BLAS kernel): figures print them as "< 1e-12" and stay the same on every machine.
RESIDUAL_NOISE = 1e-12
BASE_COLOUR = "#262626"  # near-black, distinct from the black of the text
PLATFORM_COLOUR = "tab:red"
#: The joints of a mechanism that is not legs (a graph: its links take LEG_COLOURS): one neutral colour.
JOINT_COLOUR = "0.25"
#: The group name of :func:`current_joint_axes` for the joints of a mechanism that is not legs.
GRAPH_JOINTS = "joints"


def joint_groups(mechanism: SphericalMechanism) -> list[tuple[str, tuple, str]]:
    """(name, joints, colour) of each group of joints a figure draws: the legs (LEG_COLOURS), or, for a
    mechanism that is not legs (a graph), every joint as one group (:data:`GRAPH_JOINTS`, JOINT_COLOUR)."""
    if mechanism.legs:
        return [(leg.name, leg.joints, LEG_COLOURS[i % len(LEG_COLOURS)]) for i, leg in enumerate(mechanism.legs)]
    return [(GRAPH_JOINTS, mechanism.joints, JOINT_COLOUR)]


# --------------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------------

def great_circle_arc(p, q, n_points: int = ARC_POINTS) -> np.ndarray:
    """Points of the shorter great-circle arc from the unit vector p to the unit vector q, shape (n_points, 3).

    x(t) = cos(t theta) p + sin(t theta) e, t = 0, 1/(n-1), ..., 1, where theta = angle(p, q) in
    [0, pi] and e = n x p is the unit tangent at p towards q (n = p x q / ``|p x q|``), so the points
    are equally spaced in angle. Coincident endpoints give n copies of p; for antipodal endpoints
    (``|p x q|`` < PARALLEL_TOL, p . q < 0) every half great circle qualifies and the one with pole
    n = perpendicular(p) is returned, the model's choice for a side of twist pi.
    """
    a = np.array(check_unit_vector("p", p))
    b = np.array(check_unit_vector("q", q))
    if isinstance(n_points, (bool, np.bool_)) or not isinstance(n_points, (int, np.integer)) or n_points < 2:
        raise ValueError(f"n_points: expected an integer >= 2, got {n_points!r}")
    cross = np.cross(a, b)
    sine, cosine = float(np.linalg.norm(cross)), float(a @ b)
    theta = math.atan2(sine, cosine)
    pole = cross / sine if sine >= PARALLEL_TOL else perpendicular(a)
    tangent = np.cross(pole, a)
    t = np.linspace(0.0, theta, int(n_points))[:, None]
    return np.cos(t) * a + np.sin(t) * tangent


def current_joint_axes(mechanism: SphericalMechanism, inputs, passive_angles: Mapping[str, float]) -> dict:
    """The joint axes of every leg in the configuration given by the joint readings (radians).

    ``inputs``: one reading per actuated joint (order of ``mechanism.actuated``);
    ``passive_angles``: name -> reading of every passive joint. Returns leg name -> array (k, 3),
    row i the current axis of the leg's i-th joint (base frame): a_i(q) = Rot(a_1, d_1) ...
    Rot(a_{i-1}, d_{i-1}) a_i with d the displacements from the reference configuration -- the
    columns of the leg's Jacobian, taken from :meth:`SphericalMechanism.jacobians`. For a 3-RRR:
    u_i, w_i = Rot(u_i, beta_i) w_i^0, and R v_i^0 when the loops close (each leg's last row is
    its own chain's platform axis, so at a non-closing configuration the legs disagree by the
    closure residual).
    """
    if not isinstance(mechanism, SphericalMechanism):
        raise ValueError(f"mechanism: expected a SphericalMechanism, got {type(mechanism).__name__}")
    values = mechanism.check_inputs(inputs)
    if not isinstance(passive_angles, Mapping):
        raise ValueError(f"passive_angles: expected a mapping joint name -> angle (radians), "
                         f"got {type(passive_angles).__name__}")
    actuated = [n for n in passive_angles if n in mechanism.actuated]
    if actuated:
        raise ValueError(f"passive_angles: {actuated} are actuated joints; give them in inputs")
    unknown = [n for n in passive_angles if n not in mechanism.passive]
    if unknown:
        raise ValueError(f"passive_angles: unknown joint name(s) {unknown}; valid names: {mechanism.passive}")
    missing = [n for n in mechanism.passive if n not in passive_angles]
    if missing:
        raise ValueError(f"passive_angles: missing angle(s) for {missing}")
    readings = {n: parse_angle(f"passive_angles[{n!r}]", v) for n, v in passive_angles.items()}
    readings.update(zip(mechanism.actuated, values))
    if not mechanism.legs:        # a graph: joint [a, b]'s current axis is R_a a_0
        rotations = mechanism.link_rotations(readings)
        graph = mechanism.link_graph
        return {GRAPH_JOINTS: np.array([rotations[a] @ np.asarray(j.axis) for j, (a, _) in zip(graph.joints, graph.links)])}
    legs = mechanism.jacobians(readings)["legs"]
    return {leg.name: np.array(legs[leg.name]).T for leg in mechanism.legs}


# --------------------------------------------------------------------------------------------
# Checks
# --------------------------------------------------------------------------------------------

def check_plot_path(path, key: str = "path") -> tuple[Path, str]:
    """(path, format) of a figure file, checked before any work: an existing directory, a suffix of PLOT_FORMATS.
    ``key``: the name errors give the path (the command line passes its option, "--plot")."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"{key}: expected a file name such as out.png, got {path!r}")
    out = Path(path)
    fmt = out.suffix.lower().lstrip(".")
    if out.is_dir():
        raise ValueError(f"{key}: expected a file name, got the directory {str(out)!r}")
    if not out.parent.is_dir():
        raise ValueError(f"{key}: the directory {str(out.parent)!r} of {str(out)!r} does not exist")
    if fmt not in PLOT_FORMATS:
        raise ValueError(f"{key}: expected a file name ending in one of "
                         f"{', '.join('.' + f for f in PLOT_FORMATS)}, got {out.name!r}")
    atomic.check_writable(out.parent, f"{key} {out}")
    return out, fmt


def _save(fig, out: Path, fmt: str) -> None:
    """``fig`` saved to ``out`` (format ``fmt``, DPI dots per inch) whole or not at all (:mod:`spherekin.atomic`)."""
    with atomic.replacing(out) as tmp:
        fig.savefig(tmp, format=fmt, dpi=DPI)


def _check_report(mechanism: SphericalMechanism, values: tuple, report) -> list[np.ndarray]:
    """The solutions' passive angles (radians, report.unknowns order), after consistency checks."""
    if not isinstance(report, SolveReport):
        raise ValueError(f"report: expected a SolveReport (from spherekin.search.boxloop.solve), got {type(report).__name__}")
    if sorted(report.unknowns) != sorted(mechanism.passive):
        raise ValueError(f"report: expected a solve of this mechanism, whose passive joints are {mechanism.passive}, "
                         f"got a report whose unknowns are {tuple(report.unknowns)}")
    name = report.settings.mechanism
    if name is not None and name != mechanism.name:
        raise ValueError(f"report: expected a solve of this mechanism, {mechanism.name!r}, got a report of {name!r}")
    solved = report.settings.inputs
    if solved:
        diff = np.array([wrap(a - b) for a, b in zip(values, solved)])
        if len(solved) != len(values) or np.abs(diff).max(initial=0.0) > INPUTS_TOL:
            raise ValueError(f"inputs: expected the inputs the report was solved at, {list(solved)} (radians), "
                             f"got {list(values)}")
    out = []
    for k, sol in enumerate(report.solutions):
        angles = np.asarray(sol.angles, dtype=float)
        if angles.shape != (len(report.unknowns),) or not np.all(np.isfinite(angles)):
            raise ValueError(f"report.solutions[{k}].angles: expected {len(report.unknowns)} finite angles "
                             f"(radians), got {sol.angles!r}")
        out.append(angles)
    return out


# --------------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------------

def _split_by_side(points: np.ndarray, view: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Pieces of a polyline on the unit sphere on the near (view . x >= 0) and far hemisphere.

    Where consecutive points change sides, the crossing of their chord with the outline plane,
    pushed back onto the sphere, ends one piece and starts the next.
    """
    side = points @ view
    near = side >= 0.0
    front, back = [], []
    current = [points[0]]
    for i in range(1, len(points)):
        if near[i] != near[i - 1]:
            s = side[i - 1] / (side[i - 1] - side[i])
            x = points[i - 1] + s * (points[i] - points[i - 1])
            x = x / np.linalg.norm(x)
            current.append(x)
            (front if near[i - 1] else back).append(np.array(current))
            current = [x]
        current.append(points[i])
    (front if near[-1] else back).append(np.array(current))
    return [p for p in front if len(p) > 1], [p for p in back if len(p) > 1]


def _draw_curve(ax, points, view, colour, width, zorder, **kw) -> None:
    """A curve on the sphere: solid on the near side, dashed and faded on the far side."""
    front, back = _split_by_side(points, view)
    for piece in back:
        ax.plot(*piece.T, color=colour, lw=0.6 * width, ls=(0, (3, 2)), alpha=0.45, zorder=zorder, **kw)
    for piece in front:
        ax.plot(*piece.T, color=colour, lw=width, zorder=zorder + 10, solid_capstyle="round", **kw)


def _draw_point(ax, p, view, colour, marker) -> None:
    """A joint axis as a dot; smaller, faded and under every near-side line when on the far side."""
    far = float(p @ view) < 0.0
    ax.scatter(*([c] for c in p), s=22 if far else 38, color=colour, marker=marker, edgecolors="white",
               linewidths=0.6, alpha=0.45 if far else 1.0, zorder=4 if far else 30, depthshade=False)


def _draw_sphere(ax, view: np.ndarray) -> None:
    """Light wireframe (meridians every 30 deg, parallels every 30 deg), outline, base frame labels."""
    t = np.linspace(0.0, 2 * math.pi, WIRE_POINTS)
    for lon in np.radians(np.arange(0, 180, 30)):
        circle = np.stack([np.cos(t) * math.cos(lon), np.cos(t) * math.sin(lon), np.sin(t)], axis=1)
        _draw_curve(ax, circle, view, "0.72", 0.6, 0)
    for lat in np.radians(np.arange(-60, 61, 30)):
        circle = np.stack([math.cos(lat) * np.cos(t), math.cos(lat) * np.sin(t),
                           np.full_like(t, math.sin(lat))], axis=1)
        _draw_curve(ax, circle, view, "0.72", 0.6, 0)
    e1 = perpendicular(view)
    e2 = np.cross(view, e1)
    outline = np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2
    ax.plot(*outline.T, color="0.45", lw=0.9, zorder=5)
    for k, label in enumerate("xyz"):
        e = np.eye(3)[k]
        stub = np.outer(np.linspace(1.0, 1.12, 2), e)
        far = float(e @ view) < 0.0
        ax.plot(*stub.T, color="0.35", lw=0.9, alpha=0.45 if far else 1.0, zorder=6)
        ax.text(*(1.2 * e), label, color="0.35", fontsize=8, ha="center", va="center",
                alpha=0.45 if far else 1.0, zorder=6)


def _polygon_arcs(points: Sequence[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Consecutive pairs of a polygon's vertices: one side for two vertices, closed for three or more."""
    if len(points) == 2:
        return [(points[0], points[1])]
    return [(points[i], points[(i + 1) % len(points)]) for i in range(len(points))]


def _configuration_arcs(mechanism: SphericalMechanism, axes: Mapping[str, np.ndarray]) -> list[tuple]:
    """The links of one configuration as (points (ARC_POINTS, 3), colour, line width, z-order), base first.
    A graph: each link the polygon of its joints' axes (one arc for a binary link), the ground in the
    base's colour, the output link in the platform's, the others in LEG_COLOURS."""
    if not mechanism.legs:
        graph = mechanism.link_graph
        current = dict(zip(mechanism.joint_names, axes[GRAPH_JOINTS]))
        arcs = []
        moving = [n for n in graph.link_names if n not in (graph.ground, graph.output)]
        for link in graph.link_names:
            points = [current[graph.joints[k].name] for k in graph.joints_of(link)]
            if len(points) < 2:
                continue
            if link == graph.ground:
                style = (BASE_COLOUR, 2.6, 2)
            elif link == graph.output:
                style = (PLATFORM_COLOUR, 2.6, 2)
            else:
                style = (LEG_COLOURS[moving.index(link) % len(LEG_COLOURS)], 2.2, 3)
            arcs += [(great_circle_arc(p, q), *style) for p, q in _polygon_arcs(points)]
        return arcs
    arcs = [(great_circle_arc(p, q), BASE_COLOUR, 2.6, 2)
            for p, q in _polygon_arcs([axes[leg.name][0] for leg in mechanism.legs])]
    arcs += [(great_circle_arc(p, q), PLATFORM_COLOUR, 2.6, 2)
             for p, q in _polygon_arcs([axes[leg.name][-1] for leg in mechanism.legs])]
    for i, leg in enumerate(mechanism.legs):
        pts = axes[leg.name]
        arcs += [(great_circle_arc(p, q), LEG_COLOURS[i % len(LEG_COLOURS)], 2.2, 3)
                 for p, q in zip(pts[:-1], pts[1:])]
    return arcs


def _draw_configuration(ax, mechanism: SphericalMechanism, axes: Mapping[str, np.ndarray], arcs, view) -> None:
    """Links and joint dots of one configuration (the names: :func:`_label_joints`, once all panels exist)."""
    for points, colour, width, zorder in arcs:
        _draw_curve(ax, points, view, colour, width, zorder)
    for name, joints, colour in joint_groups(mechanism):
        for joint, p in zip(joints, axes[name]):
            _draw_point(ax, p, view, colour, "s" if joint.actuated else "o")


def _screen_points(ax, points) -> np.ndarray:
    """Display coordinates (pixels), shape (N, 2), of 3-D points (N, 3) on a drawn 3-D axes."""
    from mpl_toolkits.mplot3d import proj3d

    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    x, y, _ = proj3d.proj_transform(pts[:, 0], pts[:, 1], pts[:, 2], ax.get_proj())
    return ax.transData.transform(np.column_stack([x, y]))


def _label_joints(fig, panels) -> list:
    """Write the names of the near-side joints beside their dots, none on another label, a dot, the
    x/y/z letters or the panel title, and inside the panel; joints at one point on screen share one
    label ("beta3, delta3"). Returns the Text artists.

    ``panels``: (3-D axes, mechanism, joint axes {leg: (k, 3)}, view direction (3,)) per drawn panel.
    Placement is in display space and needs the panels' projections, so the figure is drawn once
    (Agg) first. Candidates, in order: LABEL_GAP points from the dot along the outward direction
    from the sphere's centre on screen, then turned by 45, 90, ... degrees, then twice as far; the
    first candidate whose box is free wins (if none is, the first candidate).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.patheffects import withStroke   # a white halo keeps a name readable over an arc
    from matplotlib.transforms import Bbox

    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    gap = LABEL_GAP * fig.dpi / 72.0
    dot = LABEL_DOT * fig.dpi / 72.0
    texts = []
    for ax, mechanism, axes, view in panels:
        centre = _screen_points(ax, np.zeros(3))[0]
        taken = [Bbox.from_bounds(x - dot, y - dot, 2 * dot, 2 * dot)
                 for name, _, _ in joint_groups(mechanism) for x, y in _screen_points(ax, axes[name])]
        taken.append(ax.title.get_window_extent(renderer))
        for letter in list(ax.texts):                      # the x, y, z letters (3-D texts) as drawn
            xy = ax.transAxes.inverted().transform(_screen_points(ax, letter.get_position_3d())[0])
            probe = ax.text2D(*xy, letter.get_text(), transform=ax.transAxes, fontsize=letter.get_fontsize(),
                              ha=letter.get_ha(), va=letter.get_va())
            taken.append(probe.get_window_extent(renderer))
            probe.remove()
        groups: list[tuple[np.ndarray, list[str], list[str]]] = []
        for name, joints, colour in joint_groups(mechanism):
            for joint, p, xy in zip(joints, axes[name], _screen_points(ax, axes[name])):
                if float(p @ view) < 0.0:                  # far side: no name (it would sit on the near side)
                    continue
                for g_xy, names, colours in groups:
                    if np.hypot(*(g_xy - xy)) <= dot:      # one point on screen: one label
                        names.append(joint.name)
                        colours.append(colour)
                        break
                else:
                    groups.append((xy, [joint.name], [colour]))
        for xy, names, colours in groups:
            text = ", ".join(names)
            colour = colours[0] if len(set(colours)) == 1 else "0.2"    # several legs: neutral
            out = xy - centre
            base = math.atan2(out[1], out[0]) if np.hypot(*out) > dot else math.pi / 2
            chosen = None
            for radius in (gap, 2 * gap):
                for turn in (0, 1, -1, 2, -2, 3, -3, 4):
                    a = base + turn * math.pi / 4
                    c, s = math.cos(a), math.sin(a)
                    side = math.sin(math.pi / 8)       # within 22.5 deg of vertical (horizontal): centred
                    ha = "left" if c > side else "right" if c < -side else "center"
                    va = "bottom" if s > side else "top" if s < -side else "center"
                    pos = ax.transAxes.inverted().transform(xy + radius * np.array([c, s]))
                    t = ax.text2D(*pos, text, transform=ax.transAxes, fontsize=7, ha=ha, va=va, color=colour,
                                  zorder=31, path_effects=[withStroke(linewidth=2.0, foreground="white")])
                    box = t.get_window_extent(renderer)
                    free = (ax.bbox.contains(box.x0, box.y0) and ax.bbox.contains(box.x1, box.y1)
                            and not any(box.overlaps(b) for b in taken))
                    if chosen is None or free:
                        if chosen is not None:
                            chosen[0].remove()
                        chosen = (t, box)
                        if free:
                            break
                    else:
                        t.remove()
                else:
                    continue
                break
            taken.append(chosen[1])
            texts.append(chosen[0])
    return texts


def _fibonacci_directions(n: int) -> np.ndarray:
    """n nearly uniform unit vectors (Fibonacci lattice on the sphere), shape (n, 3); deterministic."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _view_direction(points: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Unit viewing direction (towards the viewer) and matplotlib's (elevation, azimuth) in degrees.

    ``points`` (N, 3): every drawn point of the mechanism (arc samples) in every panel. The
    direction, among VIEW_CANDIDATES lattice directions, that shows the most of them clearly on the
    near side (d . x >= VISIBLE_DOT), ties broken by the mean of d . x.
    """
    dirs = _fibonacci_directions(VIEW_CANDIDATES)
    dots = points @ dirs.T                                    # (N, candidates)
    score = np.sum(dots >= VISIBLE_DOT, axis=0) + dots.mean(axis=0)
    view = dirs[int(np.argmax(score))]
    elev = math.degrees(math.asin(max(-1.0, min(1.0, float(view[2])))))
    azim = math.degrees(math.atan2(float(view[1]), float(view[0])))
    return view, elev, azim


def _title(mechanism: SphericalMechanism, values: tuple, n: int, degrees: bool) -> str:
    unit = "deg" if degrees else "rad"
    shown = [math.degrees(v) if degrees else v for v in values]
    inputs = ", ".join(f"{name} = {v:+.4g}" for name, v in zip(mechanism.actuated, shown))
    return f"{mechanism.name}: {n} solution(s)\ninputs {inputs} {unit}"


def _panel_title(k: int, sol) -> str:
    status = getattr(sol, "status", None)
    head = f"solution {k}" + (f": {status}" if status else "")
    return f"{head}\nsingularity {sol.singularity or '-'}, residual {residual_text(sol.residual)}"


def residual_text(residual: float | None) -> str:
    """A closure residual as figure text: "< 1e-12" below RESIDUAL_NOISE, else 2 significant digits
    ("3.1e-08"); "-" for None. Used by the panel titles and paper_figures/, so that a figure does not
    change with the machine's rounding."""
    if residual is None:
        return "-"
    return f"< {RESIDUAL_NOISE:.0e}" if abs(residual) < RESIDUAL_NOISE else f"{residual:.1e}"


def _legend_handles(mechanism: SphericalMechanism):
    from matplotlib.lines import Line2D

    if mechanism.legs:
        handles = [Line2D([], [], color=BASE_COLOUR, lw=2.6, label="base")]
        handles += [Line2D([], [], color=LEG_COLOURS[i % len(LEG_COLOURS)], lw=2.2, label=leg.name)
                    for i, leg in enumerate(mechanism.legs)]
        handles += [Line2D([], [], color=PLATFORM_COLOUR, lw=2.6, label="platform")]
    else:
        graph = mechanism.link_graph
        moving = [n for n in graph.link_names if n not in (graph.ground, graph.output)]
        handles = [Line2D([], [], color=BASE_COLOUR, lw=2.6, label=f"{graph.ground} (ground)")]
        handles += [Line2D([], [], color=LEG_COLOURS[i % len(LEG_COLOURS)], lw=2.2, label=n)
                    for i, n in enumerate(moving)]
        if graph.output is not None:
            handles += [Line2D([], [], color=PLATFORM_COLOUR, lw=2.6, label=f"{graph.output} (output)")]
    handles += [
                Line2D([], [], color="0.3", ls="", marker="s", label="actuated joint"),
                Line2D([], [], color="0.3", ls="", marker="o", label="passive joint"),
                Line2D([], [], color="0.3", lw=1.2, ls=(0, (3, 2)), alpha=0.6, label="far side")]
    return handles


def _legend_layout(labels: Sequence[str], width: float) -> tuple[int, list[int]]:
    """Legend columns and entry order so that the entries read row by row and fit ``width`` inches.

    The fewest rows whose columns fit (an entry is its handle plus LEGEND_CHAR_INCHES per
    character); matplotlib fills columns first (np.array_split of the entries), so the entries are
    handed over column by column of the row-major grid.
    """
    n = len(labels)
    entry = [LEGEND_HANDLE_INCHES + LEGEND_CHAR_INCHES * len(t) for t in labels]
    for rows in range(1, n + 1):
        ncol = math.ceil(n / rows)
        columns = [[i for i in range(c, n, ncol)] for c in range(ncol)]
        if sum(max(entry[i] for i in col) for col in columns) <= LEGEND_FILL * width:
            return ncol, [i for col in columns for i in col]
    return 1, list(range(n))


def plot_solutions(mechanism: SphericalMechanism, inputs, report: SolveReport, path=None, *,
                   degrees: bool = False):
    """Draw the mechanism on the unit sphere in every solution of ``report``: the matplotlib Figure,
    also written to ``path`` when one is given (a notebook shows the returned Figure).

    ``mechanism``: the :class:`SphericalMechanism` solved; ``inputs``: its actuator readings
    (radians, the ones ``report`` was solved at); ``report``: the
    :class:`~spherekin.results.SolveReport` of :func:`spherekin.solve`; ``path``: the output file
    (optional), whose suffix (.png, .pdf or .svg) picks the format; ``degrees``: show the inputs
    in degrees in the figure title. One panel per solution, in report order (grid of at most
    MAX_COLUMNS columns), titled with the solution's number, status (when the report has one),
    singularity kind and closure residual. A report without solutions gives a figure saying
    "no solution in range". Returns the Figure. Bad input raises ValueError, before anything is drawn.
    """
    if not isinstance(mechanism, SphericalMechanism):
        raise ValueError(f"mechanism: expected a SphericalMechanism, got {type(mechanism).__name__}")
    values = mechanism.check_inputs(inputs)
    if not isinstance(degrees, (bool, np.bool_)):
        raise ValueError(f"degrees: expected true or false, got {degrees!r}")
    out, fmt = check_plot_path(path) if path is not None else (None, None)
    solutions = _check_report(mechanism, values, report)
    configs = [current_joint_axes(mechanism, values, dict(zip(report.unknowns, a))) for a in solutions]

    from matplotlib.figure import Figure
    import mpl_toolkits.mplot3d  # noqa: F401  (registers the "3d" projection)

    title = _title(mechanism, values, len(configs), bool(degrees))
    if not configs:
        fig = Figure(figsize=(MIN_COLUMNS * PANEL_INCHES, PANEL_INCHES), dpi=DPI)
        fig.suptitle(title, fontsize=11)
        fig.text(0.5, 0.45, "no solution in range", ha="center", va="center", fontsize=16, color="0.25")
        if out is not None:
            _save(fig, out, fmt)
        return fig

    n = len(configs)
    ncols = min(n, MAX_COLUMNS)
    nrows = math.ceil(n / ncols)
    width = max(ncols, MIN_COLUMNS) * PANEL_INCHES
    handles = _legend_handles(mechanism)
    legend_ncol, order = _legend_layout([h.get_label() for h in handles], width)
    handles = [handles[i] for i in order]
    footer = LEGEND_MARGIN_INCHES + LEGEND_ROW_INCHES * math.ceil(len(handles) / legend_ncol)
    height = nrows * PANEL_INCHES + HEADER_INCHES + footer
    fig = Figure(figsize=(width, height), dpi=DPI)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=footer / height, top=1.0 - HEADER_INCHES / height,
                        wspace=0.02, hspace=0.12)
    fig.suptitle(title, fontsize=12, y=1.0 - 0.12 / height, va="top")
    arcs = [_configuration_arcs(mechanism, axes) for axes in configs]
    view, elev, azim = _view_direction(np.concatenate([a[0] for panel in arcs for a in panel]))
    panels = []
    for k, (sol, axes) in enumerate(zip(report.solutions, configs)):
        ax = fig.add_subplot(nrows, ncols, k + 1, projection="3d", computed_zorder=False)
        ax.set_proj_type("ortho")
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlim(-1.0, 1.0)
        ax.set_ylim(-1.0, 1.0)
        ax.set_zlim(-1.0, 1.0)
        ax.set_box_aspect((1.0, 1.0, 1.0), zoom=ZOOM)
        ax.set_axis_off()
        _draw_sphere(ax, view)
        _draw_configuration(ax, mechanism, axes, arcs[k], view)
        ax.set_title(_panel_title(k + 1, sol), fontsize=9.5, pad=-4)
        panels.append((ax, mechanism, axes, view))
    fig.legend(handles=handles, loc="lower center", ncol=legend_ncol, fontsize=9, frameon=False,
               bbox_to_anchor=(0.5, 0.5 * LEGEND_MARGIN_INCHES / height))
    _label_joints(fig, panels)
    if out is not None:
        _save(fig, out, fmt)
    return fig


# --------------------------------------------------------------------------------------------
# Assembly-mode maps
# --------------------------------------------------------------------------------------------

#: Smallest parallel measure drawn on the map's second panel (log scale): below it a point is, for
#: the picture, on the singularity (the measure of a grid point next to one is ~ the grid step).
MEASURE_FLOOR = 1e-3
#: Size of one map panel (inches).
MAP_PANEL_INCHES = 5.0
#: Legend entry of the blank cells of the measure panel: inputs without any assembly have no measure.
NO_ASSEMBLY_LABEL = "no assembly (0 solutions): no measure"
#: Track plot's y-labels, short enough to stay within their panels (the figure is TRACK_INCHES).
TRACK_ORIENTATION_LABEL = "platform orientation\n(unit quaternion)"
TRACK_MEASURE_LABEL = "parallel_measure\nσmin/σmax of K_p"
TRACK_INCHES = (8.0, 6.0)
#: How the certified singular cells are drawn over a map's colours (:func:`plot_assembly_map`), by status:
#: singular cells filled black (no count colour is black) and outlined, unresolved cells hatched and outlined
#: (no fill: the colours under them stay visible). The gid of each cell's patch is "singular-cell:STATUS".
#: Tinted, not filled: the count's colour under a cell stays readable (issue 42 item 15: black cells hid it).
MAP_SINGULAR_STYLE = {"singular": dict(facecolor=(0.0, 0.0, 0.0, 0.3), edgecolor="black", linewidth=0.6),
                      "unresolved": dict(facecolor="none", edgecolor="black", linewidth=0.6, hatch="////")}
#: Outline of the singular set's free box on a map (its proven singularity-free region around home).
MAP_FREE_BOX_STYLE = dict(facecolor="none", edgecolor="white", linewidth=2.0, linestyle="--")


def plot_assembly_map(amap, path=None, *, degrees: bool = False, measure: bool = False):
    """Draw an assembly-mode map (:class:`spherekin.batch.AssemblyMap`): the number of solutions
    at each grid point as a discrete colour (the boundaries are where assembly modes appear or
    vanish: parallel singularities), grid points whose count is not fully certified marked with a
    black x; the map's ``singular_set`` if it has one (the certified singular cells, proven: singular
    cells filled black, unresolved ones hatched, :data:`MAP_SINGULAR_STYLE`; its free box, if any,
    outlined) drawn over the colours; with ``measure``, a second panel with the smallest normalized
    parallel-singularity measure over the solutions (numeric, log scale; dark curves are the
    singularities). Axes in the swept
    joints' names and units (``degrees``). Returns the matplotlib Figure; with ``path`` (.png,
    .pdf or .svg) it is also written there.
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm
    from matplotlib.figure import Figure

    out = fmt = None
    if path is not None:
        out, fmt = check_plot_path(path)
    scale, unit = (180.0 / math.pi, "deg") if degrees else (1.0, "rad")
    xs, ys = amap.x.values * scale, amap.y.values * scale
    dx = (xs[1] - xs[0]) / 2 if len(xs) > 1 else 0.5
    dy = (ys[1] - ys[0]) / 2 if len(ys) > 1 else 0.5
    extent = (xs[0] - dx, xs[-1] + dx, ys[0] - dy, ys[-1] + dy)
    tolerances = getattr(amap, "worst_error", None) is not None
    panels = 1 + bool(measure) + tolerances
    fig = Figure(figsize=(MAP_PANEL_INCHES * panels + 0.8 * panels, MAP_PANEL_INCHES + 0.6), dpi=DPI)
    top = max(int(amap.solutions.max()), 1)
    levels = np.arange(top + 1)
    base = ["#f0f0f0", "#4c72b0", "#55a868", "#c44e52", "#8172b2", "#ccb974", "#64b5cd", "#dd8452", "#937860",
            "#da8bc3"]
    # grey for no solution; the colours cycle for counts beyond len(base) - 1 (never back to grey)
    cmap = ListedColormap([base[0] if k == 0 else base[1 + (k - 1) % (len(base) - 1)] for k in levels])
    norm = BoundaryNorm(np.arange(-0.5, top + 1.5), cmap.N)
    ax = fig.add_subplot(1, panels, 1)
    im = ax.imshow(amap.solutions.T, origin="lower", extent=extent, aspect="auto", cmap=cmap, norm=norm,
                   interpolation="nearest")
    bar = fig.colorbar(im, ax=ax, ticks=levels, fraction=0.05, pad=0.03)
    bar.set_label("real solutions (assembly modes) in range")
    doubt = ~amap.proven
    if doubt.any():
        ii, jj = np.nonzero(doubt)
        ax.plot(xs[ii], ys[jj], "x", color="black", markersize=4, linestyle="none",
                label="count not fully certified")
    if amap.singular_set is not None:
        _draw_singular_cells(ax, amap.singular_set, scale, unit)
    if ax.get_legend_handles_labels()[0]:
        _legend_below(ax)
    ax.set_xlabel(f"{amap.x.name} ({unit})")
    ax.set_ylabel(f"{amap.y.name} ({unit})")
    sset = amap.singular_set
    ax.set_title("number of assembly modes" + ("" if sset is None else ", certified singular cells"
                                               + ("" if sset.complete else " (incomplete: box cap)")), fontsize=11)
    if measure:
        ax2 = fig.add_subplot(1, panels, 2)
        vals = np.clip(amap.measure, MEASURE_FLOOR, 1.0)          # NaN (no solution) stays blank
        im2 = ax2.imshow(vals.T, origin="lower", extent=extent, aspect="auto", cmap="magma",
                         norm=LogNorm(vmin=MEASURE_FLOOR, vmax=1.0), interpolation="nearest")
        bar2 = fig.colorbar(im2, ax=ax2, fraction=0.05, pad=0.03)
        bar2.set_label("min over solutions of sigma_min/sigma_max (K_p)")
        ax2.set_xlabel(f"{amap.x.name} ({unit})")
        ax2.set_ylabel(f"{amap.y.name} ({unit})")
        ax2.set_title("distance to a parallel singularity", fontsize=11)
        ax2.set_facecolor("white")                                # what a NaN cell shows
        if np.isnan(amap.measure).any():                          # say what the blank cells are
            from matplotlib.patches import Patch
            ax2.legend(handles=[Patch(facecolor="white", edgecolor="0.4", label=NO_ASSEMBLY_LABEL)],
                       loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=8, frameon=False)  # under the axis
    if tolerances:
        _draw_tolerance_panel(fig.add_subplot(1, panels, panels), amap, xs, ys, extent, unit)
    fixed = ", ".join(f"{n} = {v * scale:.4g} {unit}" for n, v in amap.fixed.items())
    fig.suptitle(f"{amap.mechanism}" + (f" ({fixed})" if fixed else ""), fontsize=12)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    if out is not None:
        _save(fig, out, fmt)
    return fig


def _draw_tolerance_panel(ax, amap, xs, ys, extent, unit: str) -> None:
    """A map's panel under tolerances (issue 45): the largest proven worst-case rotation error over each
    grid point's assemblies (degrees; blank where one is not proven), grid points where a singular
    configuration is proven within the tolerances (the real mechanism may change assembly mode there)
    marked with a filled black dot, those where the count is not proven constant with a grey x."""
    from matplotlib.lines import Line2D

    err = np.degrees(amap.worst_error)
    im = ax.imshow(err.T, origin="lower", extent=extent, aspect="auto", cmap="viridis", interpolation="nearest")
    bar = ax.figure.colorbar(im, ax=ax, fraction=0.05, pad=0.03)
    bar.set_label("worst-case rotation error, proven (deg)")
    ax.set_facecolor("white")
    handles = []
    change = amap.count_constant == 0
    if change.any():
        ii, jj = np.nonzero(change)
        ax.plot(xs[ii], ys[jj], "o", color="black", markersize=3, linestyle="none")
        handles.append(Line2D([], [], marker="o", color="black", markersize=4, linestyle="none",
                              label="may change assembly mode (singularity proven within the tolerances)"))
    open_ = np.isnan(amap.count_constant)
    if open_.any():
        ii, jj = np.nonzero(open_)
        ax.plot(xs[ii], ys[jj], "x", color="0.45", markersize=3, linestyle="none")
        handles.append(Line2D([], [], marker="x", color="0.45", markersize=4, linestyle="none",
                              label="count not proven constant (or a bound not proven: blank)"))
    if handles:
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=7, frameon=False)
    ax.set_xlabel(f"{amap.x.name} ({unit})")
    ax.set_ylabel(f"{amap.y.name} ({unit})")
    ax.set_title("the mechanism as built: worst case over the tolerances", fontsize=11)


def _draw_singular_cells(ax, sset, scale: float, unit: str) -> None:
    """A map's certified singular set over its colours: one Rectangle per cell (styled by status,
    gid "singular-cell:STATUS"), the proven free box outlined, one legend entry each."""
    from matplotlib.patches import Rectangle

    counts = sset.counts()
    labelled = set()
    for b in sset.boxes:
        label = None
        if b.status not in labelled:
            labelled.add(b.status)
            label = (f"{b.status} cell ({counts[b.status]}, <= {sset.tol * scale:.3g} {unit})" if b.status == "singular"
                     else f"{b.status} cell ({counts[b.status]})")
        patch = Rectangle((b.x[0] * scale, b.y[0] * scale), (b.x[1] - b.x[0]) * scale, (b.y[1] - b.y[0]) * scale,
                          label=label, **MAP_SINGULAR_STYLE[b.status])
        patch.set_gid(f"singular-cell:{b.status}")
        ax.add_patch(patch)
    _draw_singular_extras(ax, sset, scale, MAP_FREE_BOX_STYLE)


def _draw_singular_extras(ax, sset, scale: float, free_style: dict) -> list:
    """A singular set's free box (outlined with ``free_style``), cusps (CUSP_MARKERS) and proven mode
    change (its closed path of inputs) on ``ax`` (angles times ``scale``); returns their legend handles.
    One drawing for plot_singular and the maps' overlay."""
    from matplotlib.patches import Rectangle

    handles = []
    free = sset.free_box
    if free is not None and free["proven"]:
        box = free["inputs"]
        (x0, x1), (y0, y1) = box[sset.x[0]], box[sset.y[0]] if sset.y is not None else (0.0, 1.0 / scale)
        label = f"free box of solution {free.get('start_solution', '?')} (its assembly only)"
        handles.append(ax.add_patch(Rectangle((x0 * scale, y0 * scale), (x1 - x0) * scale, (y1 - y0) * scale,
                                              label=label, **free_style)))
    for status, style in CUSP_MARKERS.items():
        pts = [(c.x * scale, c.y * scale) for c in sset.cusps if c.status == status]
        if pts:
            handles.append(ax.scatter(*zip(*pts), zorder=CUSP_ZORDER, label=f"cusp ({len(pts)})"
                                      if status == "cusp" else f"unresolved cusp candidate ({len(pts)})", **style))
    mc = sset.mode_change
    if mc is not None and mc.found:
        path = np.asarray(mc.path)
        xs, ys = path[:, mc.columns.index(sset.x[0])], path[:, mc.columns.index(sset.y[0])]
        line, = ax.plot(xs * scale, ys * scale, color=MODE_CHANGE_COLOUR, linewidth=1.2,
                        label=f"mode change {mc.start_solution} -> {mc.end_solution}")
        handles.append(line)
    return handles


def plot_track(track, path=None, *args, degrees: bool = False):
    """Draw a tracked path (:class:`spherekin.trust.continuation.Track`): top, the platform's
    orientation along the path (the unit quaternion's components, w >= 0 at the start, kept
    continuous; the passive joints' angles for a mechanism without an output link); below, the parallel measure (sigma_min / sigma_max of the passive-joint Jacobian, as
    batch and map report it; log scale; 0 at a parallel singularity), with where the track stopped
    marked. Returns the Figure; with ``path`` (.png, .pdf, .svg) also writes it: the calling
    convention of :func:`plot_report`, :func:`plot_assembly_map` and :func:`plot_singular`. The former
    ``plot_track(mechanism, track, path)`` still works, with a DeprecationWarning."""
    import warnings

    from matplotlib.figure import Figure

    from .trust.continuation import Track

    if isinstance(track, SphericalMechanism) and isinstance(path, Track):     # the former convention
        warnings.warn("plot_track(mechanism, track, path) is deprecated: call plot_track(track, path)",
                      DeprecationWarning, stacklevel=2)
        track, path = path, (args[0] if args else None)
    elif args:
        raise TypeError(f"plot_track: expected (track, path=None), got {2 + len(args)} positional arguments")
    if not isinstance(track, Track):
        raise ValueError(f"track: expected a Track of spherekin track (Problem.track), got {type(track).__name__}")

    from .core.orientation import quaternions_from_rotations

    out = fmt = None
    if path is not None:
        out, fmt = check_plot_path(path)
    rows = np.array([p.row for p in track.poses], dtype=float)
    q = quaternions_from_rotations(track.rotations)
    for k in range(1, len(q)):                   # q and -q are one rotation: keep the curve continuous
        if q[k] @ q[k - 1] < 0:
            q[k] = -q[k]
    fig = Figure(figsize=TRACK_INCHES, dpi=DPI, layout="constrained")
    ax, ax2 = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    if np.isfinite(q).all():
        for j, label in enumerate(("qw", "qx", "qy", "qz")):
            ax.plot(rows, q[:, j], label=label, lw=1.5)
        ax.set_ylabel(TRACK_ORIENTATION_LABEL)
    else:                                        # no output link: the passive joints' angles instead
        scale = 180.0 / np.pi if degrees else 1.0
        for name in track.passive_joints:
            ax.plot(rows, [p.passive_angles[name] * scale for p in track.poses], label=name, lw=1.5)
        ax.set_ylabel(f"passive joint angle ({'degrees' if degrees else 'radians'})")
    ax.legend(loc="best", fontsize=8, ncol=4)
    ax.grid(alpha=0.3)
    st = track.stop
    where = None if st is None else st.between_rows[0] + st.fraction
    m_rows = list(rows) + ([] if st is None else [where])            # the last proven pose, where it stopped
    m_vals = [p.parallel_measure for p in track.poses] + ([] if st is None else [st.parallel_measure])
    ax2.semilogy(m_rows, np.maximum(m_vals, 1e-16), color="black", lw=1.2)
    ax2.set_ylabel(TRACK_MEASURE_LABEL)
    ax2.set_xlabel("path row")
    ax2.grid(alpha=0.3, which="both")
    title = f"{track.mechanism or 'mechanism'}: one assembly mode tracked over {len(track.poses)} row(s)"
    if st is not None:
        for a in (ax, ax2):
            a.axvline(where, color="tab:red", ls="--", lw=1)
        label = "parallel singularity:\nthe mode ends" if st.kind == "singular" else f"{st.joint} leaves\nits range"
        ax2.annotate(label, (where, max(st.parallel_measure, 1e-16)), color="tab:red",
                     fontsize=8, xytext=(-6, 0), textcoords="offset points", ha="right", va="bottom")
        title += (f"\nstopped between rows {st.between_rows[0]} and {st.between_rows[1]}: "
                  + ("a parallel singularity" if st.kind == "singular" else f"{st.joint} leaves its range"))
    fig.suptitle(title, fontsize=11)
    fig.align_ylabels((ax, ax2))
    if out is not None:
        _save(fig, out, fmt)
    return fig


#: Size (inches) of :func:`plot_branches`' figure.
BRANCHES_INCHES = (8.0, 5.0)
#: Colours of the circuits in :func:`plot_branches` (cycled beyond ten circuits).
CIRCUIT_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink",
                   "tab:olive", "tab:cyan", "tab:gray")


def plot_branches(bmap, path=None, *, degrees: bool = False):
    """Draw the branches of a one-input mechanism (:class:`spherekin.batch.branches.BranchMap`): the
    output joint's angle against the input, one colour per circuit (dashed: not a crank circuit),
    the branch points marked with black diamonds. Angles in radians (``degrees``: in degrees); a
    branch is broken where its output angle wraps from pi to -pi. Returns the matplotlib Figure;
    with ``path`` (.png, .pdf or .svg) it is also written there."""
    from matplotlib.figure import Figure

    out = fmt = None
    if path is not None:
        out, fmt = check_plot_path(path)
    scale, unit = (180.0 / math.pi, "deg") if degrees else (1.0, "rad")
    col = bmap.output_column
    fig = Figure(figsize=BRANCHES_INCHES, dpi=DPI, layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    for c, circuit in enumerate(bmap.circuits):
        colour = CIRCUIT_COLOURS[c % len(CIRCUIT_COLOURS)]
        style = "-" if circuit.crank else "--"
        label = f"circuit {c + 1}" + (" (crank)" if circuit.crank else "")
        for k in circuit.branches:
            branch = bmap.branches[k]
            x, y = branch.inputs * scale, branch.angles[:, col] * scale
            cut = np.nonzero(np.abs(np.diff(branch.angles[:, col])) > math.pi)[0] + 1   # a wrap: no line across
            for xs, ys in zip(np.split(x, cut), np.split(y, cut)):
                ax.plot(xs, ys, style, color=colour, lw=1.6, label=label)
                label = None
    if bmap.branch_points:
        ax.plot([p.input * scale for p in bmap.branch_points], [p.angles[col] * scale for p in bmap.branch_points],
                "D", color="black", markersize=6, linestyle="none", label="branch point (det K_p = 0)")
    ax.set_xlabel(f"{bmap.input} ({unit})")
    ax.set_ylabel(f"{bmap.output} ({unit})")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=8)
    ax.set_title(f"{bmap.mechanism}: {len(bmap.circuits)} circuit(s), {len(bmap.branch_points)} branch point(s)",
                 fontsize=11)
    if out is not None:
        _save(fig, out, fmt)
    return fig


def plot_report(report: SolveReport, path=None, *, degrees: bool = False):
    """:func:`plot_solutions` of a report of :func:`spherekin.solve` (or ``Problem.solve``), which
    holds its mechanism and inputs: ``spherekin.plot.plot_report(report)`` returns the Figure (also
    written to ``path`` when given). The report itself has no ``plot`` method: it is a hand-over
    type, a layer below the plots (tests/test_layers.py)."""
    if not isinstance(report, SolveReport) or report.mechanism is None:
        raise ValueError(f"report: expected a SolveReport of spherekin.solve (holding its mechanism), "
                         f"got {type(report).__name__ if not isinstance(report, SolveReport) else 'one without it'}")
    return plot_solutions(report.mechanism, report.settings.inputs, report, path, degrees=degrees)


#: Colours of the singular-set cells by status (unresolved also hatched, so that print in grey tells them apart).
SINGULAR_COLOURS = {"singular": "#c0392b", "unresolved": "#f0b27a"}
#: Figure size (inches) of :func:`plot_singular`.
SINGULAR_INCHES = (6.4, 6.0)


#: The outline of a singular set's free box (its proven singularity-free region around home).
FREE_BOX_COLOUR = "tab:green"
#: The path of a proven assembly-mode change (a closed loop of inputs around a cusp).
MODE_CHANGE_COLOUR = "tab:blue"
#: Cusp markers of plot_singular and the maps' overlay by status: proven cusps filled, unresolved hollow.
CUSP_MARKERS = {"cusp": dict(marker="*", s=110, facecolors="black", edgecolors="white", linewidths=0.8),
                "unresolved": dict(marker="o", s=40, facecolors="none", edgecolors="black")}
#: Above the cells and the free box (patches draw at zorder 1-2): a cusp is never hidden under a cell.
CUSP_ZORDER = 5


def _legend_below(ax, handles=None) -> None:
    """The legend of a plane plot under its axes, outside the data (issue 42 item 15: in the upper right
    corner it covered cells and a cusp), two columns; the figure's layout makes room for it."""
    kw = {} if handles is None else {"handles": handles}
    # a light grey ground: the map's white dashed free-box outline must show in its own entry
    ax.legend(**kw, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8, frameon=True,
              facecolor="0.88", edgecolor="none", framealpha=1.0)


def plot_singular(sset, path=None, *, degrees: bool = False):
    """Draw a singular set (:class:`spherekin.results.SingularSet`): the plane's cells in the cover, coloured
    by status (singular: proven; unresolved: hatched), and its cusps (CUSP_MARKERS); a line of inputs is drawn as a strip. Angles in
    radians (``degrees``: in degrees). Returns the matplotlib Figure; with ``path`` (.png, .pdf or .svg)
    it is also written there."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch, Rectangle

    out = fmt = None
    if path is not None:
        out, fmt = check_plot_path(path)
    scale, unit = (180.0 / math.pi, "deg") if degrees else (1.0, "rad")
    fig = Figure(figsize=SINGULAR_INCHES, dpi=DPI, layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    for b in sset.boxes:
        y0, y1 = b.y if b.y is not None else (0.0, 1.0 / scale)
        ax.add_patch(Rectangle((b.x[0] * scale, y0 * scale), (b.x[1] - b.x[0]) * scale, (y1 - y0) * scale,
                               facecolor=SINGULAR_COLOURS[b.status], edgecolor="none",
                               hatch="///" if b.status != "singular" else None))
    ax.set_xlim(sset.x[1] * scale, sset.x[2] * scale)
    ax.set_xlabel(f"{sset.x[0]} ({unit})")
    if sset.y is not None:
        ax.set_ylim(sset.y[1] * scale, sset.y[2] * scale)
        ax.set_ylabel(f"{sset.y[0]} ({unit})")
        ax.set_aspect("equal")
    else:
        ax.set_ylim(0.0, 1.0)
        ax.set_yticks([])
    counts = sset.counts()
    handles = [Patch(facecolor=SINGULAR_COLOURS[k], hatch="///" if k != "singular" else None,
                     label=f"{k} ({counts.get(k, 0)})") for k in SINGULAR_COLOURS]
    handles += _draw_singular_extras(ax, sset, scale, dict(facecolor="none", edgecolor=FREE_BOX_COLOUR, linewidth=1.5))
    _legend_below(ax, handles)
    fixed = ", ".join(f"{k} = {v * scale:.4g}" for k, v in sset.fixed.items())
    what = ("parallel singular set for every geometry within the tolerances" if sset.system == "tolerances"
            else "parallel singular set")
    ax.set_title(f"{what}, cells <= {sset.tol * scale:.3g} {unit}" + (f" ({fixed})" if fixed else "")
                 + ("" if sset.complete else ", incomplete"), fontsize=10)
    ax.grid(alpha=0.3)
    if out is not None:
        _save(fig, out, fmt)
    return fig
