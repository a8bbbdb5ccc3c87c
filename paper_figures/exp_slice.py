"""This project's experiment (not a figure of the paper): the subdivision boxes of the solver over a 2-D closure system, paper formulation vs default.

Question: what does the subdivision of Section 4 do, box by box, and how does the paper's scalar
equation (Eq. 10) differ from the default formulation in the boxes it needs?

How: the spherical four-bar preset (ground 80, crank 30, coupler 70, rocker 60 deg) at crank input
A = INPUT rad has two assemblies (3 passive joints B, D, C; one loop). The rocker angle D is also
fixed, at its value in the assembly nearer the reference configuration, which leaves a genuinely
2-D system: one closure loop F(B, C) = I (three independent equations, two unknowns, consistent
because D is taken from a solution). Both unknowns range over the full circle, which tan-half
covers by four charts (B, C each in [-90, 90] or [90, 270] deg). The system is solved twice with
:func:`spherekin.search.boxloop.solve_system` and a ``trace=`` callback that records every processed box
and its outcome (discarded / split / reduced again / accepted / isolated):

* left: the paper's formulation (Eq. 10, one scalar equation per loop; ``--paper-pruner`` pp by
  default, lp for the Eq. 12 LPs) without isolation, as in the paper;
* right: the solver's defaults (formulation, pruner, isolation).

Both use the default tolerance. Under the boxes, the equations each formulation prunes with,
evaluated on a grid by plain rotation products: the Eq. (10) value over q (F11 + F22 - 2 <= 0,
which touches 0 only at the root: contour lines of a well) and, for the halves formulation, the
zero curves of the nine entries of P - S^T (P, S the products of the loop's two halves). The
bottom row zooms on the root. Roots: the root of the slice (from the polished full solve) as a
star; every solution the solver reports as a circle, or as a cross when its closure residual
shows it is not a root. No randomness (--seed is unused); --quick changes nothing (seconds).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np


from paper_figures import _figure_tools as ft
from experiments._common import median_time

from spherekin.closure import ClosureLoop, Term, Unknown  # noqa: E402
from spherekin.mechanism import presets  # noqa: E402
from spherekin.search.parameterizations import charts_for_range  # noqa: E402
from spherekin.core.rotations import normalized_closure  # noqa: E402
from spherekin.search.boxloop import DEFAULT_TOL, TRACE_OUTCOMES, solve_system  # noqa: E402
from spherekin.problem import solve  # noqa: E402

NAME = "exp_slice"
#: Crank input (radians): the four-bar input of tests/test_plot.py; any input with two assemblies works.
INPUT = 0.5
#: The passive joint fixed in the slice, and the two that stay unknown (in this order: x, y axes).
FIXED = "D"
UNKNOWNS = ("B", "C")
#: Both unknowns over the full circle (tan-half covers each by the charts [-90, 90] and [90, 270] deg).
RANGES = {name: None for name in UNKNOWNS}
#: Half-width (degrees) of the zoom around the root in the bottom row: wide enough to show the
#: last split boxes, small enough that the accepted boxes stand apart from them.
ZOOM_DEG = 4.0
#: Grid points per axis for the equation curves: 0.9 deg steps over the 360-deg window (about two
#: pixels at figure size, so the curves look smooth); the zoom gets its own grid of the same size.
GRID = 401
#: A reported solution is a root when its closure residual |F - I| (Frobenius) is below this many
#: tolerances. Reason: each factor Rx(phi) has a derivative of Frobenius norm sqrt(2) and rotations
#: keep the norm, so within a box of side tol around a root |F - I| <= sqrt(2) * 2 tol < 3 tol; 10
#: leaves a margin, and a false acceptance (residual O(1)) is far above it.
ROOT_RESIDUAL_TOLS = 10.0
#: Timing repeats (median) for the solve times printed (not drawn: the PNG is committed and must
#: not change from run to run).
REPEATS = 3
#: Colour (edge, fill) of each trace outcome.
OUTCOME_STYLE = {
    "discarded": ("0.55", "0.88"),
    "split": ("tab:blue", "none"),
    "reduced_again": ("tab:green", "none"),
    "accepted": ("tab:red", "none"),
    "isolated": ("tab:purple", "none"),
}
#: Contour levels of F11 + F22 - 2 (its range is [-4, 0]).
WELL_LEVELS = (-3.0, -2.0, -1.0, -0.3, -0.05)


# --------------------------------------------------------------------------------------------
# The 2-D system
# --------------------------------------------------------------------------------------------

def slice_problem(inp: float = INPUT):
    """(mechanism, root angles {B, D, C}) : the four-bar and its assembly nearer the reference pose."""
    mech = presets.four_bar()
    report = solve(mech, (inp,))
    if not report.solutions:
        raise RuntimeError(f"the four-bar has no assembly at input {inp}")
    sol = min(report.solutions, key=lambda s: float(np.abs(s.angles).max()))
    return mech, dict(zip(report.unknowns, (float(a) for a in sol.angles)))


def make_build(mech, inp: float, fixed_value: float):
    """``build(chart_ranges)`` of solve_system: the four-bar loop with A = inp and D = fixed_value known."""

    def build(chart):
        system = mech.loop_system((inp,), {**{n: chart[n] for n in UNKNOWNS},
                                           FIXED: (fixed_value - 1.0, fixed_value + 1.0)})
        (loop,) = system.loops
        factors = [f.offset + f.sign * fixed_value if isinstance(f, Term) and f.unknown.name == FIXED else f
                   for f in loop.factors]
        return [ClosureLoop(factors)], tuple(system.unknown(n) for n in UNKNOWNS)

    return build


def factor_angles(loop: ClosureLoop, values: dict) -> np.ndarray:
    """phi_1..phi_n (radians) of the loop at joint readings ``values`` (name -> array), shape (..., n)."""
    cols = []
    shape = np.broadcast(*values.values()).shape
    for f in loop.factors:
        if isinstance(f, Term):
            cols.append(f.offset + f.sign * np.broadcast_to(values[f.unknown.name], shape))
        else:
            cols.append(np.full(shape, f))
    return np.stack(cols, axis=-1)


def closure(loop: ClosureLoop, b, c) -> np.ndarray:
    """F(B, C) = prod Rx(phi_i) Z by plain matrix products, shape (..., 3, 3)."""
    return normalized_closure(factor_angles(loop, {"B": np.asarray(b, float), "C": np.asarray(c, float)}))


def halves(loop: ClosureLoop, b, c) -> np.ndarray:
    """The nine entries of P - S^T (..., 3, 3): P the factors up to the loop's first unknown, S the rest."""
    phis = factor_angles(loop, {"B": np.asarray(b, float), "C": np.asarray(c, float)})
    split = next(i for i, f in enumerate(loop.factors) if isinstance(f, Term)) + 1
    p = normalized_closure(phis[..., :split])
    s = normalized_closure(phis[..., split:])
    return p - np.swapaxes(s, -1, -2)


