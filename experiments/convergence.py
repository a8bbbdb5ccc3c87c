"""Convergence of the subdivision near the roots: is it quadratic, as Section 4 claims?

Section 4 says the algorithm "has the good property of being quadratically convergent to the roots"
(citing Sherbrooke & Patrikalakis). The verification report (verification/REPORT.md, claim
s4-quadratic-convergence) shows why this cannot hold for the paper's own equation: Eq. (10) is
minus a sum of squares, f <= 0 touching 0 at every root, so every root is a double root and a hull
step cannot cut a side around it by more than half. This script measures it.

(i) Width against iteration. For two regular and two serial-singular roots of the Gosselin
    platform at the inputs of ``make run`` (found and polished by the default solver), the solver searches a local box of
    side 2 * HALF_WIDTH around it (its centre shifted from the root by a seeded random offset, so
    the root is not at a symmetric spot) with Krawczyk isolation OFF, so only the pruner works,
    and with ``trace=`` recording every box it processes. We follow the chain of boxes that
    contain the root: at each depth k (one pruning step per depth) the box B_k holding the root,
    its widest side w_k (radians) and the widest side w'_k of its reduction. The empirical order
    p of the pruning step is the least-squares slope of log w'_k against log w_k over the steps
    near the root (w_k <= ORDER_MAX_WIDTH, w'_k >= ORDER_MIN_WIDTH): w' = C w^p, p = 2 for
    quadratic convergence, p = 1 (with the ratio w'/w < 1) for linear. Configurations: the
    paper's scalar formulation vs the transversal one (three entries of F per loop: simple
    roots), each with LP pruning (Eq. 12, HiGHS) and with projected-polyhedron (pp) pruning.
    A box that holds a root must never be discarded: the script counts such events (should be 0).
    The transversal runs go down to 1e-10 rad; the paper's to 1e-5 rad (its box count explodes
    below, see (ii)); every run is capped (MAX_BOXES), and a capped chain ends early.
(ii) Boxes against tolerance: total boxes processed over the same local problems for tolerances
    1e-2 ... 1e-10 (radians), per configuration.

--quick: two roots (one regular, one serial-singular), looser trace tolerances, fewer tolerances,
the LP runs only at the loosest, smaller caps. JSON and markdown go to experiments/results/convergence.{json,md}; the figure
is drawn by paper_figures/exp_convergence.py.

    python -m experiments.convergence [--quick] [--seed 0] [--out-dir experiments/results]
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

from experiments import _common
from experiments.reproduction import INPUTS, angle_gap, with_ranges

from spherekin.mechanism import gosselin  # noqa: E402
from spherekin.search.parameterizations import make_charts  # noqa: E402
from spherekin.search.boxloop import TRACE_OUTCOMES  # noqa: E402
from experiments._common import Pinned, pinned_solve  # noqa: E402

#: The four configurations compared: (name, formulation, pruner, LP backend). HiGHS (highspy) for
#: the LPs: every backend's bound is certified by spherekin, so they give the same boxes up to
#: the LP tolerance, and HiGHS is ~10x faster than clarabel (experiments/results/reproduction.md).
CONFIGS = (("paper + lp", "paper", "lp", "highspy"), ("paper + pp", "paper", "pp", None),
           ("transversal + lp", "transversal", "lp", "highspy"), ("transversal + pp", "transversal", "pp", None))
#: The solve that gives the roots studied (the loop equations, every keyword pinned).
ROOTS = Pinned(system="loops", formulation="halves", parameterization="tan-half", pruner="pp", lp_backend=None,
               tol=1e-6, isolate=True, max_boxes=300_000)
#: Roots studied: this many regular and as many serial-singular ones (the LP runs of the paper's
#: formulation cost ~40 s per root; 8 roots would take most of an hour).
N_ROOTS, N_ROOTS_QUICK = 2, 1
#: Half-width (radians) of the local box around each root: wide enough that the chain starts far
#: from the asymptotic regime (~10 steps), one tan-half chart (width < pi).
HALF_WIDTH = 0.3
#: The box centre is shifted from the root by up to this fraction of HALF_WIDTH (seeded uniform).
CENTRE_SHIFT = 0.5
#: Tolerance (radians) of the width-vs-iteration runs, per formulation: deep enough for several
#: quadratic steps of the transversal equations; the paper's double roots need a number of boxes
#: that grows fast as the tolerance shrinks (see the sweep), and a linear rate is plain long before.
TRACE_TOL = {"paper": 1e-5, "transversal": 1e-10}
TRACE_TOL_QUICK = {"paper": 1e-3, "transversal": 1e-8}
#: Tolerances of the boxes-vs-tolerance sweep.
TOLS = tuple(10.0 ** -k for k in range(2, 11))
TOLS_QUICK = (1e-2, 1e-4, 1e-6, 1e-8)
#: In --quick, the LP configurations run only at tolerances >= this (the paper's double roots need
#: thousands of LP boxes per root below it).
QUICK_LP_MIN_TOL = 1e-2
#: Steps used for the order: boxes narrower than this (radians), i.e. near the root, ...
ORDER_MAX_WIDTH = 0.1
#: ... whose reduction is wider than this: below it the pruner's own safety margins (1e-12 of the
#: box, pruners.INTERVAL_MARGIN) and the rounding tolerance of the equations dominate (|w| <= 2.2e-13
#: times their magnitude, the size of the terms behind their control points, over a gradient of
#: ~1: reductions stop at ~1e-11 rad on the Gosselin platform).
ORDER_MIN_WIDTH = 1e-10
#: A root is in a box when it lies within this (radians) of the box: the trace's boxes are in unit
#: coordinates and their angles carry rounding of ~1e-15.
CONTAIN_SLACK = 1e-12
#: Cap on the boxes of one run (reported as "cap"; a sweep stops at its first cap), per pruner: an LP
#: box costs 12 LPs (~3 ms), a pp box ~30 us. Quick mode uses the smaller caps.
MAX_BOXES = {"pp": 300_000, "lp": 10_000}
MAX_BOXES_QUICK = {"pp": 50_000, "lp": 3_000}


# ------------------------------------------------------------------ order estimation

def empirical_order(w_in, w_out) -> float:
    """Least-squares slope p of log w_out = p log w_in + c (nan with fewer than 2 distinct points)."""
    x, y = np.log(np.asarray(w_in, dtype=float)), np.log(np.asarray(w_out, dtype=float))
    if len(x) < 2 or np.ptp(x) == 0:
        return math.nan
    return float(np.polyfit(x, y, 1)[0])


def sequence_order(w) -> float:
    """Empirical order of a sequence w_0, w_1, ...: slope of log w_{k+1} against log w_k."""
    w = np.asarray(w, dtype=float)
    return empirical_order(w[:-1], w[1:])


def asymptotic_steps(w_in, w_out, max_width: float = ORDER_MAX_WIDTH, min_width: float = ORDER_MIN_WIDTH):
    """Mask of the steps near the root used for the order (see ORDER_MAX_WIDTH, ORDER_MIN_WIDTH)."""
    w_in, w_out = np.asarray(w_in, dtype=float), np.asarray(w_out, dtype=float)
    return (w_in <= max_width) & (w_out >= min_width)


# ------------------------------------------------------------------ the chain of boxes around a root

class Recorder:
    """Collects the solver's trace records (one per batch of boxes), concatenated on demand."""

    def __init__(self):
        self.records = []

    def __call__(self, record: dict):
        self.records.append(record)

    def arrays(self) -> dict:
        keys = ("chart", "depth", "lo", "hi", "reduced_lo", "reduced_hi", "metric_width", "outcome")
        return {k: np.concatenate([r[k] for r in self.records]) for k in keys}


