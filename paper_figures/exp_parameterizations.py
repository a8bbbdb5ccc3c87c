"""This project's experiment (not a figure of the paper): tan-half-angle vs sin/cos -- what each parameterization costs on the same mechanisms.

Question: the paper's tan(theta/2) (Section 2.2) or the sin/cos variables it proposes in Section 5?
Plots the latest run of experiments/parameterizations.py (see _figure_tools.experiment_data) and
draws, per mechanism and
parameterization: (a) the Bernstein control points of one loop equation on one chart and of all
equations over all charts, (b) the median number of boxes processed and (c) the median solve time
over the random ground-truth inputs. Log scales: the quantities span several decades.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


from paper_figures import _figure_tools as ft

NAME = "exp_parameterizations"
COLOURS = {"tan-half": "#1f77b4", "sin-cos": "#d95f02"}
LABELS = {"four_bar": "four-bar", "five_bar": "five-bar", "gosselin": "Gosselin", "general_3rrr": "general 3-RRR"}


def _bars(ax, mechs, values, ylabel, title, fmt="{:.0f}", hatch_values=None, headroom=3.0):
    x = np.arange(len(mechs))
    width = 0.38
    for k, p in enumerate(("tan-half", "sin-cos")):
        v = np.array([values[(m, p)] for m in mechs], float)
        bars = ax.bar(x + (k - 0.5) * width, v, width, color=COLOURS[p], label=p)
        for b, val in zip(bars, v):
            ax.annotate(fmt.format(val), (b.get_x() + b.get_width() / 2, val), ha="center", va="bottom",
                        fontsize=7.5, xytext=(0, 1), textcoords="offset points")
        if hatch_values is not None:
            h = np.array([hatch_values[(m, p)] for m in mechs], float)
            hb = ax.bar(x + (k - 0.5) * width, h, width * 0.45, color="white", edgecolor=COLOURS[p], hatch="////",
                        label=f"{p}: one loop equation, one chart")
            for b, val in zip(hb, h):
                ax.annotate(f"{val:.0f}", (b.get_x() + b.get_width() / 2, val), ha="center", va="bottom",
                            fontsize=7.5, xytext=(0, 1), textcoords="offset points", color="white", fontweight="bold")
    ax.set_xticks(x, [LABELS.get(m, m) for m in mechs])
    ax.set_yscale("log")
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10.5)
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi * headroom)   # room for the value labels and the legend above the bars
    ax.grid(axis="y", which="major", alpha=0.3)


def draw(data: dict):
    import matplotlib.pyplot as plt

    mechs = list(dict.fromkeys(r["mechanism"] for r in data["summary"]))
    summ = {(r["mechanism"], r["parameterization"]): r for r in data["summary"]}
    charts = {(r["mechanism"], r["parameterization"]): r for r in data["charts"]}
    fig, axes = plt.subplots(1, 3, figsize=(15.5, 4.8), constrained_layout=True)
    _bars(axes[0], mechs, {k: v["total_control_points"] for k, v in charts.items()},
          "control points (count)", "(a) Bernstein control points: all equations, all charts\n"
          "(hatched: one loop equation on one chart)",
          hatch_values={k: max(v["loop_control_points"]) for k, v in charts.items()}, headroom=40.0)
    _bars(axes[1], mechs, {k: v.get("median_boxes", np.nan) for k, v in summ.items()},   # NaN: every run capped
          "boxes processed (median over inputs)",
          "(b) subdivision boxes")
    _bars(axes[2], mechs, {k: v.get("median_time_ms", np.nan) for k, v in summ.items()}, "solve time (ms, median)",
          "(c) wall time per solve")
    for ax in axes:
        ax.legend(fontsize=8, loc="upper left")
    n = data["summary"][0]["inputs"]
    agree = all(r.get("same_solutions") and r.get("truth_found") for r in data["summary"])
    fig.suptitle(f"Tangent half-angle vs sin/cos parameterization ({n} random inputs per mechanism; "
                 f"{'same solutions, start pose found in every case' if agree else 'SOLUTION SETS DIFFER: see table'})",
                 fontsize=12)
    return fig


def main(argv=None):
    args = ft.parser(__doc__.splitlines()[0]).parse_args(argv)
    data, quick = ft.experiment_data("parameterizations")
    fig = draw(data)
    ft.save(fig, args.out_dir, NAME, quick=quick)


if __name__ == "__main__":
    main()