def residual(loop: ClosureLoop, b, c) -> np.ndarray:
    """|F(B, C) - I| (Frobenius)."""
    return np.linalg.norm(closure(loop, b, c) - np.eye(3), axis=(-2, -1))


# --------------------------------------------------------------------------------------------
# Solving with a trace
# --------------------------------------------------------------------------------------------

def chart_ranges(ranges=RANGES) -> list[list[tuple[float, float]]]:
    """For every chart index of solve_system, the (lo, hi) chart range (radians) of each unknown.

    Charts are the Cartesian product of each unknown's :func:`charts_for_range`, first unknown
    slowest (the order of spherekin.search.parameterizations); :func:`trace_boxes` checks the mapping
    against the metric widths that the trace records.
    """
    per_name = [charts_for_range(ranges[n]) for n in UNKNOWNS]
    return [[per_name[k][i] for k, i in enumerate(combo)]
            for combo in itertools.product(*(range(len(p)) for p in per_name))]


def trace_boxes(records: list[dict], ranges=RANGES) -> dict:
    """The processed boxes in angle coordinates (radians): lo, hi (B, 2) and outcome names (B,)."""
    charts = chart_ranges(ranges)
    chart = np.concatenate([r["chart"] for r in records])
    xlo = np.concatenate([r["lo"] for r in records])
    xhi = np.concatenate([r["hi"] for r in records])
    rlo = np.concatenate([r["reduced_lo"] for r in records])
    rhi = np.concatenate([r["reduced_hi"] for r in records])
    width = np.concatenate([r["metric_width"] for r in records])
    outcome = np.concatenate([r["outcome"] for r in records])
    lo, hi, red_lo, red_hi = (np.empty_like(xlo) for _ in range(4))
    for k, name in enumerate(UNKNOWNS):
        for c in np.unique(chart):
            m = chart == c
            u = Unknown(name, *charts[c][k])
            lo[m, k], hi[m, k] = u.to_angle(xlo[m, k]), u.to_angle(xhi[m, k])
            red_lo[m, k], red_hi[m, k] = u.to_angle(rlo[m, k]), u.to_angle(rhi[m, k])
    if not np.allclose(hi - lo, width, rtol=1e-9, atol=1e-12):
        raise RuntimeError("chart mapping of the trace disagrees with its metric widths (chart order changed?)")
    return dict(lo=lo, hi=hi, reduced_lo=red_lo, reduced_hi=red_hi,
                outcome=np.array([TRACE_OUTCOMES[i] for i in outcome]), chart=chart)