def root_chain(charts, rec: dict, root) -> list[dict]:
    """The boxes of the trace that contain ``root`` (angles, radians), one per depth (the narrowest):
    depth, widest side before (w_in) and after (w_out) the reduction, outcome name."""
    lo = charts.angle_box(rec["chart"], rec["lo"], rec["hi"])
    a_lo, a_hi = lo
    r = np.asarray(root, dtype=float)
    # root modulo 2 pi next to each box's centre
    centre = 0.5 * (a_lo + a_hi)
    rr = centre + np.mod(r - centre + math.pi, 2 * math.pi) - math.pi
    inside = np.all((a_lo - CONTAIN_SLACK <= rr) & (rr <= a_hi + CONTAIN_SLACK), axis=1)
    idx = np.flatnonzero(inside)
    w_in = rec["metric_width"][idx].max(axis=1)
    chain = {}
    for k, w in zip(idx, w_in):
        d = int(rec["depth"][k])
        if d not in chain or w < chain[d][1]:
            chain[d] = (k, w)
    out = []
    for d in sorted(chain):
        k, w = chain[d]
        outcome = TRACE_OUTCOMES[int(rec["outcome"][k])]
        row = dict(depth=d, w_in=float(w), outcome=outcome)
        if outcome != "discarded":
            rlo, rhi = charts.angle_box(rec["chart"][k:k + 1], rec["reduced_lo"][k:k + 1], rec["reduced_hi"][k:k + 1])
            row["w_out"] = float((rhi - rlo).max())
        out.append(row)
    return out


