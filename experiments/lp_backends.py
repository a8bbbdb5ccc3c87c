"""LP backends for the Eq. (12) pruner: does the choice of LP solver change the cost or the result?

Question (paper Section 4, Eq. 12): the paper reduces every box by linear programs over the convex
hulls of the equations' control points and solves them with a general LP code. spherekin offers
several backends (spherekin.search.lp_backends.LP_BACKENDS: Clarabel and HiGHS through cvxpy, HiGHS
directly through highspy), every bound certified by spherekin from the solver's duals, and refuses
two that cvxpy offers, OSQP and SCS (first-order solvers; REJECTED_LP_BACKENDS), measured here too
(issue 18). How fast is each per LP and in total, and do they give the same boxes and the same
solutions? For the first-order solvers: how often does an LP give a certified bound at all, and how
much looser is it than HiGHS's?

How: with ``pruner="lp"`` (every box reduced by the 2n LPs of Eq. 12) and the ``halves``
formulation (the default: its nine P = S^T entries per loop have simple roots, so the LP bounds
contract; the paper's scalar Eq. (10) has only double roots, where the LP cannot cut), each backend
solves the same problems: the Gosselin platform with every passive range cut to +-GOSSELIN_HALF_WIDTH
around a ground-truth configuration (random pose + inverse kinematics, experiments/_compare.py), and
in the full run also the four-bar and the five-bar over full circles, the transversal formulation,
and wider Gosselin ranges. Each backend runs in its own fresh Python process (see below), one after
the other; times are medians of several solves in that process (the cvxpy model is built anew in
every solve, as spherekin does). Per-LP time = pruning time / LPs solved.

The refused backends are measured with their classes (REJECTED_BACKEND_CLASSES), registered by name
only inside their own fresh process (spherekin itself refuses the names). Bound quality
(``bound_quality``): the boxes highspy's search reduces are recorded (a recording subclass of the
highspy backend), then every LP of every recorded box is solved by the backend under test and by
highspy on the same loaded box; each answer's bound is certified by spherekin
(LPStructure.certified_min) and compared with highspy's certified bound. "Certified" = the answer
gave a finite certified bound (a missing or unusable dual gives none: the face is kept). Looseness
= highspy's bound minus the backend's (unit coordinates of the box; > 0: looser). Time per LP here
is the solver call alone.

A bug found while writing this experiment (fixed meanwhile in spherekin commit 54c62ed): HiGHS
keeps one global thread scheduler per process. After a solve through cvxpy's HIGHS (default thread
count), a highspy model created with ``threads=1`` refused to run ("Option 'threads' is set to 1 but
the scheduler has already been initialized to use 2 threads"): ``run()`` returned kError with model
status kNotset, every LP became a doubt, nothing was pruned, and the four-bar needed 16000 boxes
instead of 76. ``bug_demo`` runs cvxpy's HIGHS and then highspy in ONE process as a regression
check; the comparison itself still gives every backend a fresh process, so that no backend's
state (or import cost) leaks into another's timings.
"""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from experiments._common import check_ran, median_time, parser, ran, spread_text, write_results
from experiments._compare import MECHANISMS, angle_distance, contains, random_cases

#: Half-width (radians) of the Gosselin passive ranges around the start configuration: one chart,
#: ~8 boxes and ~85 LPs, small enough for --quick with the slowest backend (~4 s per solve).
GOSSELIN_HALF_WIDTH = 0.3
#: The wider Gosselin ranges of the full run (~120 boxes, ~850 LPs; Clarabel ~25 s per solve).
GOSSELIN_WIDE_HALF_WIDTH = 1.0
QUICK_REPEATS, FULL_REPEATS = 3, 3
#: Solves per problem for the refused first-order backends in the full run: OSQP needs ~5 minutes
#: for one +-1 rad solve, so the median of three would add half an hour to the full run. They run
#: the Gosselin problems only (issue 18's scope: one chart, +-0.3 rad, and the wider +-1 rad).
REFUSED_FULL_REPEATS = 1
#: Boxes replayed per problem by bound_quality (the first ones highspy's search reduced): every box
#: of the +-0.3 rad problem (8), and enough of the +-1 rad one (119) for stable shares at a few
#: minutes per backend.
QUALITY_BOXES = 40
#: Box cap of the bug demonstration: without the bug the four-bar needs ~80 boxes; with it, every
#: LP is a doubt and the search would run to spherekin's 500000-box cap (minutes).
BUG_DEMO_MAX_BOXES = 1000
#: The search's strategy besides the formulation and the backend, pinned (never the library's defaults):
#: tan(theta/2) charts, Krawczyk isolation, tol 1e-6 rad, a named box cap.
TOL = 1e-6
MAX_BOXES = 500_000
SEARCH = dict(parameterization="tan-half", isolate=True, tol=TOL, max_boxes=MAX_BOXES)


