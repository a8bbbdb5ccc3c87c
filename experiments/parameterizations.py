"""Tangent-half-angle vs sin/cos: which parameterization of the joint angles should the solver use?

Question (paper Sections 2.2 and 5): the paper substitutes t = tan(theta/2), which gives degree 2
per angle but is singular at theta = pi; Section 5 proposes x = sin(theta), y = cos(theta) with
x^2 + y^2 = 1 instead. What does each cost, and do they find the same solutions?

How: on the four-bar, the five-bar, the Gosselin platform and the general 3-RRR, several random
ground-truth configurations (experiments/_compare.py: a random pose, then inverse kinematics; the
seed fixes them) give the actuator inputs. Each is solved with ``parameterization="tan-half"`` and
``"sin-cos"`` on the loop equations (the paper's unknowns, Eq. (2)), every other keyword pinned
(:data:`LOOP_STRATEGY`: system "loops", formulation halves, pruner pp, tol 1e-6, Krawczyk isolation),
and once more by the default pipeline (:data:`DEFAULT_PIPELINE`, every name "auto": on a 3-RRR the
platform system, whose charts are a quaternion's), a row of its own. Each row records what ran, read
back from its report. Measured: the chart set (charts, control points per equation, read from
:func:`spherekin.search.parameterizations.make_charts`), boxes processed, LPs solved, median wall time,
the solutions found, whether both parameterizations return the same solution set, whether the
configuration we started from is among them, and the closure error of every solution computed
independently (each leg's product of Rodrigues rotations must give the same platform pose).

Robustness at pi: configurations in which a passive angle is exactly pi (a leg's joint readings
set to pi, the pose that leg then gives, the other legs by inverse kinematics) are solved by both.
spherekin's tan-half covers a full-circle joint by two charts centred at 0 and pi (t = tan((theta -
shift)/2) with |t| <= 1 on each), so theta = pi is the centre t = 0 of the second chart; sin-cos has
no singularity (pi is c = -1, s = 0, a face of the (c, s) box [-1, 1]^2).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from experiments._common import Pinned, parser, pinned_solve, ran_text, spread_text, write_results
from experiments._compare import MATCH_TOL, MECHANISMS, Case, closure_error, contains, random_cases, same_set

from spherekin.core.angles import wrap  # noqa: E402
from spherekin.mechanism.chains import axis_rotation, serial_ik  # noqa: E402
from spherekin.search.parameterizations import make_charts  # noqa: E402
PARAMETERIZATIONS = ("tan-half", "sin-cos")
#: The row of the default pipeline (its "parameterization" column).
DEFAULT_ROW = "default pipeline"
#: Box cap of every solve (a named number, not the library's default, which may change).
MAX_BOXES = 500_000
#: The Section 5 comparison: the loop equations with everything but the parameterization pinned.
LOOP_STRATEGY = dict(system="loops", formulation="halves", pruner="pp", lp_backend=None, tol=1e-6, isolate=True,
                     max_boxes=MAX_BOXES)
#: The default pipeline's row: every choice left to the library ("auto"), what ran read from the report.
DEFAULT_PIPELINE = dict(LOOP_STRATEGY, system="auto", formulation="auto", parameterization="tan-half")
#: What each row's "parameterization" runs with.
VARIANTS = {**{p: Pinned(**LOOP_STRATEGY, parameterization=p) for p in PARAMETERIZATIONS},
            DEFAULT_ROW: Pinned(**DEFAULT_PIPELINE)}
#: Inputs per mechanism and timing repeats: quick keeps `make experiments` under a minute.
QUICK_INPUTS, FULL_INPUTS = 2, 6
QUICK_REPEATS, FULL_REPEATS = 3, 5
#: The pi configurations: mechanism -> [(leg, passive joints of that leg set to exactly pi)].
#: Gosselin's elbow joints (gamma) are not set to pi here: with link angles of pi/2 an elbow at pi
#: folds the leg so that its base and platform axes are coaxial (u . v = -1), a serial+parallel
#: singularity with a continuum of assemblies (see PI_CONTINUUM).
PI_SETTINGS = {
    "gosselin": [("leg2", ("delta2",)), ("leg1", ("delta1",)), ("leg3", ("delta3",))],
    "general_3rrr": [("leg1", ("gamma1",)), ("leg1", ("delta1",)), ("leg1", ("gamma1", "delta1")),
                     ("leg2", ("gamma2", "delta2"))],
}
#: The folded Gosselin leg (gamma2 = pi): solved once per parameterization with a small box cap,
#: to show what a continuum does (the cap is reached); 20000 boxes take ~1 s (tan-half).
PI_CONTINUUM = ("gosselin", "leg2", ("gamma2",))
PI_CONTINUUM_MAX_BOXES = 20_000
#: Attempts at drawing the other joints of a pi configuration until every leg reaches the pose.
PI_DRAWS = 200


def chart_summary(mech, inputs, parameterization: str, formulation: str = LOOP_STRATEGY["formulation"]) -> dict:
    """Charts and control points of the equation blocks that spherekin builds (no solve)."""
    names = mech.loop_unknowns
    ranges = {n: mech.ranges[n] for n in names}

    def build(chart):
        system = mech.loop_system(inputs, chart)
        return system.loops, system.unknowns

    cs = make_charts(parameterization, build, ranges, formulation)
    blocks = []
    for labels, c, prune in zip(cs.labels, cs.coeffs, cs.prune):
        blocks.append(dict(label=labels[0].split(":")[0], equations=int(c.shape[1]),
                           control_points=int(np.prod(c.shape[2:])), shape=[int(d) for d in c.shape[2:]],
                           pruned=bool(prune)))
    loop_cps = sorted({b["control_points"] for b in blocks if b["label"].startswith("loop") and b["pruned"]})
    side_cps = sorted({b["control_points"] for b in blocks if b["label"].startswith("circle")})
    total = cs.n_charts * sum(b["equations"] * b["control_points"] for b in blocks)
    return dict(charts=cs.n_charts, unknowns=len(cs.unknowns), variables=len(cs.variables), blocks=blocks,
                loop_control_points=loop_cps, circle_control_points=side_cps, total_control_points=total)


def solve_case(mech, case: Case, pinned: Pinned, repeats: int) -> dict:
    """Solve one case ``repeats`` times with ``pinned``; what ran, counts, median time (and spread),
    solutions and their checks; a capped run is ``capped`` with no count."""
    got = pinned_solve(mech, case.inputs, pinned, repeats)
    if got.capped:
        return got.settings_row()
    rep, med, times = got.report, got.time, list(got.times)
    sols = [np.asarray(s.angles, float) for s in rep.solutions]
    inputs = dict(zip(mech.actuated, case.inputs))
    closure = max((closure_error(mech, {**inputs, **dict(zip(rep.unknowns, s))}) for s in sols), default=0.0)
    st = rep.stats
    return dict(**got.settings_row(), boxes=st.boxes_processed, lps=st.lps_solved, isolated=st.isolated,
                accepted=st.accepted, time=med, times=times, spread=spread_text(times), n_solutions=len(sols), solutions=[s.tolist() for s in sols],
                unknowns=list(rep.unknowns), statuses=[s.status for s in rep.solutions],
                truth_found=contains(sols, case.passive(rep.unknowns)), max_closure_error=closure)


def compare_mechanism(name: str, n_inputs: int, repeats: int, rng: np.random.Generator) -> list[dict]:
    """One row per (input, parameterization) on mechanism ``name``."""
    make, max_angle = MECHANISMS[name]
    mech = make()
    rows = []
    for i, case in enumerate(random_cases(mech, rng, n_inputs, max_angle)):
        res = {p: solve_case(mech, case, pinned, repeats) for p, pinned in VARIANTS.items()}
        for p in VARIANTS:
            other = "sin-cos" if p == "tan-half" else "tan-half"
            agree = None if res[p]["capped"] or res[other]["capped"] else same_set(res[p]["solutions"],
                                                                                  res[other]["solutions"])
            rows.append(dict(mechanism=name, input=i, inputs=list(case.inputs), parameterization=p,
                             same_solutions=agree, **res[p]))
    return rows


def pi_case(mech, leg_name: str, joints_at_pi, rng: np.random.Generator) -> Case:
    """A configuration with the readings of ``joints_at_pi`` (passive joints of leg ``leg_name``) exactly pi.

    The leg's other joints are drawn at random, the platform pose is the leg's product of
    exponentials, and the other legs come from inverse kinematics of that pose (redrawn until every
    leg reaches it).
    """
    leg = mech.leg(leg_name)
    for _ in range(PI_DRAWS):
        readings = {j.name: (math.pi if j.name in joints_at_pi else rng.uniform(-math.pi, math.pi))
                    for j in leg.joints}
        disp = np.eye(3)
        for j in leg.joints:
            disp = disp @ axis_rotation(np.array(j.axis), readings[j.name] - j.reference_angle)
        ok = True
        for other in mech.legs:
            if other.name == leg_name:
                continue
            sols = serial_ik(np.array([j.axis for j in other.joints]), disp)
            if not sols:
                ok = False
                break
            d = sols[int(rng.integers(len(sols)))]
            readings.update({j.name: wrap(j.reference_angle + x) for j, x in zip(other.joints, d)})
        if ok:
            return Case(tuple(readings[n] for n in mech.actuated), readings)
    raise RuntimeError(f"{mech.name}: no configuration with {joints_at_pi} = pi found in {PI_DRAWS} draws")


def _pi_row(mech, name, case, at_pi, repeats, max_boxes: int = MAX_BOXES) -> list[dict]:
    res = {p: solve_case(mech, case, Pinned(**{**LOOP_STRATEGY, "max_boxes": max_boxes}, parameterization=p),
                         repeats) for p in PARAMETERIZATIONS}
    ok = not any(r["capped"] for r in res.values())
    agree = ok and same_set(res["tan-half"]["solutions"], res["sin-cos"]["solutions"])
    rows = []
    for p in PARAMETERIZATIONS:
        r = res[p]
        row = dict(mechanism=name, joints_at_pi=",".join(at_pi), parameterization=p, inputs=list(case.inputs),
                   singularity=mech.singularity(case.joints).kind)
        if r["capped"]:
            rows.append(dict(row, **r, found=False, status=f"capped: {r['error']}", same_solutions=None))
            continue
        idx = [r["unknowns"].index(n) for n in at_pi]
        truth = case.passive(r["unknowns"])            # the configuration we started from
        hit = [i for i, s in enumerate(r["solutions"]) if contains([s], truth)]
        err = max(abs(abs(wrap(r["solutions"][hit[0]][k])) - math.pi) for k in idx) if hit else None
        rows.append(dict(row, found=bool(hit), pi_error=err, status=r["statuses"][hit[0]] if hit else "missing",
                         same_solutions=agree,
                         **{k: r[k] for k in ("asked", "ran", "capped", "boxes", "time", "n_solutions",
                                              "max_closure_error")}))
    return rows


def pi_rows(rng: np.random.Generator, repeats: int, with_continuum: bool = True) -> list[dict]:
    """Solve the pi configurations (PI_SETTINGS, and PI_CONTINUUM) with both parameterizations."""
    rows = []
    for name, settings in PI_SETTINGS.items():
        mech = MECHANISMS[name][0]()
        for leg_name, at_pi in settings:
            rows += _pi_row(mech, name, pi_case(mech, leg_name, at_pi, rng), at_pi, repeats)
    if with_continuum:
        name, leg_name, at_pi = PI_CONTINUUM
        mech = MECHANISMS[name][0]()
        rows += _pi_row(mech, name, pi_case(mech, leg_name, at_pi, rng), at_pi, 1, max_boxes=PI_CONTINUUM_MAX_BOXES)
    return rows


def summarize(rows: list[dict]) -> list[dict]:
    """Per mechanism and parameterization: medians over the inputs and all-inputs checks."""
    out = []
    for name in dict.fromkeys(r["mechanism"] for r in rows):
        for p in VARIANTS:
            every = [r for r in rows if r["mechanism"] == name and r["parameterization"] == p]
            sel = [r for r in every if not r["capped"]]      # a capped run has no count: never in a median
            ran_as = sorted({ran_text(r) for r in sel})
            if not sel:
                out.append(dict(mechanism=name, parameterization=p, inputs=0, capped=len(every)))
                continue
            out.append(dict(mechanism=name, parameterization=p, inputs=len(sel), capped=len(every) - len(sel),
                            ran="; ".join(ran_as),
                            median_boxes=float(np.median([r["boxes"] for r in sel])),
                            median_time_ms=1e3 * float(np.median([r["time"] for r in sel])),
                            lps=int(sum(r["lps"] for r in sel)),
                            solutions="/".join(str(r["n_solutions"]) for r in sel),
                            same_solutions=all(r["same_solutions"] for r in sel),
                            truth_found=all(r["truth_found"] for r in sel),
                            max_closure_error=max(r["max_closure_error"] for r in sel)))
    # time and box ratios sin-cos / tan-half, measured in the same process on the same inputs
    for s in out:
        base = next(t for t in out if t["mechanism"] == s["mechanism"] and t["parameterization"] == "tan-half")
        if not s["inputs"] or not base["inputs"]:
            continue
        s["time_ratio"] = s["median_time_ms"] / base["median_time_ms"]
        s["box_ratio"] = s["median_boxes"] / base["median_boxes"]
    return out


def run(quick: bool = True, seed: int = 0, mechanisms=tuple(MECHANISMS), n_inputs: int | None = None,
        repeats: int | None = None, with_pi: bool = True) -> dict:
    """The whole experiment as a dict (what the JSON file holds, without the metadata)."""
    rng = np.random.default_rng(seed)
    n_inputs = n_inputs or (QUICK_INPUTS if quick else FULL_INPUTS)
    repeats = repeats or (QUICK_REPEATS if quick else FULL_REPEATS)
    charts = []
    rows = []
    for name in mechanisms:
        rows += compare_mechanism(name, n_inputs, repeats, rng)
        mech = MECHANISMS[name][0]()
        first = next(r for r in rows if r["mechanism"] == name)
        for p in PARAMETERIZATIONS:
            cs = chart_summary(mech, first["inputs"], p)
            charts.append(dict(mechanism=name, parameterization=p, **cs,
                               loop_cps=", ".join(map(str, cs["loop_control_points"])),
                               circle_cps=", ".join(map(str, cs["circle_control_points"])) or "-"))
    data = dict(settings=dict(loop_strategy=LOOP_STRATEGY, default_pipeline=DEFAULT_PIPELINE,
                              inputs_per_mechanism=n_inputs, repeats=repeats, match_tol=MATCH_TOL),
                charts=charts, runs=rows, summary=summarize(rows))
    if with_pi:
        data["pi"] = pi_rows(rng, repeats)
    return data


def main(argv=None):
    args = parser(__doc__.splitlines()[0]).parse_args(argv)
    data = run(args.quick, args.seed)
    tables = [
        ("Chart sets (control points per equation of one chart; total over all blocks and charts)", data["charts"],
         [("mechanism", "mechanism", ""), ("parameterization", "parameterization", ""), ("unknowns", "angles", "d"),
          ("variables", "variables", "d"), ("charts", "charts", "d"), ("loop_cps", "cps / loop equation", ""),
          ("circle_cps", "cps / circle equation", ""), ("total_control_points", "total cps", "d")]),
        ("Cost and solutions (medians over the inputs; ratio = this row / tan-half)", data["summary"],
         [("mechanism", "mechanism", ""), ("parameterization", "parameterization", ""), ("inputs", "inputs", "d"),
          ("capped", "capped", "d"),
          ("median_boxes", "boxes", ".0f"), ("box_ratio", "box ratio", ".2f"), ("lps", "LPs", "d"),
          ("median_time_ms", "time (ms)", ".1f"), ("time_ratio", "time ratio", ".2f"),
          ("solutions", "solutions per input", ""), ("same_solutions", "same solutions", ""),
          ("truth_found", "start pose found", ""), ("max_closure_error", "max closure error", ".1e"),
          ("ran", "ran (from the reports)", "")]),
    ]
    if "pi" in data:
        tables.append(("Passive angles exactly pi", data["pi"],
                       [("mechanism", "mechanism", ""), ("joints_at_pi", "joints at pi", ""),
                        ("parameterization", "parameterization", ""), ("singularity", "singularity", ""),
                        ("found", "start found", ""),
                        ("pi_error", "|angle| - pi", ".1e"), ("status", "status (or error)", ""),
                        ("n_solutions", "solutions", "d"), ("same_solutions", "same solutions", ""),
                        ("boxes", "boxes", "d"), ("time", "time (s)", ".3f")]))
    notes = ("tan-half and sin-cos: the loop equations (system loops), formulation halves, pruner pp, tol 1e-6, "
             "isolation on, every keyword pinned; 'default pipeline': every choice left to the library (auto), "
             "what ran read from the reports (since issue 44 the complete counts where they apply: the 3-RRR's, "
             "on the platform's quaternion, and the one-loop count of the four-bar and five-bar, neither with "
             "any box; the platform system's quaternion charts elsewhere: boxes not comparable with the loop "
             "rows'). A capped run is counted under 'capped', never in a median. A solution matches another (or the start configuration) when every angle "
             f"agrees within {MATCH_TOL:g} rad modulo 2 pi. The closure error is the largest entry of the "
             "difference between the platform poses of the legs, each a plain product of Rodrigues rotations.")
    write_results("parameterizations", args, data, tables, notes)


if __name__ == "__main__":
    main()