def _source_box(boxes, angles):
    """(processed width B, C, reduced width B, C) in degrees of the accepted box holding ``angles``, or None."""
    a = np.mod(np.asarray(angles) - boxes["lo"] + math.pi / 2, 2 * math.pi) - math.pi / 2  # offsets from lo
    hit = np.flatnonzero((boxes["outcome"] == "accepted")
                         & np.all((a >= boxes["reduced_lo"] - boxes["lo"] - 1e-9)
                                  & (a <= boxes["reduced_hi"] - boxes["lo"] + 1e-9), axis=1))
    if not len(hit):
        return None
    i = hit[0]
    return tuple(np.degrees(np.concatenate([boxes["hi"][i] - boxes["lo"][i],
                                            boxes["reduced_hi"][i] - boxes["reduced_lo"][i]])))


def run(build, tol: float, **strategy) -> dict:
    """Solve the slice with a trace; return the report, the boxes and the median solve time."""
    records: list[dict] = []
    report = solve_system(build, RANGES, tol=tol, trace=records.append, **strategy)
    seconds, _, _ = median_time(lambda: solve_system(build, RANGES, tol=tol, **strategy), REPEATS)
    return dict(report=report, boxes=trace_boxes(records), seconds=seconds)


def compute(inp: float = INPUT, tol: float = DEFAULT_TOL, paper_pruner: str = "pp") -> dict:
    """Everything the figure shows: the root, the loop and both solver runs."""
    mech, root = slice_problem(inp)
    build = make_build(mech, inp, root[FIXED])
    loop = build({n: (-1.0, 1.0) for n in UNKNOWNS})[0][0]
    runs = {
        "paper": run(build, tol, formulation="paper", pruner=paper_pruner, isolate=False),
        "default": run(build, tol),
    }
    for r in runs.values():
        r["solutions"] = [dict(angles=np.array(s.angles, dtype=float),
                               residual=float(residual(loop, *s.angles)))
                          for s in r["report"].clusters]
        for s in r["solutions"]:
            s["is_root"] = s["residual"] <= ROOT_RESIDUAL_TOLS * tol
            s["source"] = None if s["is_root"] else _source_box(r["boxes"], s["angles"])
    return dict(mechanism=mech, input=inp, tol=tol, root=root, loop=loop, runs=runs)


# --------------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------------

def _window(centre=None):
    if centre is None:
        return (-90.0, 270.0), (-90.0, 270.0)
    b, c = np.degrees(centre)
    return (b - ZOOM_DEG, b + ZOOM_DEG), (c - ZOOM_DEG, c + ZOOM_DEG)


def _background(ax, loop, kind: str, window) -> None:
    (b0, b1), (c0, c1) = window
    b, c = np.meshgrid(np.radians(np.linspace(b0, b1, GRID)), np.radians(np.linspace(c0, c1, GRID)), indexing="xy")
    bd, cd = np.degrees(b), np.degrees(c)
    if kind == "paper":
        f = closure(loop, b, c)
        well = f[..., 0, 0] + f[..., 1, 1] - 2.0
        cs = ax.contour(bd, cd, well, levels=WELL_LEVELS, colors="0.35", linewidths=0.7, zorder=1)
        ax.clabel(cs, fontsize=6.5, fmt="%g", inline_spacing=2)
    else:
        h = halves(loop, b, c)
        for r in range(3):
            for k in range(3):
                ax.contour(bd, cd, h[..., r, k], levels=[0.0], colors=[f"C{(3 * r + k) % 10}"],
                           linewidths=0.9, alpha=0.55, zorder=1)


