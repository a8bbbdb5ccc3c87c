"""The paper's Fig. 2 redrawn: the Gosselin platform (left) and the spherical polygons it defines (right).

Question: what mechanism does examples/gosselin.toml describe, drawn as the paper draws it, and
which spherical polygons (closure loops, Eqs. 3-4) does the general model derive from its joint axes?

How: the mechanism is loaded from examples/gosselin.toml (spherekin.mechanism.io.load_mechanism);
every coordinate drawn comes from the file's axes through spherekin's API. Every joint axis passes
through the centre, so it is a point of the unit sphere and every link a great-circle arc
(spherekin.plot's drawing helpers). At the file's reference configuration (beta = 0, R = I) every
axis is a coordinate axis and several links coincide, so the mechanism is drawn with the platform
turned by ROTATION_DEG about ROTATION_AXIS (inverse kinematics, the working mode of the reference
configuration), which pulls them apart. Panel (a), the paper's left: the base triangle of the
actuated joints beta_i (squares), each leg's proximal link (beta_i to the elbow gamma_i, thick) and
distal link (gamma_i to the platform joint delta_i, thin), and the platform triangle of the
delta_i. Panels (b) and (c), the paper's right: in that configuration, the two loops of the
model (SphericalMechanism.loop_geometry: loop 1 up leg 1 and down leg 2, loop 2 up leg 3 and down
leg 2, leg 2 the reference leg as in the paper), each vertex labelled with its joint and the factor
angle phi_k = offset + sign * reading that the model puts into Eq. (2). The script measures the
exterior angles of each drawn hexagon on the sphere and checks that they equal the model's phi_k
(all sides are pi/2, so Eq. 1 is already Eq. 2) and that both loops close. No randomness (--seed
is unused); --quick changes nothing (the script runs in seconds).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


from paper_figures import _figure_tools as ft

from spherekin.mechanism.io import load_mechanism  # noqa: E402
from spherekin.plot import (BASE_COLOUR, LEG_COLOURS, PLATFORM_COLOUR, _configuration_arcs,  # noqa: E402
                            current_joint_axes)

NAME = "fig2_gosselin"
#: The mechanism drawn: the paper's Gosselin platform as this repository describes it.
MECHANISM_FILE = ft.ROOT / "examples" / "gosselin.toml"
#: The displaced configuration of panels (b)-(d): the platform turned by ROTATION_DEG about this
#: axis from R = I. 25 deg separates the links that coincide at the reference configuration by
#: ~0.2-0.4 rad on the sphere while keeping the pose recognisably the reference one.
ROTATION_AXIS = (1.0, 2.0, 1.5)
ROTATION_DEG = 25.0
#: Measured exterior angles and the model's phi_k must agree to this (radians, modulo 2 pi), and
#: both loops must close to it: double-precision products of 6 rotations are exact to ~1e-15.
ANGLE_TOL = 1e-12
#: Line widths (points) of the mechanism panel: proximal links thick, distal links thin (as the
#: paper's drawing tells them apart), the platform and the base in between.
WIDTHS = {"proximal": 4.2, "distal": 1.8, "platform": 3.2, "base": 2.6}
GREEK = {"beta": "β", "gamma": "γ", "delta": "δ"}


# --------------------------------------------------------------------------------------------
# Configurations and loops
# --------------------------------------------------------------------------------------------

def rotation(axis, angle: float) -> np.ndarray:
    """Rodrigues' rotation matrix about the unit vector of ``axis`` by ``angle`` radians."""
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * kx @ kx


def configurations(mech) -> dict:
    """name -> joint readings (radians): 'reference' and 'displaced' (IK branch nearest the reference)."""
    ref = {j.name: j.reference_angle for j in mech.joints}
    target = rotation(ROTATION_AXIS, math.radians(ROTATION_DEG))
    sols = mech.inverse_kinematics(target)
    wrap = lambda a: (a + math.pi) % (2 * math.pi) - math.pi  # noqa: E731

    def distance(s):
        return max(abs(wrap(s.joint_angles[n] - ref[n])) for n in ref)

    best = min(sols, key=distance)
    return {"reference": ref, "displaced": dict(best.joint_angles)}


def axes_at(mech, readings: dict) -> dict:
    """Leg name -> current joint axes (k, 3) at the joint readings."""
    inputs = [readings[n] for n in mech.actuated]
    return current_joint_axes(mech, inputs, {n: readings[n] for n in mech.passive})


def loop_data(mech, readings: dict, axes: dict) -> list[dict]:
    """Per loop: its legs, joint names, vertices (current axes), the model's phi_k and the measured angles."""
    legs = {leg.name: leg for leg in mech.legs}
    out = []
    for g in mech.loop_geometry:
        up, down = g.legs
        names = [j.name for j in legs[up].joints] + [j.name for j in reversed(legs[down].joints)]
        verts = np.concatenate([axes[up], axes[down][::-1]])
        if [v.joint for v in g.vertices] != names:
            raise RuntimeError(f"loop {g.legs}: vertex order {[v.joint for v in g.vertices]} is not {names}")
        measured = ft.polygon(verts)
        phis = g.factor_angles(readings)
        d = measured["exterior"] - phis
        gap = np.abs(d - 2 * math.pi * np.round(d / (2 * math.pi))).max()
        out.append(dict(legs=g.legs, names=names, vertices=verts, specs=g.factor_specs(), phis=phis,
                        sides=measured["sides"], angle_gap=float(gap)))
    return out


