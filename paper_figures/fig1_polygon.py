"""The paper's Fig. 1 redrawn: the spherical polygon of a four-bar linkage, and a spherical polygon before and after normalization (Eqs. 1 and 2).

Question: which spherical polygon does a spherical linkage define (the paper's Fig. 1, left), what
is the normalized polygon of Eq. (2) of a given spherical polygon (centre and right), and do they
really close as spherekin computes them?

How, left panel: the spherical four-bar of examples/four_bar.toml, loaded with
spherekin.mechanism.io.load_mechanism, at its reference configuration (spherekin.plot.
current_joint_axes at every joint's reference reading). Its joint axes pass through the centre, so
they are points of the sphere, the vertices A, B, C, D of a spherical quadrilateral whose sides are
the links (crank AB, coupler BC, rocker CD, ground DA) and whose side lengths are the link angles
(radians); its closure, Eq. (1) of its measured sides and exterior angles, is checked like the
centre panel's.

How, centre and right: a spherical quadrilateral with unequal sides and angles is given by its four vertices p_k
(unit vectors). Its sides alpha_k (arc p_k -> p_k+1) and exterior angles theta_k (the signed turn
at p_k about p_k, from the pole n_k-1 of the incoming side to the pole n_k of the outgoing one) are
measured on the sphere; spherekin.core.rotations.polygon_closure evaluates Eq. (1),
prod Rx(theta_k) Rz(alpha_k), and normalize_polygon gives the n = 2m angles of Eq. (2) (the
corrected index rule phi_2k-1 = theta_k + pi, phi_2k = alpha_k + pi), whose product
normalized_closure(phi) = prod Rx(phi_i) Z is evaluated too. The normalized polygon is drawn by
walking its frames: vertex i is E (prod_{j < i} Rx(phi_j) Z) e_x, with E = [p_1, n_m x p_1, n_m]
Rx(pi/2)^T (rotations.normalization_conjugator: the normalized product is Eq. 1's conjugated by
Rx(pi/2)). All its sides are pi/2 by construction (Z turns e_x by pi/2); its odd vertices land on
the p_k and its even vertices on the poles of the sides, which the figure shows and the script
checks. Both closure residuals |product - I| (Frobenius) are printed and written on the figure.
No randomness (--seed is unused); --quick changes nothing (the script runs in seconds).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


from paper_figures import _figure_tools as ft

from spherekin.mechanism.io import load_mechanism  # noqa: E402
from spherekin.plot import BASE_COLOUR, LEG_COLOURS, PLATFORM_COLOUR, current_joint_axes  # noqa: E402
from spherekin.core.rotations import (Z, normalization_conjugator, normalize_polygon, normalized_closure,  # noqa: E402
                                 polygon_closure, rx)

NAME = "fig1_polygon"
#: The linkage of the left panel: a one-loop mechanism of two legs (crank and rocker, each two joints).
FOUR_BAR = ft.ROOT / "examples" / "four_bar.toml"
#: The quadrilateral's vertices as (polar angle from +z, azimuth) in degrees: chosen convex, with
#: four different sides and angles, and on one hemisphere so that one view shows all of it.
VERTICES_DEG = ((75.0, -35.0), (62.0, 50.0), (22.0, 95.0), (42.0, -128.0))
#: Angular radius (radians) of the small arcs that mark the exterior angles at the vertices.
ANGLE_MARK = 0.13
#: Length (radians) of the dotted prolongation of each incoming side beyond its vertex (the
#: reference direction of the exterior angle, as in the paper's definition).
PROLONGATION = 0.32
#: Closure residual above which a polygon counts as not closed (Frobenius norm of product - I):
#: products of 8-16 rotations in double precision are exact to ~1e-15; 1e-12 leaves a margin.
CLOSURE_TOL = 1e-12
POLYGON_COLOUR = "tab:blue"
NORMALIZED_COLOUR = "tab:red"


# --------------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------------

def unit(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])


def normalized_vertices(poly: dict, phis: np.ndarray) -> np.ndarray:
    """Vertices (n + 1, 3) of the normalized polygon walked from its frames (the last one = the first).

    The starting frame has x through p_1 and, before conjugation, z through the pole n_m of the
    side entering p_1; the conjugation by P = Rx(pi/2) of normalization_conjugator is undone by P^T.
    """
    p1, nm = poly["vertices"][0], poly["poles"][-1]
    frame = np.column_stack([p1, np.cross(nm, p1), nm]) @ normalization_conjugator().T
    out = [frame[:, 0]]
    for phi in phis:
        frame = frame @ rx(phi) @ Z
        out.append(frame[:, 0])
    return np.array(out)


def four_bar(path=FOUR_BAR) -> dict:
    """The four-bar of ``path`` at its reference configuration as a spherical polygon.

    Returns the mechanism, the vertex names in loop order (up the first leg, down the second), the
    polygon (ft.polygon: vertices = current joint axes, sides = link angles and exterior angles in
    radians), the side names with the link each side is (a leg's own link, the coupler between the
    legs' last joints, the ground between their first joints), and the Eq. (1) closure residual.
    """
    mech = load_mechanism(path)
    if len(mech.legs) != 2:
        raise ValueError(f"{path}: expected a one-loop linkage of two legs, got {len(mech.legs)} legs")
    ref = {j.name: j.reference_angle for j in mech.joints}
    axes = current_joint_axes(mech, [ref[n] for n in mech.actuated], {n: ref[n] for n in mech.passive})
    up, down = mech.legs
    names = [j.name for j in up.joints] + [j.name for j in reversed(down.joints)]
    poly = ft.polygon(np.concatenate([axes[up.name], axes[down.name][::-1]]))
    n_up, m = len(up.joints), len(names)
    links = []
    for k in range(m):
        if k < n_up - 1:
            links.append((up.name, LEG_COLOURS[0]))
        elif k == n_up - 1:
            links.append(("coupler", PLATFORM_COLOUR))
        elif k < m - 1:
            links.append((down.name, LEG_COLOURS[1]))
        else:
            links.append(("ground", BASE_COLOUR))
    residual = float(np.linalg.norm(polygon_closure(poly["sides"], poly["exterior"]) - np.eye(3)))
    return dict(mechanism=mech, names=names, poly=poly, links=links, residual=residual)


def compute(vertices_deg=VERTICES_DEG) -> dict:
    poly = ft.polygon([unit(*v) for v in vertices_deg])
    eq1 = polygon_closure(poly["sides"], poly["exterior"])
    phis = normalize_polygon(poly["sides"], poly["exterior"])
    eq2 = normalized_closure(phis)
    q = normalized_vertices(poly, phis)
    m = poly["m"]
    # where the normalized vertices land: odd ones on the p_k, even ones on +-(pole of side k)
    odd_gap = float(np.abs(q[0:2 * m:2] - poly["vertices"]).max())
    even_sign = np.sign(np.sum(q[1:2 * m:2] * poly["poles"], axis=1))
    even_gap = float(np.abs(q[1:2 * m:2] - even_sign[:, None] * poly["poles"]).max())
    q_sides = np.arctan2(np.linalg.norm(np.cross(q[:-1], q[1:]), axis=1), np.sum(q[:-1] * q[1:], axis=1))
    return dict(linkage=four_bar(), poly=poly, phis=phis, eq1=eq1, eq2=eq2, normalized=q,
                residual_eq1=float(np.linalg.norm(eq1 - np.eye(3))),
                residual_eq2=float(np.linalg.norm(eq2 - np.eye(3))),
                walk_gap=float(np.linalg.norm(q[-1] - q[0])), odd_gap=odd_gap, even_gap=even_gap,
                even_sign=even_sign, normalized_sides=q_sides)


# --------------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------------

def _tangent(p, q) -> np.ndarray:
    """Unit tangent at p of the great-circle arc p -> q."""
    t = q - (p @ q) * p
    return t / np.linalg.norm(t)


def _small_circle_arc(p, t0, angle, radius, n=40) -> np.ndarray:
    """Points at angular distance ``radius`` from p, from direction t0 turning by ``angle`` about p."""
    s = np.linspace(0.0, angle, n)[:, None]
    d = np.cos(s) * t0 + np.sin(s) * np.cross(p, t0)
    return math.cos(radius) * p + math.sin(radius) * d


def _deg(a: float) -> str:
    return f"{math.degrees(a):.1f}°"


LABEL_BOX = dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85)


def _four_bar_panel(fig, spec, linkage: dict):
    """The left panel: the linkage's links as great-circle arcs between its joint axes (points of the sphere)."""
    poly, names, mech = linkage["poly"], linkage["names"], linkage["mechanism"]
    p, m = poly["vertices"], poly["m"]
    centre = p.sum(axis=0) / np.linalg.norm(p.sum(axis=0))
    view = ft.view_for(p)
    v = view[0]
    ax = ft.sphere_axes(fig, spec, view, f"left: a spherical four-bar linkage ({FOUR_BAR.name})\n"
                        "joint axes through the centre O: vertices; links: sides (link angles)")
    for k in range(m):
        a, b = p[k], p[(k + 1) % m]
        name, colour = linkage["links"][k]
        ft.draw_arc(ax, a, b, v, colour, 3.4)
        mid = (a + b) / np.linalg.norm(a + b)
        ft.label_at(ax, ft.away(mid, centre, 0.16), f"{name} {names[k]}{names[(k + 1) % m]}\n{_deg(poly['sides'][k])}",
                    v, colour, radius=1.0, fontsize=10, bbox=LABEL_BOX)
    for k in range(m):
        ft.draw_point(ax, p[k], v, "black", "s" if mech.joint(names[k]).actuated else "o")
        ft.label_at(ax, ft.away(p[k], centre, -0.12), names[k], v, "black",
                    radius=1.0, fontsize=12, fontweight="bold")
    ax.text2D(0.5, 0.0, f"Eq. (1) of its sides and angles: |Π Rx(θk) Rz(αk) − I| {ft.residual_phrase(linkage['residual'])}",
              transform=ax.transAxes, ha="center", va="top", fontsize=11)
    return ax


def draw(data: dict):
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    poly, q = data["poly"], data["normalized"]
    p, m = poly["vertices"], poly["m"]
    centre = p.sum(axis=0) / np.linalg.norm(p.sum(axis=0))
    view = ft.view_for(np.concatenate([p, q]))
    v = view[0]
    fig = Figure(figsize=(20.0, 7.6))
    grid = fig.add_gridspec(1, 4, width_ratios=(1.0, 1.0, 1.0, 0.5), left=0.0, right=1.0, top=0.82, bottom=0.13,
                            wspace=0.0)

    # ---- left: the spherical polygon of a four-bar linkage
    _four_bar_panel(fig, grid[0, 0], data["linkage"])

    # ---- centre: the polygon of Eq. (1)
    ax = ft.sphere_axes(fig, grid[0, 1], view, "centre: a spherical quadrilateral, Eq. (1): m = 4")
    for k in range(m):
        a, b = p[k], p[(k + 1) % m]
        ft.draw_arc(ax, a, b, v, POLYGON_COLOUR, 2.6)
        mid = (a + b) / np.linalg.norm(a + b)
        ft.label_at(ax, ft.away(mid, centre, 0.15), f"α{k + 1} = {_deg(poly['sides'][k])}", v, POLYGON_COLOUR,
                    radius=1.0, fontsize=10, bbox=LABEL_BOX)
    for k in range(m):
        a, prev_pt = p[k], p[k - 1]
        t_in = -_tangent(a, prev_pt)                     # direction of travel arriving at p_k
        ft.draw_curve(ax, np.array([ft.along(a, t_in, s) for s in np.linspace(0, PROLONGATION, 20)]), v, "0.3", 1.0)
        turn = poly["exterior"][k]
        ft.draw_curve(ax, _small_circle_arc(a, t_in, turn, ANGLE_MARK), v, "tab:green", 2.0, 6)
        bis = math.cos(turn / 2) * t_in + math.sin(turn / 2) * np.cross(a, t_in)
        ft.label_at(ax, ft.along(a, bis, 0.3), f"θ{k + 1} = {_deg(turn)}", v, "tab:green", radius=1.0,
                    fontsize=10, bbox=LABEL_BOX)
        ft.draw_point(ax, a, v, "black")
        ft.label_at(ax, ft.away(a, centre, 0.1) - 0.12 * bis, f"p{k + 1}", v, "black", radius=1.0, fontsize=12,
                    fontweight="bold")
    ax.text2D(0.5, 0.0, f"|Π Rx(θk) Rz(αk) − I| {ft.residual_phrase(data['residual_eq1'])}", transform=ax.transAxes,
              ha="center", va="top", fontsize=11)

    # ---- right: the normalized polygon of Eq. (2)
    ax = ft.sphere_axes(fig, grid[0, 2], view, f"right: its normalized form, Eq. (2): n = 2m = {2 * m} sides of 90°")
    for k in range(m):
        ft.draw_arc(ax, p[k], p[(k + 1) % m], v, POLYGON_COLOUR, 1.0, 2)
    for i in range(2 * m):
        ft.draw_arc(ax, q[i], q[i + 1], v, NORMALIZED_COLOUR, 2.4)
    names = [f"θ{i // 2 + 1}" if i % 2 == 0 else f"α{i // 2 + 1}" for i in range(2 * m)]
    for i in range(2 * m):
        odd = i % 2 == 0                                   # q_1, q_3, ... (1-based odd)
        ft.draw_point(ax, q[i], v, "black" if odd else NORMALIZED_COLOUR, "o" if odd else "D")
        # odd vertices (the p_k) labelled inside the quadrilateral, the poles outside it
        ft.label_at(ax, ft.away(q[i], centre, 0.1 if not odd else -0.1), f"q{i + 1}", v,
                    "black" if odd else NORMALIZED_COLOUR, radius=1.0, fontsize=11, fontweight="bold",
                    bbox=LABEL_BOX)
    ax.text2D(0.5, 0.0, f"|Π Rx(φi) Z − I| {ft.residual_phrase(data['residual_eq2'])}", transform=ax.transAxes,
              ha="center", va="top", fontsize=11)
    rows = [f"φ{i + 1} = {names[i]} + π = {math.degrees(data['phis'][i]) % 360:5.1f}°" for i in range(2 * m)]
    fig.text(6.05 / 7.0, 0.5, "angles of Eq. (2)\n(exterior angle at q_i)\n\n" + "\n".join(rows), ha="left", va="center",
             fontsize=10.5, family="DejaVu Sans Mono", linespacing=1.5)

    signs = set(data["even_sign"].astype(int))
    pole = "the pole" if signs == {1} else ("minus the pole" if signs == {-1} else "± the pole")
    fig.suptitle("The paper's Fig. 1 redrawn. Left: the spherical polygon of a spherical four-bar linkage "
                 "(joint axes = vertices, links = sides). Centre and right: a spherical polygon before and after "
                 "normalization\n"
                 "centre: sides α_k, exterior angles θ_k (turned from the prolongation of the incoming side); "
                 f"right: all sides 90°; vertex q(2k−1) = p_k, vertex q(2k) = {pole} of side α_k", fontsize=12)
    handles = [Line2D([], [], color=c, lw=3.0, label=f"four-bar: {name}")
               for name, c in dict(data["linkage"]["links"]).items()]
    handles.append(Line2D([], [], color="black", marker="s", ls="", label="four-bar: driven joint"))
    handles += [Line2D([], [], color=POLYGON_COLOUR, lw=2.6, label="polygon p1..p4 (sides α_k)"),
               Line2D([], [], color="tab:green", lw=2.0, label="exterior angle θ_k"),
               Line2D([], [], color="0.3", lw=1.0, label="prolongation of the incoming side"),
               Line2D([], [], color=NORMALIZED_COLOUR, lw=2.4, label="normalized polygon q1..q8 (all sides 90°)"),
               Line2D([], [], color="black", marker="o", ls="", label="q(2k−1) = p_k, angle φ = θ_k + π"),
               Line2D([], [], color=NORMALIZED_COLOUR, marker="D", ls="", label="q(2k) = pole of α_k, angle φ = α_k + π"),
               Line2D([], [], color="0.3", lw=1.2, ls=(0, (3, 2)), alpha=0.6, label="far side of the sphere")]
    fig.legend(handles=handles, loc="lower center", ncol=6, fontsize=9.5, frameon=False, bbox_to_anchor=(0.5, 0.01))
    return fig


def main(argv=None) -> dict:
    args = ft.parser(__doc__.split("\n\n")[0]).parse_args(argv)
    data = compute()
    poly = data["poly"]
    print("sides alpha (deg):", np.round(np.degrees(poly["sides"]), 3))
    print("exterior theta (deg):", np.round(np.degrees(poly["exterior"]), 3))
    print("normalized phi (deg):", np.round(np.degrees(data["phis"]), 3))
    print(f"|Eq. (1) product - I| = {data['residual_eq1']:.2e}, |Eq. (2) product - I| = {data['residual_eq2']:.2e}; "
          f"frame walk returns to q1 within {data['walk_gap']:.1e}; odd vertices on p_k within {data['odd_gap']:.1e}, "
          f"even vertices on the poles within {data['even_gap']:.1e} (signs {data['even_sign'].astype(int)})")
    print(f"four-bar {FOUR_BAR.name}: vertices {data['linkage']['names']}, link angles (deg) "
          f"{np.round(np.degrees(data['linkage']['poly']['sides']), 6)}; |Eq. (1) - I| = {data['linkage']['residual']:.2e}")
    worst = max(data["linkage"]["residual"], data["residual_eq1"], data["residual_eq2"], data["walk_gap"], data["odd_gap"], data["even_gap"])
    if worst > CLOSURE_TOL:
        raise RuntimeError(f"the polygon or its normalized form does not close: {worst:.2e} > {CLOSURE_TOL}")
    ft.save(draw(data), args.out_dir, NAME)
    return data


if __name__ == "__main__":
    main()