def problems(quick: bool) -> list[dict]:
    """The problems every backend solves: name, mechanism, formulation, range half-width (None: full)."""
    out = [dict(problem=f"gosselin +-{GOSSELIN_HALF_WIDTH} rad", mechanism="gosselin", formulation="halves",
                half_width=GOSSELIN_HALF_WIDTH)]
    if not quick:
        out += [dict(problem=f"gosselin +-{GOSSELIN_HALF_WIDTH} rad", mechanism="gosselin", formulation="transversal",
                     half_width=GOSSELIN_HALF_WIDTH),
                dict(problem=f"gosselin +-{GOSSELIN_WIDE_HALF_WIDTH} rad", mechanism="gosselin", formulation="halves",
                     half_width=GOSSELIN_WIDE_HALF_WIDTH)]
        for name in ("four_bar", "five_bar"):
            for form in ("halves", "transversal"):
                out.append(dict(problem=f"{name.replace('_', '-')} (full circles)", mechanism=name, formulation=form,
                                half_width=None))
    return out


def _system(problem: dict, seed: int):
    """(build, ranges, start configuration's passive angles) of a problem; the start from the seed."""
    make, max_angle = MECHANISMS[problem["mechanism"]]
    mech = make()
    case = random_cases(mech, np.random.default_rng(seed), 1, max_angle)[0]
    names = mech.loop_unknowns
    w = problem["half_width"]
    ranges = {n: (mech.ranges[n] if w is None else (case.joints[n] - w, case.joints[n] + w)) for n in names}

    def build(chart):
        s = mech.loop_system(case.inputs, chart)
        return s.loops, s.unknowns

    return build, ranges, case.passive(names)


def _offer(backend: str) -> None:
    """In this (fresh, experiment-only) process, accept a backend spherekin refuses, by its class."""
    from spherekin.search.lp_backends import LP_BACKENDS, REJECTED_BACKEND_CLASSES, REJECTED_LP_BACKENDS

    if backend in REJECTED_LP_BACKENDS:
        REJECTED_LP_BACKENDS.pop(backend)
        LP_BACKENDS.register(REJECTED_BACKEND_CLASSES[backend])


def measure(backend: str, probs: list[dict], seed: int, repeats: int) -> list[dict]:
    """Solve every problem with one backend (call it in a fresh process): what ran, counts, times, solutions;
    a capped problem is ``capped`` with no count."""
    from spherekin.search.boxloop import SolverLimitError, solve_system

    _offer(backend)
    rows = []
    for prob in probs:
        build, ranges, truth = _system(prob, seed)
        try:
            med, times, rep = median_time(lambda: solve_system(build, ranges, formulation=prob["formulation"],
                                                               pruner="lp", lp_backend=backend, **SEARCH), repeats)
        except SolverLimitError as exc:
            rows.append(dict(prob, backend=backend, capped=True, error=str(exc).split(";")[0]))
            continue
        asked = dict(system=None, formulation=prob["formulation"], parameterization=SEARCH["parameterization"],
                     pruner="lp", lp_backend=backend, tol=TOL)
        check_ran(asked, rep)
        st = rep.stats
        sols = [np.asarray(s.angles, float).tolist() for s in rep.clusters]
        rows.append(dict(prob, backend=backend, asked=asked, ran=ran(rep), capped=False, time=med, times=times,
                         spread=spread_text(times), boxes=st.boxes_processed, lps=st.lps_solved,
                         doubts=st.lp_doubts, isolated=st.isolated, accepted=st.accepted, time_prune=st.time_prune,
                         ms_per_lp=1e3 * st.time_prune / max(st.lps_solved, 1), n_solutions=len(sols),
                         solutions=sols, truth_found=contains(sols, truth)))
    return rows


