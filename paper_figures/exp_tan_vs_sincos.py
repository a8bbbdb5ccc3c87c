"""This project's experiment (not a figure of the paper): tan(theta/2) against (cos, sin) inside the paper's algorithm.

Plots the latest run of experiments/tan_vs_sincos.py (see _figure_tools.experiment_data): for each
mechanism (a row), tan-half and sin-cos in the paper's algorithm (Eq. (10), the Eq. (12) LPs, plain
subdivision): (a) boxes per subdivision depth of the traced run, (b) the largest hull width H_k (the
widest side, in the chart's unit coordinates, of the boxes the LPs reduced and kept) against the level,
its measured order p in the legend, (c) boxes and LPs against the tolerance, (d) time against the
tolerance. Capped runs are left out of (c) and (d) and named under the panels.
"""

from __future__ import annotations

import math

from paper_figures import _figure_tools as ft

NAME = "exp_tan_vs_sincos"
COLOURS = {"tan-half": "#1f77b4", "sin-cos": "#d95f02"}


def draw(data: dict):
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(t["problem"] for t in data["traces"]))
    fig, axes = plt.subplots(len(names), 4, figsize=(17, 3.6 * len(names)), constrained_layout=True, squeeze=False)
    capped = []
    traced_tol = {t["problem"]: t["tol"] for t in data["traces"]}
    for row, name in zip(axes, names):
        for t in (t for t in data["traces"] if t["problem"] == name):
            p, colour = t["parameterization"], COLOURS[t["parameterization"]]
            levels = [lv for lv in t["levels"] if lv["boxes"]]
            row[0].plot([lv["depth"] for lv in levels], [lv["boxes"] for lv in levels], "o-", ms=3, color=colour,
                        label=p)
            hull = [lv for lv in levels if lv["hull_width"]]
            order = t.get("order")
            shown = "capped" if t["capped"] else ("p n/a" if order is None or math.isnan(order) else f"p = {order:.2f}")
            row[1].semilogy([lv["depth"] for lv in hull], [lv["hull_width"] for lv in hull], "o-", ms=3, color=colour,
                            label=f"{p} ({shown})")
            sweep = [r for r in data["sweep"] if r["problem"] == name and r["parameterization"] == p]
            done = [r for r in sweep if not r["capped"]]
            capped += [f"{name}, {p}, tol {r['tol']:g}" for r in sweep if r["capped"]]
            tols = [r["tol"] for r in done]
            row[2].loglog(tols, [r["boxes"] for r in done], "o-", color=colour, label=f"{p}: boxes")
            row[2].loglog(tols, [r["lps"] for r in done], "s--", color=colour, label=f"{p}: LPs")
            row[3].loglog(tols, [r["time"] for r in done], "o-", color=colour, label=p)
        titles = (f"{name}\n(a) boxes per depth (tol {traced_tol[name]:g})", "(b) largest hull width H_k",
                  "(c) boxes and LPs", "(d) median time (s)")
        xlabels = ("subdivision depth", "subdivision level k", "tol (rad)", "tol (rad)")
        for ax, title, xlabel in zip(row, titles, xlabels):
            ax.set_title(title, fontsize=10)
            ax.set_xlabel(xlabel)
            ax.grid(alpha=0.3, which="major")
            ax.legend(fontsize=8)
        for ax in row[2:]:
            ax.invert_xaxis()                      # finer tolerances to the right
        row[0].set_ylabel("boxes")
        row[1].set_ylabel("H_k (unit chart coordinates)")
    fig.suptitle("tan(theta/2) vs (cos, sin) in the paper's algorithm (Eq. (10), Eq. (12) LPs, subdivision)",
                 fontsize=12)
    if capped:
        fig.text(0.01, 0.002, "Capped (not plotted): " + "; ".join(capped), fontsize=8, ha="left", va="bottom",
                 wrap=True)
        fig.get_layout_engine().set(rect=(0, 0.03, 1, 0.97))
    return fig


def main(argv=None):
    args = ft.parser(__doc__.splitlines()[0]).parse_args(argv)
    data, quick = ft.experiment_data("tan_vs_sincos")
    fig = draw(data)
    ft.save(fig, args.out_dir, NAME, quick=quick)


if __name__ == "__main__":
    main()
