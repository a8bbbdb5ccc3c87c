"""This project's experiment (not a figure of the paper): the solutions of the Gosselin example (paper Section 2.1) drawn on the unit sphere.

Question: what are the assemblies of the paper's Gosselin platform at the inputs that ``make run``
solves, and which of them are singular?

How: spherekin.search.boxloop.solve with its default strategies on the preset
spherekin.mechanism.presets.gosselin at beta = INPUTS rad (the paper gives no numeric inputs for
its example; it states 8 solutions, 4 of them singular, which the figure shows), then
spherekin.plot.plot_solutions: one panel per solution, titled with its status (certified /
singular / unverified), singularity kind and closure residual. No randomness (--seed is unused);
--quick changes nothing (the solve takes about a second).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path


from paper_figures import _figure_tools as ft

from spherekin.mechanism import presets  # noqa: E402
import numpy as np  # noqa: E402

from spherekin.plot import current_joint_axes, plot_solutions  # noqa: E402
from spherekin.problem import solve  # noqa: E402

NAME = "exp_solutions"
#: The inputs (radians) of ``make run`` (Makefile: spherekin solve examples/gosselin.toml --inputs 0.3,-0.2,0.5).
INPUTS = (0.3, -0.2, 0.5)


def compute(inputs=INPUTS) -> dict:
    mech = presets.gosselin()
    report = solve(mech, inputs)
    return dict(mechanism=mech, inputs=tuple(inputs), report=report)


def numbers(data: dict) -> dict:
    """What the README quotes: solutions in all and by status, and the range of |det[u w v]| (the
    legs' fold measure: 0 when a leg's three joint axes are coplanar) over the legs of the certified
    solutions, to 2 decimals (the README's precision; rounding keeps the bytes machine-independent)."""
    report = data["report"]
    counts = Counter(s.status for s in report.solutions)
    dets = []
    for s in report.solutions:
        if s.status == "certified":
            axes = current_joint_axes(data["mechanism"], data["inputs"], dict(zip(report.unknowns, s.angles)))
            dets += [abs(float(np.linalg.det(a))) for a in axes.values()]
    return dict(inputs=list(data["inputs"]), solutions=len(report.solutions), **dict(sorted(counts.items())),
                det_certified_min=round(min(dets), 2), det_certified_max=round(max(dets), 2))


def main(argv=None) -> dict:
    args = ft.parser(__doc__.split("\n\n")[0]).parse_args(argv)
    data = compute()
    report = data["report"]
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig = plot_solutions(data["mechanism"], data["inputs"], report)
    paths = ft.save(fig, out, NAME, dpi=fig.dpi)          # the resolution of spherekin solve --plot
    counts = Counter(s.status for s in report.solutions)
    print(f"{len(report.solutions)} solutions at inputs {data['inputs']} rad: {dict(counts)}; "
          f"max residual {max(s.residual for s in report.solutions):.1e}; solve {report.stats.time_total:.2f} s")
    print("  k: status     singularity      passive angles (rad)                      det[u w v] per leg")
    for k, s in enumerate(report.solutions, 1):
        axes = current_joint_axes(data["mechanism"], data["inputs"], dict(zip(report.unknowns, s.angles)))
        dets = [float(np.linalg.det(a)) for a in axes.values()]   # 0: the leg's three axes are coplanar
        print(f"  {k}: {s.status:10s} {s.singularity:16s} " + " ".join(f"{a:+.4f}" for a in s.angles)
              + "   " + " ".join(f"{d:+.3f}" for d in dets))
    data["paths"] = paths
    ft.save_numbers(out, NAME, numbers(data))
    return data


if __name__ == "__main__":
    main()
