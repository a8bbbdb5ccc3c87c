"""Scaling: how does the cost of a solve grow with the number of unknowns, loops and legs?

Question (paper Sections 4 and 5): subdivision over [0, 1]^n is exponential in the worst case,
and the paper only solves the 3-RRR. How do boxes and time grow from a one-loop linkage to
mechanisms with more legs or more joints per leg, and does the solver handle them at all?

How: one ground-truth configuration per mechanism (random pose + inverse kinematics, seeded,
experiments/_compare.py) gives the inputs; each mechanism is solved on the loop equations with
every keyword pinned (:data:`LOOP_STRATEGY`: system loops, halves, pp, tol 1e-6, isolation), in
tan-half and in sin-cos; each row records what ran, read back from its report. Mechanisms, by number of unknown
(passive) angles: the spherical four-bar and five-bar (3 unknowns, 1 loop), the Gosselin platform
and the general 3-RRR (6 unknowns, 2 loops), a 3-RRR whose third leg is an RRRR chain with two
actuated joints (6 unknowns, a loop with one more joint), a redundantly actuated 4-RRR (8
unknowns, 3 loops: 9 equations, over-determined) and a 3-RRR with a fourth, fully passive RRR leg
(9 unknowns, 3 loops, square), the last three built with the general model
(spherekin/mechanism/model.py). Times are medians of several solves after one warm-up solve (a
warm-up slower than SLOW_RUN seconds is the first of MIN_REPEATS runs: at least 3 runs every time). Any solver error
is recorded with its exact message.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from experiments._common import Pinned, parser, pinned_solve, ran_text, spread_text, write_results
from experiments._compare import (GENERAL_POSE_ANGLE, MECHANISMS, closure_error, contains, four_rrr,
                      random_cases, three_rrr_rrrr)


#: name -> (constructor, max pose angle of the random pose or None for uniform), by growing size.
SCALING_MECHANISMS = {
    "four_bar": MECHANISMS["four_bar"],
    "five_bar": MECHANISMS["five_bar"],
    "gosselin": MECHANISMS["gosselin"],
    "general_3rrr": MECHANISMS["general_3rrr"],
    "3rrr_rrrr": (three_rrr_rrrr, GENERAL_POSE_ANGLE),
    "4rrr_redundant": (lambda: four_rrr(4), GENERAL_POSE_ANGLE),
    "3rrr_passive_leg": (lambda: four_rrr(3), GENERAL_POSE_ANGLE),
}
PARAMETERIZATIONS = ("tan-half", "sin-cos")
#: (mechanism, parameterization) pairs left out of --quick: sin-cos on 8 and 9 unknowns takes
#: ~6 s and ~140 s per solve (measured), far beyond the quick budget.
QUICK_SKIP = {("4rrr_redundant", "sin-cos"), ("3rrr_passive_leg", "sin-cos")}
QUICK_REPEATS, FULL_REPEATS = 3, 5
#: A warm-up solve slower than this (seconds) is the first measured run (a warm-up of a 140 s solve
#: warms nothing worth paying for).
SLOW_RUN = 2.0
#: Runs behind every median (issue 41: one run on a shared machine is not a measurement).
MIN_REPEATS = 3
#: Box cap of every solve (a named number, not the library's default, which may change).
MAX_BOXES = 500_000
#: The strategy of every solve but its parameterization: the loop equations, pinned.
LOOP_STRATEGY = Pinned(system="loops", formulation="halves", parameterization="tan-half", pruner="pp",
                       lp_backend=None, tol=1e-6, isolate=True, max_boxes=MAX_BOXES)


def structure(mech) -> dict:
    """Legs, loops, joints per leg, unknowns and scalar equations of a mechanism."""
    return dict(legs=len(mech.legs), loops=len(mech.loop_geometry), unknowns=len(mech.passive),
                inputs=len(mech.actuated), equations=3 * len(mech.loop_geometry),
                joints_per_leg="/".join(str(len(leg.joints)) for leg in mech.legs),
                loop_factors="/".join(str(len(g.vertices)) for g in mech.loop_geometry))


def solve_timed(mech, inputs, parameterization: str, repeats: int):
    """The :class:`~experiments._common.Solved` of ``repeats`` (at least MIN_REPEATS) timed solves after
    one warm-up solve; a slow warm-up (SLOW_RUN) is the first of them. Capped: as soon as one is."""
    pinned = replace(LOOP_STRATEGY, parameterization=parameterization)
    warm = pinned_solve(mech, inputs, pinned, 1)
    if warm.capped:
        return warm
    if warm.time > SLOW_RUN:
        rest = pinned_solve(mech, inputs, pinned, MIN_REPEATS - 1)
        return rest if rest.capped else replace(rest, times=warm.times + rest.times)
    return pinned_solve(mech, inputs, pinned, max(MIN_REPEATS, repeats))


def run(quick: bool = True, seed: int = 0, mechanisms=None, parameterizations=PARAMETERIZATIONS,
        repeats: int | None = None) -> dict:
    repeats = repeats or (QUICK_REPEATS if quick else FULL_REPEATS)
    names = list(mechanisms or SCALING_MECHANISMS)
    rng = np.random.default_rng(seed)
    rows = []
    for name in names:
        make, max_angle = SCALING_MECHANISMS[name]
        mech = make()
        case = random_cases(mech, rng, 1, max_angle)[0]
        info = structure(mech)
        for p in parameterizations:
            row = dict(mechanism=name, title=mech.name, parameterization=p, inputs_values=list(case.inputs), **info)
            if quick and (name, p) in QUICK_SKIP:
                rows.append(dict(row, skipped="quick"))
                continue
            try:
                got = solve_timed(mech, case.inputs, p, repeats)
            except Exception as exc:  # reported with its exact message: the question is whether it can solve it
                rows.append(dict(row, error=f"{type(exc).__name__}: {exc}"))
                continue
            row.update(got.settings_row(), ran_text=ran_text(got.settings_row()))
            if got.capped:
                rows.append(row)
                continue
            rep, med, times = got.report, got.time, list(got.times)
            sols = [np.asarray(s.angles, float) for s in rep.solutions]
            given = dict(zip(mech.actuated, case.inputs))
            st = rep.stats
            statuses = {}
            for s in rep.solutions:
                statuses[s.status] = statuses.get(s.status, 0) + 1
            rows.append(dict(row, charts=st.charts, boxes=st.boxes_processed, isolated=st.isolated,
                             accepted=st.accepted, max_depth=st.max_depth, time=med, times=times,
                             spread=spread_text(times),
                             n_solutions=len(sols), statuses=", ".join(f"{v} {k}" for k, v in sorted(statuses.items())),
                             truth_found=contains(sols, case.passive(rep.unknowns)),
                             max_closure_error=max((closure_error(mech, {**given, **dict(zip(rep.unknowns, s))})
                                                    for s in sols), default=0.0)))
    return dict(settings=dict(strategy=LOOP_STRATEGY.keywords(), repeats=repeats, min_repeats=MIN_REPEATS,
                              slow_run=SLOW_RUN),
                runs=rows)


def main(argv=None):
    args = parser(__doc__.splitlines()[0]).parse_args(argv)
    data = run(args.quick, args.seed)
    for r in data["runs"]:
        r["note"] = (f"capped: {r['error']}" if r.get("capped") else r.get("error")
                     or ("not run in --quick" if r.get("skipped") else ""))
    tables = [("Cost against size (one ground-truth input per mechanism; the loop equations, every keyword pinned)",
               data["runs"],
               [("mechanism", "mechanism", ""), ("legs", "legs", "d"), ("joints_per_leg", "joints/leg", ""),
                ("loops", "loops", "d"), ("unknowns", "unknowns", "d"), ("equations", "equations", "d"),
                ("parameterization", "parameterization", ""), ("charts", "charts", "d"), ("boxes", "boxes", "d"),
                ("time", "time (s)", ".3f"), ("spread", "spread (s)", ""), ("n_solutions", "solutions", "d"), ("statuses", "statuses", ""),
                ("truth_found", "start found", ""), ("max_closure_error", "closure error", ".1e"),
                ("note", "note", ""), ("ran_text", "ran (from the report)", "")])]
    notes = ("unknowns = passive joint angles; equations = 3 per independent loop. Closure error: largest entry of "
             "the difference between the platform poses of the legs (plain Rodrigues products) over the solutions.")
    write_results("scaling", args, data, tables, notes)


if __name__ == "__main__":
    main()