def _boxes(ax, boxes, window) -> None:
    from matplotlib.patches import Rectangle

    (b0, b1), (c0, c1) = window
    lo, hi = np.degrees(boxes["lo"]), np.degrees(boxes["hi"])
    order = {"discarded": 0, "split": 1, "reduced_again": 2, "accepted": 3, "isolated": 4}
    for i in sorted(range(len(lo)), key=lambda i: order[boxes["outcome"][i]]):
        if hi[i, 0] < b0 or lo[i, 0] > b1 or hi[i, 1] < c0 or lo[i, 1] > c1:
            continue
        edge, fill = OUTCOME_STYLE[boxes["outcome"][i]]
        filled = fill != "none"
        ax.add_patch(Rectangle((lo[i, 0], lo[i, 1]), hi[i, 0] - lo[i, 0], hi[i, 1] - lo[i, 1],
                               facecolor=fill if filled else "none", edgecolor=edge,
                               lw=0.5 if filled else 1.1, alpha=0.55 if filled else 0.9, zorder=2))


def _roots(ax, data, r, window) -> None:
    (b0, b1), (c0, c1) = window
    root = np.degrees([data["root"][n] for n in UNKNOWNS])
    ax.plot(*root, marker="*", ms=15, color="gold", mec="black", mew=0.8, ls="", zorder=6)
    for s in r["solutions"]:
        b, c = np.degrees(s["angles"])
        c = c + 360.0 if c < c0 else c           # the charts show C in [-90, 270) deg
        b = b + 360.0 if b < b0 else b
        if not (b0 <= b <= b1 and c0 <= c <= c1):
            continue
        if s["is_root"]:
            ax.plot(b, c, marker="o", ms=21, mfc="none", mec="black", mew=1.4, ls="", zorder=7)
        else:
            ax.plot(b, c, marker="X", ms=11, color="black", mec="white", mew=0.8, ls="", zorder=7)
            text = f"reported, not a root: |F - I| = {s['residual']:.2g}"
            if s.get("source") is not None:
                text += ("\nits accepted box: a {:.0f} x {:.0f} deg box\nthat one reduction shrank to "
                         "{:.0e} x {:.0e} deg").format(*s["source"])
            ax.annotate(text, (b, c), xytext=(10, 10), textcoords="offset points", fontsize=8, zorder=8,
                        bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="0.5", alpha=0.92))


def _counts(boxes) -> dict:
    return {k: int(np.sum(boxes["outcome"] == k)) for k in TRACE_OUTCOMES}


def _title(r, label: str) -> str:
    s = r["report"].settings
    cnt = _counts(r["boxes"])
    n_roots = sum(x["is_root"] for x in r["solutions"])
    n_false = len(r["solutions"]) - n_roots
    iso = "off" if not s.isolate else ("on (never applies here: 3 equations, 2 unknowns)" if not cnt["isolated"]
                                          else "on")
    head = f"{label}: formulation {s.formulation}, pruner {s.pruner},\nisolation {iso}"
    line2 = (f"{len(r['boxes']['outcome'])} boxes ({cnt['discarded']} discarded, {cnt['split']} split, "
             f"{cnt['reduced_again']} reduced again, {cnt['accepted']} accepted, {cnt['isolated']} isolated)")
    line3 = f"{len(r['solutions'])} reported: {n_roots} root(s)" + (f", {n_false} false" if n_false else "")
    return "\n".join([head, line2, line3])