def compute() -> dict:
    mech = load_mechanism(MECHANISM_FILE)
    configs = configurations(mech)
    axes = {k: axes_at(mech, r) for k, r in configs.items()}
    loops = loop_data(mech, configs["displaced"], axes["displaced"])
    residuals = mech.forward(configs["displaced"]).loop_residuals
    ref_residuals = mech.forward(configs["reference"]).loop_residuals
    return dict(mechanism=mech, configs=configs, axes=axes, loops=loops, residuals=residuals,
                reference_residuals=ref_residuals)


# --------------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------------

def greek(name: str) -> str:
    """beta1 -> β1."""
    for word, letter in GREEK.items():
        if name.startswith(word):
            return letter + name[len(word):]
    return name


def pi_multiple(x: float) -> str:
    """A multiple of pi/2 as text (0, π/2, π, 3π/2, −π/2, ...), else the number in radians."""
    k = round(x / (math.pi / 2))
    if abs(x - k * math.pi / 2) > 1e-9:
        return f"{x:.3f}"
    sign = "−" if k < 0 else ""
    k = abs(k)
    text = {0: "0", 1: "π/2", 2: "π", 3: "3π/2", 4: "2π"}.get(k, f"{k}π/2")
    return sign + text


def factor_text(offset: float, name: str | None, sign: int) -> str:
    head = pi_multiple(offset)
    if name is None:
        return head
    joint = greek(name)
    if head == "0":
        return joint if sign > 0 else f"−{joint}"
    return f"{head} {'+' if sign > 0 else '−'} {joint}"


def _joint_colours(mech) -> dict:
    return {j.name: LEG_COLOURS[i % len(LEG_COLOURS)] for i, leg in enumerate(mech.legs) for j in leg.joints}


def _mechanism_panel(ax, mech, axes, view) -> None:
    """The mechanism as the paper draws it: base triangle, each leg's proximal and distal link, platform triangle."""
    v = view[0]
    legs = [leg.name for leg in mech.legs]
    base = [axes[n][0] for n in legs]
    platform = [axes[n][-1] for n in legs]
    for i in range(len(legs)):
        ft.draw_arc(ax, base[i], base[(i + 1) % len(legs)], v, BASE_COLOUR, WIDTHS["base"], 2)
        ft.draw_arc(ax, platform[i], platform[(i + 1) % len(legs)], v, PLATFORM_COLOUR, WIDTHS["platform"], 3)
    centre = sum(p for leg in axes.values() for p in leg)
    centre = centre / np.linalg.norm(centre)
    colours = _joint_colours(mech)
    for i, leg in enumerate(mech.legs):
        pts = axes[leg.name]
        for k, (p, q) in enumerate(zip(pts[:-1], pts[1:])):
            ft.draw_arc(ax, p, q, v, LEG_COLOURS[i % len(LEG_COLOURS)],
                        WIDTHS["proximal"] if k == 0 else WIDTHS["distal"], 4)
        for j, p in zip(leg.joints, pts):
            ft.draw_point(ax, p, v, colours[j.name], "s" if j.actuated else "o")
            ft.label_at(ax, ft.away(p, centre, 0.13), greek(j.name), v, colours[j.name], radius=1.0, fontsize=11,
                        fontweight="bold")


def _loop_panel(ax, mech, axes, loop, view) -> list[str]:
    v = view[0]
    for points, colour, width, zorder in _configuration_arcs(mech, axes):   # the whole mechanism, faint
        ft.draw_curve(ax, points, v, "0.8", 1.4, 1)
    verts, names = loop["vertices"], loop["names"]
    colours = _joint_colours(mech)
    m = len(verts)
    up, down = loop["legs"]
    n_up = len([leg for leg in mech.legs if leg.name == up][0].joints)
    for k in range(m):
        a, b = verts[k], verts[(k + 1) % m]
        if k < n_up - 1:
            colour = colours[names[k]]                       # up the leg
        elif k == n_up - 1:
            colour = PLATFORM_COLOUR                         # across the platform
        elif k < m - 1:
            colour = colours[names[k]]                       # down the reference leg
        else:
            colour = BASE_COLOUR                             # across the base, back to the start
        ft.draw_arc(ax, a, b, v, colour, 2.8, 3)
    centre = verts.sum(axis=0) / np.linalg.norm(verts.sum(axis=0))
    rows = []
    for k, (p, name, spec) in enumerate(zip(verts, names, loop["specs"])):
        ft.draw_point(ax, p, v, colours[name], "s" if mech.joint(name).actuated else "o")
        ft.label_at(ax, ft.away(p, centre, 0.16), f"{k + 1}", v, colours[name], radius=1.0, fontsize=12,
                    fontweight="bold", bbox=dict(boxstyle="circle,pad=0.15", fc="white", ec=colours[name], alpha=0.9))
        rows.append(f"{k + 1}  {greek(name):<3} φ{k + 1} = {factor_text(*spec)}")
    return rows