def bound_quality(backend: str, probs: list[dict], seed: int, max_boxes: int) -> list[dict]:
    """Per LP, on the boxes highspy's search reduces: does ``backend`` give a certified bound, and how
    much looser than highspy's is it? (Call it in a fresh process.)"""
    import time

    from spherekin.search.boxloop import solve_system
    from spherekin.search.lp_backends import LP_BACKENDS, OPTIMAL, HighspyBackend, make_backend

    _offer(backend)
    rows = []
    for prob in probs:
        recorded = []

        class Recording(HighspyBackend):
            name = "highspy-recording"

            def box_bounds(self, cps, tols):
                if len(recorded) < max_boxes:
                    recorded.append(([np.array(c) for c in cps], [np.array(t) for t in tols]))
                return super().box_bounds(cps, tols)

        build, ranges, _ = _system(prob, seed)
        LP_BACKENDS.register(Recording)
        try:
            solve_system(build, ranges, formulation=prob["formulation"], pruner="lp", lp_backend=Recording.name,
                         **SEARCH)
        finally:
            LP_BACKENDS.unregister(Recording.name)
        shapes = [c.shape for c in recorded[0][0]]
        ref, test = make_backend("highspy", shapes), make_backend(backend, shapes)
        loose, times, statuses = [], [], []
        for cps, tols in recorded:
            if not test.structure.load(cps, tols):
                continue
            ref.structure.load(cps, tols)
            ref._load()
            test._load()
            n = test.structure.n
            for k in range(n):
                for sign in (1.0, -1.0):
                    c = test.structure.objective(k, sign)
                    status, _, y = ref._solve(c[:n].copy())
                    if status != OPTIMAL:          # no reference bound (an empty box): not compared
                        continue
                    reference = ref.structure.certified_min(c, y)
                    t0 = time.perf_counter()
                    status, _, y = test._solve(c[:n].copy())
                    times.append(time.perf_counter() - t0)
                    statuses.append(status)
                    loose.append(reference - test.structure.certified_min(c, y))
        loose = np.array(loose)
        ok = np.isfinite(loose)
        rows.append(dict(problem=prob["problem"], formulation=prob["formulation"], backend=backend,
                         boxes=len(recorded), lps=len(loose), certified_share=float(ok.mean()),
                         solver_optimal_share=float(np.mean([s == OPTIMAL for s in statuses])),
                         loose_median=float(np.median(loose[ok])) if ok.any() else None,
                         loose_p90=float(np.quantile(loose[ok], 0.9)) if ok.any() else None,
                         loose_max=float(loose[ok].max()) if ok.any() else None,
                         looser_than_1e3_share=float(np.mean(~ok | (loose > 1e-3))),
                         ms_per_lp=1e3 * float(np.median(times)) if times else None))
    return rows


def bug_demo(seed: int) -> list[dict]:
    """In ONE process: the four-bar with cvxpy's HIGHS, then with highspy (the HiGHS scheduler bug)."""
    from spherekin.search.boxloop import SolverLimitError, solve_system

    build, ranges, _ = _system(dict(mechanism="four_bar", half_width=None), seed)
    rows = []
    for backend in ("highs", "highspy"):
        row = dict(order=len(rows) + 1, backend=backend)
        try:
            rep = solve_system(build, ranges, formulation="halves", pruner="lp", lp_backend=backend,
                               **{**SEARCH, "max_boxes": BUG_DEMO_MAX_BOXES})
            row.update(boxes=rep.stats.boxes_processed, lps=rep.stats.lps_solved, doubts=rep.stats.lp_doubts,
                       n_solutions=len(rep.clusters), outcome="finished")
        except SolverLimitError as exc:
            row.update(outcome=f"{type(exc).__name__}: {str(exc).split(';')[0]}")
        rows.append(row)
    return rows


def _in_fresh_process(fn, *args):
    """Run fn(*args) in a new interpreter (spawn): no HiGHS state shared with other backends."""
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(fn, *args).result()


def compare(rows: list[dict], reference: str = "highspy") -> None:
    """Add to each row whether its boxes and solutions are those of the reference backend."""
    for r in rows:
        ref = next(x for x in rows if x["problem"] == r["problem"] and x["formulation"] == r["formulation"]
                   and x["backend"] == reference)
        if r["capped"] or ref["capped"]:        # a capped run has no count to compare
            continue
        r["same_counts"] = (r["boxes"], r["accepted"], r["isolated"]) == (ref["boxes"], ref["accepted"], ref["isolated"])
        same_n = len(r["solutions"]) == len(ref["solutions"])
        r["max_solution_diff"] = (max((min(angle_distance(s, t) for t in ref["solutions"]) for s in r["solutions"]),
                                      default=0.0) if same_n and ref["solutions"] else None)
        r["time_ratio"] = r["time"] / ref["time"]