def chain_summary(chain: list[dict]) -> dict:
    """Order and ratios of a chain: steps, steps near the root, order p, median ratio w_out/w_in there."""
    steps = [c for c in chain if "w_out" in c and c["w_out"] > 0]
    w_in = np.array([c["w_in"] for c in steps])
    w_out = np.array([c["w_out"] for c in steps])
    mask = asymptotic_steps(w_in, w_out) if len(steps) else np.zeros(0, bool)
    ratios = w_out[mask] / w_in[mask]
    return dict(steps=len(chain), near_steps=int(mask.sum()), order=empirical_order(w_in[mask], w_out[mask]),
                median_ratio=float(np.median(ratios)) if len(ratios) else math.nan,
                min_ratio=float(ratios.min()) if len(ratios) else math.nan,
                root_discarded=sum(c["outcome"] == "discarded" for c in chain),
                final_width=float(chain[-1].get("w_out", chain[-1]["w_in"])) if chain else math.nan)


# ------------------------------------------------------------------ problems and runs

def local_ranges(root: dict, rng: np.random.Generator, half_width: float = HALF_WIDTH) -> dict:
    """A box of side 2 half_width around the root, its centre shifted by a seeded random offset."""
    out = {}
    for name, v in root.items():
        c = v + rng.uniform(-CENTRE_SHIFT, CENTRE_SHIFT) * half_width
        out[name] = (c - half_width, c + half_width)
    return out


def pinned(config: tuple, tol: float, max_boxes: int) -> Pinned:
    """The whole strategy of one run of ``config`` (name, formulation, pruner, LP backend): the loop
    system in tan(theta/2), no Krawczyk isolation (the paper's subdivision), ``tol`` radians."""
    _, formulation, pruner, backend = config
    return Pinned(system="loops", formulation=formulation, parameterization="tan-half", pruner=pruner,
                  lp_backend=backend, tol=tol, isolate=False, max_boxes=max_boxes)


def run(mech, inputs, config: tuple, tol: float, trace: bool, max_boxes: int):
    """One solve of the local problem; returns (Solved, recorder or None): ``Solved.capped`` when the
    run hit ``max_boxes`` (no count), else its report, what ran and the seconds."""
    rec = Recorder() if trace else None
    return pinned_solve(mech, inputs, pinned(config, tol, max_boxes), 1, trace=rec), rec


def charts_of(mech, inputs, ranges: dict, formulation: str):
    """The solver's chart set of a local problem (the same construction as inside solve)."""
    def build(chart):
        s = mech.loop_system(inputs, chart)
        return s.loops, s.unknowns

    return make_charts("tan-half", build, ranges, formulation)