def draw(data: dict):
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    mech, axes = data["mechanism"], data["axes"]
    view = ft.view_for(np.concatenate([pts for cfg in axes.values() for pts, *_ in _configuration_arcs(mech, cfg)]))
    fig = Figure(figsize=(24.0, 8.6))
    grid = fig.add_gridspec(1, 5, width_ratios=(1.15, 1.0, 0.36, 1.0, 0.36), left=0.0, right=0.99, top=0.8,
                            bottom=0.13, wspace=0.0)
    cfg = data["configs"]["displaced"]
    inputs = ", ".join(f"{greek(n)} = {cfg[n]:+.3f}" for n in mech.actuated)

    ax = ft.sphere_axes(fig, grid[0, 0], view, f"(a) the Gosselin platform ({MECHANISM_FILE.name}), platform turned "
                        f"{ROTATION_DEG:g}° about ({', '.join(f'{c:g}' for c in ROTATION_AXIS)})\n"
                        f"inputs {inputs} rad; proximal links thick, distal links thin", pad=14)
    _mechanism_panel(ax, mech, axes["displaced"], view)
    for k, loop in enumerate(data["loops"]):
        up, down = loop["legs"]
        title = (f"({'bc'[k]}) loop {k + 1}: up {up}, across the platform, down {down}, across the base\n"
                 f"6 sides of 90°; |Π Rx(φi) Z − I| {ft.residual_phrase(data['residuals'][k])}")
        ax = ft.sphere_axes(fig, grid[0, 1 + 2 * k], view, title, pad=14)
        rows = _loop_panel(ax, mech, axes["displaced"], loop, view)
        tab = fig.add_subplot(grid[0, 2 + 2 * k])
        tab.set_axis_off()
        tab.text(0.0, 0.5, "vertex, joint,\nangle in Eq. (2):\n\n" + "\n".join(rows), transform=tab.transAxes,
                 ha="left", va="center", fontsize=10.5, family="DejaVu Sans Mono", linespacing=1.5)
    fig.suptitle("The paper's Fig. 2 redrawn: the Gosselin platform (left) and the spherical polygons it defines "
                 "(right; Eqs. 3-5)\n"
                 "joint axes are points of the unit sphere, links are great-circle arcs; actuated joints β_i "
                 "(squares), passive γ_i, δ_i (dots)", fontsize=12.5)
    handles = [Line2D([], [], color=BASE_COLOUR, lw=WIDTHS["base"], label="base"),
               Line2D([], [], color=PLATFORM_COLOUR, lw=WIDTHS["platform"], label="platform")]
    for i, leg in enumerate(mech.legs):
        c = LEG_COLOURS[i % len(LEG_COLOURS)]
        handles += [Line2D([], [], color=c, lw=WIDTHS["proximal"], label=f"{leg.name}: proximal link"),
                    Line2D([], [], color=c, lw=WIDTHS["distal"], label=f"{leg.name}: distal link")]
    handles += [Line2D([], [], color="black", marker="s", ls="", label="actuated joint β_i"),
                Line2D([], [], color="0.8", lw=1.4, label="other links (loop panels)"),
                Line2D([], [], color="0.3", lw=1.2, ls=(0, (3, 2)), alpha=0.6, label="far side of the sphere")]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=10, frameon=False, bbox_to_anchor=(0.5, 0.01))
    return fig


def main(argv=None) -> dict:
    args = ft.parser(__doc__.split("\n\n")[0]).parse_args(argv)
    data = compute()
    mech = data["mechanism"]
    for k, loop in enumerate(data["loops"]):
        print(f"loop {k + 1} {loop['legs']}: " + ", ".join(
            f"{n}: phi = {factor_text(*s)}" for n, s in zip(loop["names"], loop["specs"])))
        print(f"   sides (deg) {np.round(np.degrees(loop['sides']), 9)}; measured exterior angles = model phi_k "
              f"within {loop['angle_gap']:.1e} rad; |F - I| = {data['residuals'][k]:.1e}")
    print(f"reference configuration: loop residuals {[f'{r:.1e}' for r in data['reference_residuals']]}; "
          f"displaced inputs {[round(data['configs']['displaced'][n], 4) for n in mech.actuated]} rad")
    worst = max([lp["angle_gap"] for lp in data["loops"]] + list(data["residuals"]) + list(data["reference_residuals"]))
    if worst > ANGLE_TOL:
        raise RuntimeError(f"the model's loops disagree with the drawn polygons: {worst:.2e} > {ANGLE_TOL}")
    ft.save(draw(data), args.out_dir, NAME)
    return data


if __name__ == "__main__":
    main()