def run(quick: bool = True, seed: int = 0, backends=None, repeats: int | None = None, probs=None,
        with_bug_demo: bool = True, quality_boxes: int = QUALITY_BOXES) -> dict:
    """Every backend (offered and refused, each in a fresh process) on every problem; the bound
    quality of every backend but highspy (the reference) on the Gosselin problems."""
    from spherekin.search.lp_backends import LP_BACKENDS, REJECTED_LP_BACKENDS

    backends = tuple(backends or (*LP_BACKENDS, *REJECTED_LP_BACKENDS))
    probs = probs or problems(quick)
    repeats = repeats or (QUICK_REPEATS if quick else FULL_REPEATS)
    rows, quality = [], []
    for b in backends:
        refused = b in REJECTED_LP_BACKENDS and not quick
        rows += _in_fresh_process(measure, b, [p for p in probs if p["mechanism"] == "gosselin" or not refused], seed,
                                  REFUSED_FULL_REPEATS if refused else repeats)
    compare(rows, "highspy" if "highspy" in backends else backends[0])
    gosselin = [p for p in probs if p["mechanism"] == "gosselin" and p["formulation"] == "halves"]
    for b in backends:
        if b != "highspy" and gosselin:
            quality += _in_fresh_process(bound_quality, b, gosselin, seed, quality_boxes)
    data = dict(settings=dict(pruner="lp", tol=TOL, repeats=repeats, refused_full_repeats=REFUSED_FULL_REPEATS,
                              backends=list(backends), refused=list(REJECTED_LP_BACKENDS),
                              quality_boxes=quality_boxes),
                runs=rows, bound_quality=quality)
    if with_bug_demo:
        data["bug_demo"] = _in_fresh_process(bug_demo, seed)
    return data


def main(argv=None):
    args = parser(__doc__.splitlines()[0]).parse_args(argv)
    data = run(args.quick, args.seed)
    tables = [("Backends on the same problems (pruner lp, tol 1e-6; ratios and differences against highspy)",
               data["runs"],
               [("problem", "problem", ""), ("formulation", "formulation", ""), ("backend", "backend", ""),
                ("boxes", "boxes", "d"), ("lps", "LPs", "d"), ("doubts", "doubts", "d"),
                ("ms_per_lp", "ms / LP", ".2f"), ("time", "total (s)", ".2f"), ("spread", "spread (s)", ""),
                ("time_ratio", "time ratio", ".1f"),
                ("n_solutions", "solutions", "d"), ("same_counts", "same boxes", ""),
                ("max_solution_diff", "max solution diff (rad)", ".1e"), ("truth_found", "start found", ""),
                ("error", "capped", "")]),
              ("Bound quality per LP on the boxes highspy's search reduces (Gosselin, halves; certified bound "
               "against highspy's certified bound, unit box coordinates)",
               data["bound_quality"],
               [("problem", "problem", ""), ("backend", "backend", ""), ("boxes", "boxes", "d"), ("lps", "LPs", "d"),
                ("certified_share", "certified", ".1%"), ("solver_optimal_share", "solver 'optimal'", ".1%"),
                ("loose_median", "looser: median", ".1e"), ("loose_p90", "p90", ".1e"), ("loose_max", "max", ".1e"),
                ("looser_than_1e3_share", "none or > 1e-3 looser", ".1%"), ("ms_per_lp", "ms / LP (solver call)", ".2f")])]
    if "bug_demo" in data:
        tables.append(("Regression check of the HiGHS scheduler bug: cvxpy's HIGHS, then highspy, in one process (four-bar, halves)",
                       data["bug_demo"],
                       [("order", "order", "d"), ("backend", "backend", ""), ("boxes", "boxes", "d"),
                        ("lps", "LPs", "d"), ("doubts", "doubts", "d"), ("outcome", "outcome", "")]))
    notes = ("Each backend ran in a fresh process; osqp and scs are refused by spherekin (REJECTED_LP_BACKENDS) and "
             "measured here by their classes, with one solve per problem, Gosselin problems only, in the full run. 'doubts': LPs whose "
             "answer spherekin could not certify (the bound stayed at the box face) or whose primal point missed "
             "Eq. (12) by > 1e-7 (first-order solvers: nearly all; their bounds are certified all the same). "
             "'same boxes': the same numbers of boxes processed, accepted and "
             "isolated as highspy. Solutions are the raw Newton roots of the solver (no polishing).")
    write_results("lp_backends", args, data, tables, notes)


if __name__ == "__main__":
    main()