def pick_roots(report, quick: bool) -> list[int]:
    """Indices of the roots studied: N_ROOTS regular and N_ROOTS serial-singular ones (first in order)."""
    k = N_ROOTS_QUICK if quick else N_ROOTS
    reg = [i for i, s in enumerate(report.solutions) if s.status == "certified"][:k]
    sing = [i for i, s in enumerate(report.solutions) if s.status == "singular"][:k]
    return reg + sing


def main(argv=None) -> dict:
    args = _common.parser(__doc__.splitlines()[0]).parse_args(argv)
    return experiment(quick=args.quick, seed=args.seed, args=args)


def experiment(quick: bool, seed: int = 0, args=None, roots=None, configs=CONFIGS, tols=None,
               trace_tol=None) -> dict:
    """The whole experiment (``args`` given: also write the results); small pieces for the tests."""
    rng = np.random.default_rng(seed)
    mech = gosselin()
    report = pinned_solve(mech, INPUTS, ROOTS).report
    roots = pick_roots(report, quick) if roots is None else roots
    tols = (TOLS_QUICK if quick else TOLS) if tols is None else tols
    trace_tol = (TRACE_TOL_QUICK if quick else TRACE_TOL) if trace_tol is None else trace_tol
    if not isinstance(trace_tol, dict):
        trace_tol = {"paper": trace_tol, "transversal": trace_tol}
    caps = MAX_BOXES_QUICK if quick else MAX_BOXES
    problems = []
    for i in roots:
        s = report.solutions[i]
        root = dict(zip(report.unknowns, map(float, s.angles)))
        ranges = local_ranges(root, rng)
        problems.append(dict(index=i + 1, status=s.status, root=root, ranges=ranges,
                             mech=with_ranges(mech, ranges)))

    chains, summary = [], []
    for cfg in configs:
        for p in problems:
            print(f"  trace {cfg[0]:18s} root {p['index']} ...", flush=True)
            got, rec = run(p["mech"], INPUTS, cfg, trace_tol[cfg[1]], trace=True, max_boxes=caps[cfg[2]])
            rep, t = got.report, got.time
            charts = charts_of(mech, INPUTS, p["ranges"], cfg[1])
            chain = root_chain(charts, rec.arrays(), list(p["root"].values())) if rec.records else []
            summ = chain_summary(chain)
            found = rep is not None and any(angle_gap(s.angles, list(p["root"].values())) < 1e-8
                                            for s in rep.solutions)     # modulo 2 pi: roots at +-pi
            chains.append(dict(config=cfg[0], root=p["index"], status=p["status"], chain=chain))
            summary.append(dict(config=cfg[0], root=p["index"], status=p["status"], tol=trace_tol[cfg[1]], **summ,
                                boxes=rep.stats.boxes_processed if rep else None, time=t, root_found=found,
                                **got.settings_row()))

    sweep = []
    for cfg in configs:
        capped = False
        for tol in tols:
            if capped or (quick and cfg[2] == "lp" and tol < QUICK_LP_MIN_TOL):
                continue
            boxes, lps, t_all, got = 0, 0, 0.0, None
            for p in problems:
                got, _ = run(p["mech"], INPUTS, cfg, tol, trace=False, max_boxes=caps[cfg[2]])
                if got.capped:
                    break
                boxes += got.report.stats.boxes_processed
                lps += got.report.stats.lps_solved
                t_all += got.time
            capped = got.capped
            print(f"  sweep {cfg[0]:18s} tol {tol:.0e}: {'cap' if capped else boxes} boxes", flush=True)
            sweep.append(dict(config=cfg[0], tol=tol, boxes=None if capped else boxes, lps=None if capped else lps,
                              time=None if capped else t_all, **got.settings_row()))

    data = dict(inputs=INPUTS, half_width=HALF_WIDTH, trace_tol=trace_tol, tols=list(tols), max_boxes=caps,
                configs=[dict(name=c[0], formulation=c[1], pruner=c[2], lp_backend=c[3]) for c in configs],
                problems=[dict(index=p["index"], status=p["status"], root=p["root"],
                               ranges={k: list(v) for k, v in p["ranges"].items()}) for p in problems],
                summary=summary, chains=chains, sweep=sweep,
                settings=dict(ORDER_MAX_WIDTH=ORDER_MAX_WIDTH, ORDER_MIN_WIDTH=ORDER_MIN_WIDTH,
                              CENTRE_SHIFT=CENTRE_SHIFT, MAX_BOXES=MAX_BOXES))
    if args is not None:
        write(args, data)
    return data


