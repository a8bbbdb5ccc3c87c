"""This project's experiment (not a figure of the paper): how the cost of a solve grows with the number of unknown joint angles.

Question: how do boxes and time grow from one-loop linkages (3 unknowns) to 3-RRRs (6) and to
four-legged platforms (8 and 9)? Plots the latest run of experiments/scaling.py (see
_figure_tools.experiment_data), per
mechanism and parameterization, (a) boxes processed and (b) solve time against the number of
unknowns, on log scales. Mechanisms the solver could not handle, or that the quick run skipped,
are listed under the panels.
"""

from __future__ import annotations

from pathlib import Path


from paper_figures import _figure_tools as ft

NAME = "exp_scaling"
COLOURS = {"tan-half": "#1f77b4", "sin-cos": "#d95f02"}
MARKERS = {"four_bar": "o", "five_bar": "s", "gosselin": "^", "general_3rrr": "v", "3rrr_rrrr": "D",
           "4rrr_redundant": "P", "3rrr_passive_leg": "X"}
LABELS = {"four_bar": "four-bar", "five_bar": "five-bar", "gosselin": "Gosselin 3-RRR",
          "general_3rrr": "general 3-RRR", "3rrr_rrrr": "3-RRR with an RRRR leg",
          "4rrr_redundant": "4-RRR, redundantly actuated (9 eq.)", "3rrr_passive_leg": "3-RRR + passive RRR leg"}
#: Horizontal offsets (unknowns) of the two parameterizations so that equal-size mechanisms do not overlap.
OFFSET = {"tan-half": -0.12, "sin-cos": 0.12}
JITTER = {"four_bar": -0.05, "five_bar": 0.05, "gosselin": -0.06, "general_3rrr": 0.0, "3rrr_rrrr": 0.06}


def draw(data: dict):
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    rows = data["runs"]
    fig, axes = plt.subplots(1, 2, figsize=(13.5, 5.6), constrained_layout=True)
    missing = []
    for r in rows:
        if "boxes" not in r:
            why = r.get("error") or ("not run in --quick" if r.get("skipped") else "no result")
            missing.append(f"{LABELS.get(r['mechanism'], r['mechanism'])}, {r['parameterization']}: {why}")
            continue
        x = r["unknowns"] + OFFSET[r["parameterization"]] + JITTER.get(r["mechanism"], 0.0)
        for ax, key in zip(axes, ("boxes", "time")):
            ax.scatter(x, r[key], marker=MARKERS.get(r["mechanism"], "o"), s=70, color=COLOURS[r["parameterization"]],
                       edgecolor="black", linewidth=0.6, zorder=3)
    for ax, ylabel, title in ((axes[0], "boxes processed (count)", "(a) subdivision boxes"),
                              (axes[1], "solve time (s, median)", "(b) wall time per solve")):
        ax.set_yscale("log")
        ax.set_xlabel("unknown (passive) joint angles")
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=11)
        ax.set_xticks(sorted({r["unknowns"] for r in rows}))
        ax.grid(alpha=0.3, which="major")
    handles = [Line2D([], [], marker="o", linestyle="", color=c, markeredgecolor="black", markersize=8, label=p)
               for p, c in COLOURS.items()]
    handles += [Line2D([], [], marker=MARKERS[m], linestyle="", color="lightgrey", markeredgecolor="black",
                       markersize=8, label=LABELS[m]) for m in dict.fromkeys(r["mechanism"] for r in rows)]
    axes[0].legend(handles=handles, fontsize=8, loc="upper left")
    fig.suptitle("Cost of the direct kinematics against the number of unknowns "
                 "(one ground-truth input per mechanism, tol 1e-6)", fontsize=12)
    if missing:
        fig.text(0.01, 0.005, "Not plotted: " + "; ".join(missing), fontsize=8, ha="left", va="bottom", wrap=True)
        fig.get_layout_engine().set(rect=(0, 0.05, 1, 0.95))
    return fig


def main(argv=None):
    args = ft.parser(__doc__.splitlines()[0]).parse_args(argv)
    data, quick = ft.experiment_data("scaling")
    fig = draw(data)
    ft.save(fig, args.out_dir, NAME, quick=quick)


if __name__ == "__main__":
    main()
