"""tan(theta/2) against (cos theta, sin theta) inside the paper's own algorithm: how each converges.

Question (paper Sections 2.2, 4 and 5): Section 5 suggests replacing t = tan(theta/2) by c = cos theta,
s = sin theta with c^2 + s^2 = 1. experiments/parameterizations.py compares the two in spherekin's
pipeline; this script compares them in the paper's algorithm itself: the loop equations' scalar
Eq. (10) (formulation "paper"), its Bernstein control points, the Eq. (12) LPs on every box (pruner
"lp", HiGHS called directly: every backend gives the same boxes up to the LP tolerance,
results/lp_backends.md) and plain subdivision to the tolerance (no Krawczyk isolation). Every keyword
is pinned (:data:`STRATEGY`) and each row records what ran, read back from its report; a run that
reaches MAX_BOXES is recorded as capped, with no count.

Measured, per mechanism and parameterization:

(a) boxes against subdivision depth (the trace's boxes per depth, at TRACE_TOL);
(b) the largest hull width against the subdivision level: H_k, the widest side (in the chart's unit
    coordinates, [0, 1] per variable) of the boxes the LPs reduced at depth k (discarded boxes
    excluded), and its order p: the slope of log H_{k+1} against log H_k over the levels with
    H_k <= ORDER_MAX_WIDTH (p = 2 quadratic, p = 1 linear; experiments/convergence.py's fit);
(c) boxes, LPs and time (median of REPEATS runs, with the spread) against the tolerance.

Mechanisms: the spherical four-bar and five-bar over their full circles (examples/*.toml), and the
Gosselin platform on one chart: its passive joints within +-LOCAL_HALF_WIDTH of one regular root
(experiments/reproduction.py's local problem; its full circles take minutes per LP run), at the
tolerances GOSSELIN_TOLS only.

    python -m experiments.tan_vs_sincos [--quick] [--seed 0] [--out-dir experiments/results]

The figure: paper_figures/exp_tan_vs_sincos.py.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from experiments import _common
from experiments._common import Pinned, pinned_solve, ran_text, spread_text
from experiments.convergence import Recorder, sequence_order
from experiments.reproduction import INPUTS as GOSSELIN_INPUTS
from experiments.reproduction import local_problem

from spherekin.mechanism import load_mechanism  # noqa: E402
from spherekin.search.boxloop import TRACE_OUTCOMES  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PARAMETERIZATIONS = ("tan-half", "sin-cos")
#: Box cap of every run: the paper's double roots need boxes fast as the tolerance shrinks (the
#: four-bar: ~400 at 1e-2, ~700 at 1e-4, more than 20,000 at 1e-6); a capped run is recorded as such.
MAX_BOXES, MAX_BOXES_QUICK = 30_000, 5_000
#: The paper's algorithm, every keyword but the parameterization and the tolerance pinned.
STRATEGY = dict(system="loops", formulation="paper", pruner="lp", lp_backend="highspy", isolate=False)
#: Tolerances (radians) of the sweep (c), and the one of the traced runs (a), (b).
TOLS, TOLS_QUICK = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5), (1e-1, 1e-2)
TRACE_TOL, TRACE_TOL_QUICK = 1e-4, 1e-2
#: Runs behind each time (median, with the spread).
REPEATS, REPEATS_QUICK = 3, 1
#: Levels used for the order of H_k: hulls narrower than this (unit coordinates), near the roots.
ORDER_MAX_WIDTH = 0.1
#: Half-width (radians) of the Gosselin platform's local problem around its first regular root.
LOCAL_HALF_WIDTH = 0.25
#: The Gosselin chart's tolerances and traced tol. Reason: measured, sin-cos needs ~5,000 boxes there
#: already at 1e-1 (12 variables, 4^4 control points per loop equation), minutes per run below 1e-2.
GOSSELIN_TOLS, GOSSELIN_TRACE_TOL = (1e-1, 1e-2), 1e-2
#: The four-bar's crank input (radians; docs/howto/paper-configuration.md) and the five-bar's two.
FOUR_BAR_INPUTS = (0.7,)
FIVE_BAR_INPUTS = (0.3, 0.3)
#: The solve that finds the Gosselin root the local problem is centred on (any certified system will do).
ROOT_SOLVE = Pinned(system="loops", formulation="halves", parameterization="tan-half", pruner="pp", lp_backend=None,
                    tol=1e-6, isolate=True, max_boxes=500_000)


def problems(quick: bool) -> list[dict]:
    """(name, mechanism, inputs) of every problem: the four-bar (quick), the five-bar and the Gosselin chart."""
    out = [dict(name="four-bar (full circles)", mech=load_mechanism(ROOT / "examples" / "four_bar.toml"),
                inputs=FOUR_BAR_INPUTS)]
    if quick:
        return out
    out.append(dict(name="five-bar (full circles)", mech=load_mechanism(ROOT / "examples" / "five_bar.toml"),
                    inputs=FIVE_BAR_INPUTS))
    gosselin = load_mechanism(ROOT / "examples" / "gosselin.toml")
    report = pinned_solve(gosselin, GOSSELIN_INPUTS, ROOT_SOLVE).report
    root = next(s for s in report.solutions if s.status == "certified")
    local = local_problem(gosselin, GOSSELIN_INPUTS, dict(zip(report.unknowns, map(float, root.angles))),
                          half_width=LOCAL_HALF_WIDTH)
    out.append(dict(name=f"Gosselin (one chart, +-{LOCAL_HALF_WIDTH} rad)", mech=local, inputs=GOSSELIN_INPUTS,
                    tols=GOSSELIN_TOLS, trace_tol=GOSSELIN_TRACE_TOL))
    return out


def levels(records: dict) -> list[dict]:
    """Per subdivision depth of a trace (:class:`~experiments.convergence.Recorder` arrays): the boxes
    processed and H, the widest side (unit coordinates) of the boxes the pruner reduced and kept."""
    depth = records["depth"].astype(int)
    kept = records["outcome"] != TRACE_OUTCOMES.index("discarded")
    width = (records["reduced_hi"] - records["reduced_lo"]).max(axis=1)
    out = []
    for d in range(int(depth.max()) + 1 if len(depth) else 0):
        at = depth == d
        h = width[at & kept]
        out.append(dict(depth=d, boxes=int(at.sum()), hull_width=float(h.max()) if len(h) else None))
    return out


def hull_order(rows: list[dict], max_width: float = ORDER_MAX_WIDTH) -> float:
    """The order p of the largest hull width against the level (:func:`sequence_order`) over the levels
    whose H is at most ``max_width``; NaN with fewer than three such levels."""
    h = [r["hull_width"] for r in rows if r["hull_width"] is not None and 0 < r["hull_width"] <= max_width]
    return sequence_order(h) if len(h) >= 3 else float("nan")


def run(quick: bool = True, probs=None, tols=None, trace_tol=None, repeats=None, max_boxes=None) -> dict:
    """The whole experiment as a dict (the JSON file's data)."""
    probs = problems(quick) if probs is None else probs
    tols = (TOLS_QUICK if quick else TOLS) if tols is None else tols
    trace_tol = (TRACE_TOL_QUICK if quick else TRACE_TOL) if trace_tol is None else trace_tol
    repeats = (REPEATS_QUICK if quick else REPEATS) if repeats is None else repeats
    cap = (MAX_BOXES_QUICK if quick else MAX_BOXES) if max_boxes is None else max_boxes
    sweep, traces = [], []
    for prob in probs:
        for p in PARAMETERIZATIONS:
            capped = False
            for tol in prob.get("tols", tols):
                pinned = Pinned(**STRATEGY, parameterization=p, tol=tol, max_boxes=cap)
                row = dict(problem=prob["name"], parameterization=p, tol=tol)
                if capped:                     # a finer tol needs more boxes than the cap a coarser one hit
                    sweep.append(dict(row, capped=True, error="a coarser tol was capped", asked=pinned.asked(),
                                      ran=None))
                    continue
                got = pinned_solve(prob["mech"], prob["inputs"], pinned, repeats)
                row.update(got.settings_row(), ran_text=ran_text(got.settings_row()))
                capped = got.capped
                if not capped:
                    st = got.report.stats
                    row.update(boxes=st.boxes_processed, lps=st.lps_solved, time=got.time, times=list(got.times),
                               spread=spread_text(got.times), solutions=len(got.report.solutions))
                print(f"  {prob['name']:32s} {p:8s} tol {tol:.0e}: {'capped' if capped else row['boxes']} boxes",
                      flush=True)
                sweep.append(row)
            rec = Recorder()
            pinned = Pinned(**STRATEGY, parameterization=p, tol=prob.get("trace_tol", trace_tol), max_boxes=cap)
            got = pinned_solve(prob["mech"], prob["inputs"], pinned, 1, trace=rec)
            per_level = levels(rec.arrays()) if rec.records else []
            traces.append(dict(problem=prob["name"], parameterization=p, tol=pinned.tol, levels=per_level,
                               order=None if got.capped else hull_order(per_level), **got.settings_row()))
    return dict(strategy=STRATEGY, tols=list(tols), trace_tol=trace_tol, max_boxes=cap, repeats=repeats,
                order_max_width=ORDER_MAX_WIDTH, sweep=sweep, traces=traces)


def main(argv=None) -> dict:
    args = _common.parser(__doc__.splitlines()[0]).parse_args(argv)
    data = run(args.quick)
    for r in data["sweep"]:
        r["tol_text"] = f"{r['tol']:.0e}"
        r["capped_text"] = "yes" if r["capped"] else "no"
    orders = []
    for t in data["traces"]:
        depths = [lv for lv in t["levels"] if lv["boxes"]]
        orders.append(dict(problem=t["problem"], parameterization=t["parameterization"], tol=f"{t['tol']:.0e}",
                           levels=len(depths), boxes=sum(lv["boxes"] for lv in depths),
                           widest_level=max(depths, key=lambda lv: lv["boxes"])["depth"] if depths else None,
                           order=t["order"], capped="yes" if t["capped"] else "no", ran_text=ran_text(t)))
    data["orders"] = orders
    sweep_cols = [("problem", "problem", ""), ("parameterization", "parameterization", ""),
                  ("tol_text", "tol (rad)", ""), ("boxes", "boxes", "d"), ("lps", "LPs", "d"),
                  ("time", "median time (s)", ".3f"), ("spread", "spread (s)", ""), ("solutions", "solutions", "d"),
                  ("capped_text", "capped", ""), ("ran_text", "ran (from the report)", "")]
    order_cols = [("problem", "problem", ""), ("parameterization", "parameterization", ""), ("tol", "tol (rad)", ""),
                  ("levels", "levels", "d"), ("boxes", "boxes", "d"), ("widest_level", "level with most boxes", "d"),
                  ("order", "order p of H_k", ".2f"), ("capped", "capped", "")]
    notes = (f"The paper's algorithm: Eq. (10) (formulation paper) on the loop equations, the Eq. (12) LPs on every "
             f"box (highspy), no isolation, cap {data['max_boxes']} boxes; only the parameterization changes. H_k: "
             "the widest side, in the chart's unit coordinates, of the boxes the LPs reduced and kept at depth k; p: "
             f"the slope of log H_(k+1) against log H_k over the levels with H_k <= {ORDER_MAX_WIDTH}. A capped run has "
             "no count; after a capped tol the finer ones are not run. Boxes per level: the JSON's traces.")
    _common.write_results("tan_vs_sincos", args, data, [
        ("Boxes, LPs and time against tolerance", data["sweep"], sweep_cols),
        ("Subdivision levels and the order of the largest hull width", orders, order_cols)], notes)
    return data


if __name__ == "__main__":
    main()