def draw(data: dict):
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fig = Figure(figsize=(13.0, 13.4))
    grid = fig.add_gridspec(2, 2, left=0.06, right=0.985, top=0.875, bottom=0.1, wspace=0.17, hspace=0.3)
    root = np.array([data["root"][n] for n in UNKNOWNS])
    for col, (kind, label) in enumerate((("paper", "paper"), ("default", "default"))):
        r = data["runs"][kind]
        halves_bg = r["report"].settings.formulation == "halves"
        for row, centre in enumerate((None, root)):
            window = _window(centre)
            ax = fig.add_subplot(grid[row, col])
            _background(ax, data["loop"], "halves" if halves_bg else "paper", window)
            _boxes(ax, r["boxes"], window)
            _roots(ax, data, r, window)
            ax.set_xlim(*window[0])
            ax.set_ylim(*window[1])
            ax.set_aspect("equal")
            ax.set_xlabel("B, crank-coupler joint angle (deg)")
            ax.set_ylabel("C, coupler-rocker joint angle (deg)")
            if centre is None:
                ax.set_xticks(np.arange(-90, 271, 45))
                ax.set_yticks(np.arange(-90, 271, 45))
                for v in (90.0,):
                    ax.axvline(v, color="0.3", lw=0.8, ls=":", zorder=1.5)
                    ax.axhline(v, color="0.3", lw=0.8, ls=":", zorder=1.5)
                ax.set_title(_title(r, label), fontsize=9.5)
            else:
                ax.set_title(f"{label}: zoom ±{ZOOM_DEG:g}° around the root", fontsize=9.5)
            ax.grid(False)
    root_deg = {n: math.degrees(v) for n, v in data["root"].items()}
    fig.suptitle(
        "Subdivision boxes on a 2-D slice of the spherical four-bar closure F(B, C) = I\n"
        f"crank A = {data['input']:g} rad, rocker D fixed at {root_deg[FIXED]:.2f} deg (its value at the "
        f"root B = {root_deg['B']:.2f}, C = {root_deg['C']:.2f} deg); tolerance {data['tol']:g} rad; "
        "dotted lines: tan-half chart edges",
        fontsize=11.5)
    handles = [Patch(facecolor=OUTCOME_STYLE["discarded"][1], edgecolor=OUTCOME_STYLE["discarded"][0],
                     alpha=0.55, label="box discarded (no root)")]
    handles += [Patch(facecolor="none", edgecolor=OUTCOME_STYLE[k][0], lw=1.1, label=f"box {k.replace('_', ' ')}")
                for k in ("split", "reduced_again", "accepted", "isolated")]
    handles += [Line2D([], [], marker="*", ms=13, color="gold", mec="black", ls="", label="root of the slice"),
                Line2D([], [], marker="o", ms=12, mfc="none", mec="black", ls="", label="reported solution (a root)"),
                Line2D([], [], marker="X", ms=10, color="black", ls="", label="reported solution, not a root"),
                Line2D([], [], color="0.35", lw=0.8, label="left: Eq. (10) / q = F11 + F22 - 2 (levels)"),
                Line2D([], [], color="C0", lw=0.9, alpha=0.7, label="right: zero curves of the nine P - S^T")]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=9, frameon=False, bbox_to_anchor=(0.5, 0.005))
    return fig


def numbers(data: dict) -> dict:
    """What the README quotes, per run ("paper", "default"): boxes in all and by trace outcome, solutions reported."""
    out = {}
    for kind, r in data["runs"].items():
        s = r["report"].settings
        out[kind] = dict(formulation=s.formulation, pruner=s.pruner, isolate=bool(s.isolate), tol=data["tol"],
                         boxes=len(r["boxes"]["outcome"]), solutions=len(r["solutions"]),
                         roots=sum(x["is_root"] for x in r["solutions"]), **_counts(r["boxes"]))
    return dict(input=data["input"], runs=out)


def main(argv=None) -> dict:
    p = ft.parser(__doc__.split("\n\n")[0])
    p.add_argument("--paper-pruner", choices=("pp", "lp"), default="pp",
                   help="pruner of the paper panel: pp (projected polyhedron) or lp (the Eq. 12 LPs, slower)")
    args = p.parse_args(argv)
    data = compute(paper_pruner=args.paper_pruner)
    for kind, r in data["runs"].items():
        cnt = _counts(r["boxes"])
        print(f"{kind}: {r['report'].settings.formulation}/{r['report'].settings.pruner}: "
              f"{len(r['boxes']['outcome'])} boxes {cnt}; median solve {1e3 * r['seconds']:.1f} ms; solutions "
              + ", ".join(f"({math.degrees(s['angles'][0]):.4f}, {math.degrees(s['angles'][1]):.4f}) deg "
                          f"|F-I|={s['residual']:.1e}" for s in r["solutions"]))
    ft.save(draw(data), args.out_dir, NAME)
    ft.save_numbers(args.out_dir, NAME, numbers(data))
    return data


if __name__ == "__main__":
    main()