def aggregate(summary: list[dict], configs) -> list[dict]:
    """Per configuration: the order and ratio over all roots (median, range)."""
    rows = []
    for cfg in configs:
        s = [r for r in summary if r["config"] == cfg[0] and not math.isnan(r["order"])]
        if not s:
            rows.append(dict(config=cfg[0]))
            continue
        orders = np.array([r["order"] for r in s])
        ratios = np.array([r["median_ratio"] for r in s])
        rows.append(dict(config=cfg[0], roots=len(s), order_median=float(np.median(orders)),
                         order_range=f"{orders.min():.2f} .. {orders.max():.2f}",
                         ratio_median=float(np.median(ratios)), steps_median=float(np.median([r["steps"] for r in s])),
                         discarded=sum(r["root_discarded"] for r in s)))
    return rows


def write(args, data: dict) -> None:
    configs = [(c["name"], c["formulation"], c["pruner"], c["lp_backend"]) for c in data["configs"]]
    agg = aggregate(data["summary"], configs)
    data["aggregate"] = agg
    for r in data["summary"]:
        r["found"] = "yes" if r["root_found"] else "NO"
    tols = data["tols"]
    sweep_rows = []
    for cfg in configs:
        row = dict(config=cfg[0])
        for r in data["sweep"]:
            if r["config"] == cfg[0]:
                row[f"{r['tol']:.0e}"] = "capped" if r["capped"] else r["boxes"]
        sweep_rows.append(row)
    agg_cols = [("config", "configuration", ""), ("roots", "roots", "d"), ("order_median", "order p (median)", ".2f"),
                ("order_range", "order p (range)", ""), ("ratio_median", "w'/w near root (median)", ".3f"),
                ("steps_median", "steps to tol (median)", ".0f"), ("discarded", "root boxes discarded", "d")]
    sum_cols = [("config", "configuration", ""), ("root", "root", "d"), ("status", "status", ""),
                ("steps", "steps", "d"), ("near_steps", "steps near root", "d"), ("order", "order p", ".2f"),
                ("median_ratio", "median w'/w", ".3f"), ("min_ratio", "min w'/w", ".1e"),
                ("final_width", "final width (rad)", ".1e"), ("boxes", "boxes", "d"), ("found", "root found", ""),
                ("error", "capped", "")]
    sweep_cols = [("config", "configuration", "")] + [(f"{t:.0e}", f"tol {t:.0e}", "") for t in tols]
    notes = (f"Local problems: a box of side {2 * data['half_width']} rad around each root (centre shifted by a seeded "
             "offset), no Krawczyk isolation; width-vs-iteration runs at tol " +
             ", ".join(f"{v:.0e} rad ({k})" for k, v in data["trace_tol"].items()) + ". Order p: "
             f"slope of log w' against log w over the pruning steps of the root's chain with w <= {ORDER_MAX_WIDTH} rad "
             f"and w' >= {ORDER_MIN_WIDTH:g} rad (w: widest side of the box holding the root, w': of its reduction); "
             "p = 2 is quadratic, p = 1 with w'/w < 1 linear. Every run: the loop system in tan(theta/2), no isolation, "
             "each strategy keyword pinned and read back from its report (JSON: asked, ran). 'capped' in the sweep: the run hit the box cap "
             f"({data['max_boxes']}); a run that hits it stops its chain early (final width above tol) and "
             "ends its configuration's sweep.")
    _common.write_results("convergence", args, data, [
        ("Empirical order of the pruning step near the roots (all roots)", agg, agg_cols),
        ("Per root", data["summary"], sum_cols),
        ("Boxes processed against tolerance (sum over the local problems)", sweep_rows, sweep_cols)], notes)


if __name__ == "__main__":
    main()
