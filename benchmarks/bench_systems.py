"""Benchmark of the systems layer: per-solve time of each equation system on each mechanism, in one run.

Mechanisms: a spherical four-bar and five-bar (:func:`spherekin.mechanism.four_bar`, ``five_bar``),
the elbow-actuated 3-RRR (general_3rrr with each leg's elbow joint actuated instead of its base
joint), general_3rrr, and the Watt and Stephenson six-bars of examples/ (graph files; the Watt one
skipped, with a note, where that file is missing or this checkout cannot read it). For each mechanism and each system of
:data:`spherekin.systems.SYSTEMS` that accepts it, the problem is compiled once and solved
``--repeats`` times at one input; the table gives the median per-solve wall time, the solutions
found and proven, and which system "auto" chooses (with the reasons of the faster ones that
declined). JSON goes to benchmarks/results/systems.json.

    python -m benchmarks.bench_systems [--repeats 7] [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from spherekin.mechanism import five_bar, four_bar, general_3rrr, load_mechanism
from spherekin.problem import compile
from spherekin.systems import SYSTEMS

ROOT = Path(__file__).resolve().parent.parent
WATT = ROOT / "examples" / "watt_six_bar.toml"
STEPHENSON = ROOT / "examples" / "stephenson_six_bar.toml"
#: Inputs of general_3rrr (radians): 8 real assemblies' worth of a regular input.
INPUTS_3RRR = (0.3, -0.2, 0.5)
#: The Watt six-bar's input offset from its reference assembly (where every joint reads 0, so the
#: file's linkage assembles there): small, so that it still assembles, non-zero, so that the input
#: is a generic one.
GRAPH_OFFSET = 0.05


def elbow_actuated_3rrr():
    """general_3rrr with each leg's second (elbow) joint actuated instead of its base joint."""
    mech = general_3rrr()
    legs = tuple(dataclasses.replace(leg, joints=tuple(dataclasses.replace(j, actuated=(k == 1))
                                                       for k, j in enumerate(leg.joints))) for leg in mech.legs)
    return dataclasses.replace(mech, legs=legs, name="elbow-actuated 3-RRR (general_3rrr)")


def elbow_inputs(elbow_mech) -> tuple:
    """Elbow readings of an assembly of general_3rrr at INPUTS_3RRR (so the elbow-actuated one assembles)."""
    report = compile(general_3rrr()).solve(INPUTS_3RRR)
    angles = dict(zip(report.unknowns, report.solutions[0].angles))
    return tuple(float(angles[n]) for n in elbow_mech.actuated)


def cases(quick: bool = False):
    """(label, mechanism, inputs) of the benchmark, or (label, None, note) for a skipped one."""
    out = [("four-bar", four_bar(), (0.3,)), ("five-bar", five_bar(), (0.2, -0.1))]
    if not quick:
        elbow = elbow_actuated_3rrr()
        out.append(("elbow-actuated 3-RRR", elbow, elbow_inputs(elbow)))
    out.append(("general_3rrr", general_3rrr(), INPUTS_3RRR))
    if not quick:
        if not WATT.exists():
            out.append(("Watt six-bar", None, f"{WATT.relative_to(ROOT)} is missing"))
        else:
            try:
                watt = load_mechanism(WATT)
            except (ValueError, OSError) as exc:     # e.g. a file kind this checkout does not know
                out.append(("Watt six-bar", None, f"{WATT.relative_to(ROOT)} cannot be read here ({exc})"))
            else:
                out.append(("Watt six-bar", watt, tuple(GRAPH_OFFSET for _ in watt.actuated)))
        stephenson = load_mechanism(STEPHENSON)
        out.append(("Stephenson six-bar", stephenson, tuple(GRAPH_OFFSET for _ in stephenson.actuated)))
    return out


def time_system(mech, inputs, system: str, repeats: int) -> dict:
    """Compile ``mech`` for ``system`` once, solve at ``inputs`` ``repeats`` times: the median and the answer."""
    problem = compile(mech, system=system)
    times, report = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        report = problem.solve(inputs)
        times.append(time.perf_counter() - t0)
    return dict(system=system, median_seconds=statistics.median(times), times=times,
                solutions=len(report.solutions), proven=report.proven_count, solved_by=report.settings.system,
                fallback=report.settings.fallback, boxes=report.stats.boxes_processed)


def run(repeats: int = 7, quick: bool = False) -> list[dict]:
    """One row per (mechanism, accepting system), plus the system "auto" chooses for the mechanism."""
    rows = []
    for label, mech, inputs in cases(quick):
        if mech is None:
            print(f"note: {label} skipped: {inputs}")
            rows.append(dict(mechanism=label, skipped=inputs))
            continue
        auto = compile(mech)
        for name, cls in SYSTEMS.items():
            why = cls.accepts(mech)
            row = dict(mechanism=label, inputs=list(inputs), chosen_by_auto=auto.system == name,
                       declined_by_auto=dict(auto.declined).get(name))
            if why is not None:
                rows.append(dict(row, system=name, accepts=False, reason=why))
                continue
            rows.append(dict(row, accepts=True, **time_system(mech, inputs, name, repeats)))
    return rows


def print_table(rows) -> None:
    header = f"{'mechanism':22s} {'system':9s} {'median ms':>10s} {'sols':>4s} {'proven':>6s} {'boxes':>6s}  auto"
    print(header)
    print("-" * len(header))
    for r in rows:
        if "skipped" in r:
            continue
        if not r["accepts"]:
            print(f"{r['mechanism']:22s} {r['system']:9s} {'-':>10s} {'':>4s} {'':>6s} {'':>6s}  "
                  f"does not accept: {r['reason']}")
            continue
        print(f"{r['mechanism']:22s} {r['system']:9s} {1e3 * r['median_seconds']:10.2f} {r['solutions']:4d} "
              f"{r['proven']:6d} {r['boxes']:6d}  {'chosen' if r['chosen_by_auto'] else ''}"
              + (f" (fell back: {r['fallback']})" if r["fallback"] else ""))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="solves per (mechanism, system); the median is shown")
    parser.add_argument("--quick", action="store_true", help="the four-bar, five-bar and general_3rrr only")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "systems.json")
    args = parser.parse_args(argv)
    print(f"per-solve median of {args.repeats} solves (compiled once); {os.cpu_count()} cores, "
          f"Python {platform.python_version()}")
    rows = run(args.repeats, args.quick)
    print_table(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"benchmark": "systems", "repeats": args.repeats, "cores": os.cpu_count(),
                                    "python": platform.python_version(), "machine": platform.machine(),
                                    "numpy": np.__version__, "rows": rows}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
