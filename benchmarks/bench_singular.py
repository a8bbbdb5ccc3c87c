"""Certified parallel-singular sets in a plane of inputs (issue 31): cells, boxes, seconds as T shrinks.

For general_3rrr and the Gosselin platform (the agile eye, examples/gosselin.toml) in the plane beta3 = 0.5
over [-pi, pi]^2, :func:`spherekin.singular` at each cell width T (default 0.1 and 0.05; ``--full`` adds the
issue's 1e-2 and 1e-3: minutes each for general_3rrr with the traced cover, spherekin.singularities.cells.trace_cover).
Reported per mechanism and T: cells by status, whether the cover completed (its box cap not reached), boxes
processed, seconds (wall and this process's CPU: the machine is shared; one run each), and the ratio of
cells between successive T against the ratio of the T (a curve's cover grows as ~1/T). For general_3rrr a
cross-check: the singular inputs of tests/singular_refs.py's independent reference on ``--ref-lines`` seeded
lines across the plane, and how many lie in a cell (must be all).

``--figure PATH`` also draws the map of general_3rrr at beta3 = 0.5 (``--map-n`` x ``--map-n`` grid) with the
certified cells of the largest T and the free box of home (0, 0, 0.5), solution 1, in the plane.

    python -m benchmarks.bench_singular [--full] [--max-boxes N] [--figure PATH] [--json PATH]

The box cap is per mechanism (:data:`MAX_BOXES`; both keep the library's): the agile eye's crossings with its
stationary assemblies are proven on their blow-up (spherekin.singularities.blowup).

JSON to benchmarks/results/singular.json.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MECHANISMS = ("general_3rrr", "gosselin")
#: Cell widths (radians) of a default run, and those ``--full`` adds (the issue's; long runs).
DEFAULT_TOLS = (0.1, 0.05)
FULL_TOLS = (1e-2, 1e-3)
#: Box cap per set, by mechanism (``--max-boxes`` sets one for all). Reason: general_3rrr needs ~5e5 boxes at
#: T = 0.1, ~1.5e6 at 1e-2 and ~3e6 at 1e-3 (the traced cover): it keeps the library's cap
#: (spherekin.problem.SINGULAR_MAX_BOXES, 1e7; None here), which only stops a runaway.
#: The agile eye's too, since its stationary assemblies are blown up (~1.5e6 boxes at 1e-2, measured; before,
#: the band of cells along its crossings refined as ~T^-2.5 and a cap of 5e4 stopped it).
MAX_BOXES = {"general_3rrr": None, "gosselin": None}
#: A reference point (bisected to 1e-10) on a cell edge counts as inside within this (radians).
EDGE = 1e-9


def _reference_points(n_lines: int) -> np.ndarray:
    """The independent reference's singular inputs of general_3rrr on n_lines seeded lines of the plane."""
    sys.path.insert(0, str(ROOT / "tests"))
    from singular_refs import seeded_lines, singular_points_on_line

    return np.array([s.inputs[:2] for p0, p1 in seeded_lines(n_lines, seed=31)
                     for s in singular_points_on_line(p0, p1, n_samples=150, seed=0)])


