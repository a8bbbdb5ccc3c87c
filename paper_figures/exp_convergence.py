"""This project's experiment (not a figure of the paper): convergence of the subdivision near the roots (Section 4's "quadratically convergent" claim).

Plots the latest run of experiments/convergence.py (see _figure_tools.experiment_data: the full
run, else the quick one, else a quick run made now) in two panels:

(a) the widest side of the box that holds a root against the iteration (subdivision depth), log y,
    one colour per configuration (paper's scalar Eq. (10) vs the transversal equations, LP vs
    projected-polyhedron pruning): thin lines for every root, a thick line for the first regular one;
(b) boxes processed against the tolerance, log-log, summed over the same local problems.

    python -m paper_figures.exp_convergence [--out-dir paper_figures] [--results PATH]
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent

from paper_figures._figure_tools import experiment_data, parser, save

#: One colour and marker per configuration (colour-blind safe pairs: formulation = hue family,
#: pruner = dark/light), so the four stay apart in print and on screen.
STYLE = {"paper + lp": ("#b2182b", "o"), "paper + pp": ("#ef8a62", "s"),
         "transversal + lp": ("#2166ac", "^"), "transversal + pp": ("#67a9cf", "D")}
FALLBACK = ("#444444", "x")


def line_style(name: str) -> str:
    """LP pruning solid, projected polyhedron dashed (the paper's two curves nearly coincide)."""
    return "--" if name.endswith("pp") else "-"


def draw(data: dict):
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    names = [c["name"] for c in data["configs"]]
    bold = next((p["index"] for p in data["problems"] if p["status"] == "certified"), data["problems"][0]["index"])
    for name in names:
        colour, marker = STYLE.get(name, FALLBACK)
        for ch in data["chains"]:
            if ch["config"] != name or not ch["chain"]:
                continue
            depth = [c["depth"] for c in ch["chain"]] + [ch["chain"][-1]["depth"] + 1]
            width = [c["w_in"] for c in ch["chain"]] + [ch["chain"][-1].get("w_out", ch["chain"][-1]["w_in"])]
            if ch["root"] == bold:
                ax1.semilogy(depth, width, color=colour, marker=marker, ms=3.5, lw=1.6, ls=line_style(name),
                             zorder=4 if name.endswith("lp") else 3,
                             label=f"{name} (root {bold})")
            else:
                ax1.semilogy(depth, width, color=colour, lw=0.8, alpha=0.4, ls=line_style(name))
    for form, tol in data["trace_tol"].items():
        ax1.axhline(tol, color="k", ls=":", lw=1)
        ax1.annotate(f"tol {tol:.0e} rad ({form})", (0.02, tol), xycoords=("axes fraction", "data"),
                     ha="left", va="bottom", fontsize=8)
    ax1.set_xlabel("iteration k (subdivision depth: one pruning step per level)")
    ax1.set_ylabel("widest side of the box holding the root (rad)")
    ax1.set_title("(a) Box width along each root's chain\n(thin: other roots; no Krawczyk isolation)")
    ax1.grid(True, which="major", alpha=0.3)
    ax1.legend(fontsize=8, loc="upper right")

    for name in names:
        colour, marker = STYLE.get(name, FALLBACK)
        rows = [r for r in data["sweep"] if r["config"] == name]
        pts = [(r["tol"], r["boxes"]) for r in rows if r["boxes"] is not None]
        if pts:
            t, b = zip(*pts)
            ax2.loglog(t, b, color=colour, marker=marker, ms=5, lw=1.5, ls=line_style(name), label=name)
            capped = [r["tol"] for r in rows if r["boxes"] is None]
            if capped:   # the next tolerance hit the box cap: say so at the last point
                ax2.annotate(f"tol {capped[0]:.0e}: box cap", (t[-1], b[-1]), textcoords="offset points",
                             xytext=(6, 4), fontsize=8, color=colour)
    ax2.invert_xaxis()
    ax2.set_xlabel("tolerance (rad)  [smaller to the right]")
    ax2.set_ylabel(f"boxes processed (sum over {len(data['problems'])} local problems)")
    ax2.set_title("(b) Cost against tolerance")
    ax2.grid(True, which="major", alpha=0.3)
    ax2.legend(fontsize=8, loc="upper left")
    fig.suptitle("Convergence near the roots of the Gosselin platform: paper's Eq. (10) vs transversal equations",
                 fontsize=11)
    return fig


def main(argv=None):
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--results", type=Path, default=None,
                   help="convergence.json to plot (default: the latest run, see _figure_tools.experiment_data)")
    args = p.parse_args(argv)
    data, quick = experiment_data("convergence", args.results)
    fig = draw(data)
    paths = save(fig, args.out_dir, "exp_convergence", quick=quick)
    plt.close(fig)
    return paths


if __name__ == "__main__":
    main()