def _covered(sset, points) -> int:
    lo = np.array([[b.x[0], b.y[0]] for b in sset.boxes])
    hi = np.array([[b.x[1], b.y[1]] for b in sset.boxes])
    return int(sum(np.any(np.all((lo - EDGE <= p) & (p <= hi + EDGE), axis=1)) for p in points))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="also T = 1e-2 and 1e-3 (long: minutes to hours)")
    ap.add_argument("--tols", help="comma-separated cell widths instead (radians)")
    ap.add_argument("--max-boxes", type=int, help=f"box cap per set, every mechanism (default: {MAX_BOXES})")
    ap.add_argument("--mechanisms", default=",".join(MECHANISMS))
    ap.add_argument("--ref-lines", type=int, default=2, help="seeded reference lines (0: no cross-check)")
    ap.add_argument("--figure", help="also draw the map of general_3rrr with its cells and free box here (.png)")
    ap.add_argument("--map-n", type=int, default=51, help="the figure's map grid points per axis")
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "singular.json"))
    args = ap.parse_args(argv)

    import spherekin

    tols = tuple(float(t) for t in args.tols.split(",")) if args.tols else DEFAULT_TOLS + (FULL_TOLS if args.full else ())
    plane = dict(x=("beta1", -math.pi, math.pi), y=("beta2", -math.pi, math.pi), fixed={"beta3": 0.5})
    refs = _reference_points(args.ref_lines) if args.ref_lines else np.empty((0, 2))
    rows, sets = [], {}
    from spherekin.singularities.cover import SINGULAR_MAX_BOXES

    caps = {name: args.max_boxes or MAX_BOXES.get(name) or SINGULAR_MAX_BOXES for name in args.mechanisms.split(",")}
    print(f"parallel singular set, plane beta3 = 0.5 over [-pi, pi]^2, box caps {caps} "
          f"({platform.machine()}, one process)")
    head = (f"{'mechanism':<13} {'T':>6} {'singular':>9} {'unresolved':>10} {'complete':>8} {'boxes':>10} "
            f"{'seconds':>8} {'cpu s':>8} {'cells/prev':>10} {'1/T ratio':>9} {'refs in cells':>13}")
    print(head)
    for name in args.mechanisms.split(","):
        prev = None
        for tol in tols:
            t0, c0 = time.perf_counter(), time.process_time()
            s = spherekin.singular(ROOT / "examples" / f"{name}.toml", tol=tol, max_boxes=caps[name], **plane)
            seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
            sets[(name, tol)] = s
            c = s.counts()
            cells = len(s.boxes)
            growth = None if prev is None else cells / prev[1]
            expect = None if prev is None else prev[0] / tol
            refs_in = (f"{_covered(s, refs)}/{len(refs)}" if name == "general_3rrr" and len(refs) else "-")
            row = dict(mechanism=name, tol=tol, max_boxes=caps[name], singular=c["singular"], unresolved=c["unresolved"], cells=cells,
                       complete=s.complete, boxes_processed=s.stats.boxes_processed, seconds=seconds, cpu_seconds=cpu,
                       cusps=sum(c.status == "cusp" for c in s.cusps), cusp_candidates=len(s.cusps),
                       cells_ratio=growth, tol_ratio=expect, reference_points_covered=refs_in)
            rows.append(row)
            print(f"{name:<13} {tol:>6.3g} {c['singular']:>9} {c['unresolved']:>10} {'yes' if s.complete else 'no':>8} "
                  f"{s.stats.boxes_processed:>10,} {seconds:>8.1f} {cpu:>8.1f} "
                  f"{'-' if growth is None else f'{growth:.2f}':>10} {'-' if expect is None else f'{expect:.2f}':>9} "
                  f"{refs_in:>13}", flush=True)
            prev = (tol, cells)
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"plane": {"x": "beta1", "y": "beta2", "range": [-math.pi, math.pi],
                                         "fixed": {"beta3": 0.5}},
                               "machine": platform.machine(), "rows": rows}, indent=2))
    print(f"wrote {out}")
    if args.figure:
        _figure(args.figure, sets.get(("general_3rrr", max(tols))), args.map_n, plane)
    return 0


def _figure(path, sset, n: int, plane) -> None:
    """The map of general_3rrr at beta3 = 0.5 with its certified cells and cusps, the free box of home
    (0, 0, 0.5), solution 1 (in the plane), and a proven assembly-mode change around a cusp (if one is
    found), written to ``path``."""
    import dataclasses

    import spherekin
    from spherekin import batch
    from spherekin.plot import plot_assembly_map
    from spherekin.singularities import mode_change

    file = ROOT / "examples" / "general_3rrr.toml"
    if sset is None:
        sset = spherekin.singular(file, tol=DEFAULT_TOLS[0], **plane)
    t0 = time.perf_counter()
    box = spherekin.compile(file).free_box((0.0, 0.0, 0.5), start=0, inputs=("beta1", "beta2"))
    sset = dataclasses.replace(sset, free_box={**box.as_dict(), "start_solution": 1})
    print(f"free box of solution 1 at home (0, 0, 0.5): beta1 [{box.lo[0]:.3f}, {box.hi[0]:.3f}], "
          f"beta2 [{box.lo[1]:.3f}, {box.hi[1]:.3f}] ({'proven' if box.proven else 'none proven'}, "
          f"limit {box.limit}; {time.perf_counter() - t0:.1f} s)")
    t0 = time.perf_counter()
    change = mode_change(file, sset)
    sset = dataclasses.replace(sset, mode_change=change)
    print(f"cusps: {sum(c.status == 'cusp' for c in sset.cusps)} proven, "
          f"{sum(c.status != 'cusp' for c in sset.cusps)} unresolved; mode change: "
          + (f"solution {change.start_solution} -> {change.end_solution} around the cusp "
             f"({change.cusp[0]:.4f}, {change.cusp[1]:.4f})" if change.found else "none found")
          + f" ({time.perf_counter() - t0:.1f} s)")
    t0 = time.perf_counter()
    amap = batch.assembly_map(file, f"beta1=-pi:pi:{n}", f"beta2=-pi:pi:{n}", {"beta3": 0.5})
    amap = dataclasses.replace(amap, singular_set=sset)
    print(f"map {n} x {n}: {time.perf_counter() - t0:.1f} s")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    plot_assembly_map(amap, path)
    print(f"wrote {path} ({Path(path).stat().st_size / 1e3:.0f} kB)")


if __name__ == "__main__":
    raise SystemExit(main())
