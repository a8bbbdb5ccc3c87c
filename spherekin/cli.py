"""Command-line interface: ``spherekin <command>``.

Commands:
    solve      direct kinematics of a mechanism file: every solution inside the joint ranges
    ik         inverse kinematics: every actuator solution (working mode) of a platform pose
    batch      direct kinematics of many inputs (a CSV or a grid) on Dask, written as they finish
    map        the number of assembly modes over a 2-D grid of inputs, drawn as a map; for one
               actuated joint, the branches and circuits over its input
    track      follow one assembly mode along a path of inputs, every step proven
    gosselin   summary of the paper's two Gosselin closure loops in Bernstein form (Section 2.1, Eq. 10)
    verify     symbolic verification of every claim of the paper; writes verification/REPORT.md
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import math
import os
import re
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from . import atomic

# numpy and the package's modules are imported by the functions that use them (build_parser imports
# every strategy module; spherekin.atomic imports nothing heavy): importing this module stays light, so
# that run() can pause the garbage collector before the heavy imports.

#: Default actuator angles (radians) of the example: arbitrary, generic values (no symmetry).
DEFAULT_BETAS = (0.3, -0.2, 0.5)


def _gosselin(args) -> int:
    import numpy as np

    from .core import bernstein
    from .mechanism.checks import check_range, parse_angle
    from .paper_gosselin import paper_gosselin_loops
    from .results import format_number

    betas = [parse_angle(f"--beta (B{k})", b) for k, b in enumerate(args.beta, start=1)]
    passive = check_range("--range", args.range)
    t0 = time.perf_counter()
    loops = paper_gosselin_loops(betas, passive, corrected=True)
    rng = np.random.default_rng(args.seed)
    print("Gosselin platform: the paper's two closure loops in Bernstein form (Section 2.1, Eq. 10);")
    print("  loop 2 with its first and last factors swapped back (erratum s21-final-loop2, verification/REPORT.md)")
    print(f"  actuators beta = ({', '.join(format_number(b, '+.4f') for b in betas)}) rad; "
          f"passive joints in [{format_number(passive[0], '+.4f')}, {format_number(passive[1], '+.4f')}] rad")
    total = 0
    for k, loop in enumerate(loops, start=1):
        rec = loop.scalar_control_points("recursion")
        prod = loop.scalar_control_points("product")
        scale = np.abs(prod).max()
        lo, hi = bernstein.bounds(rec)
        x = rng.uniform(0.0, 1.0, (args.samples, len(loop.unknowns)))
        values = bernstein.evaluate(rec, x)
        mats = loop.closure_matrix(x)
        trig = mats[:, 0, 0] + mats[:, 1, 1] - 2.0
        total += rec.size
        print(f"loop {k}: n = {loop.n} factors, unknowns {', '.join(loop.names)}")
        print(f"  control points of f = f11 + f22 - 2q: {rec.size} (3^{rec.ndim}); "
              f"recursion vs product route: max |diff| / max|c| = {np.abs(rec - prod).max() / scale:.1e}")
        print(f"  control-point enclosure of f over the box: [{lo:.4g}, {hi:.4g}]")
        print(f"  f at {args.samples} random points:           [{values.min():.4g}, {values.max():.4g}]")
        print(f"  f11 + f22 - 2 (closure residual) there:     [{trig.min():.4g}, {trig.max():.4g}] "
              "(0 only where the loop closes)")
    shared = sorted(set(loops[0].names) & set(loops[1].names))
    print(f"total control points: {total} (the paper counts 162); shared unknowns: {', '.join(shared)}")
    print(f"done in {time.perf_counter() - t0:.2f} s")
    return 0


def _parse_angles(key: str, text: str, names, degrees: bool, what: str) -> list[float]:
    """The angles of ``names`` (radians) from the comma-separated ``text`` of option ``key``: each a
    number or text such as "pi/2", read as the mechanism files, --grid and --fix read angles
    (:func:`~spherekin.mechanism.checks.parse_angle`; degrees with ``degrees``). ``what``: what the
    values are, for the error when there are not as many as names."""
    from .mechanism.checks import parse_angle

    parts = text.split(",")
    if len(parts) != len(names):
        raise ValueError(f"{key}: expected {len(names)} values ({what}: {', '.join(names)}), comma-separated, "
                         f"got {len(parts)} in {text!r}")
    return [parse_angle(f"{key} ({name})", part, degrees=degrees) for name, part in zip(names, parts)]


class _Progress:
    """The progress of one solve on stderr: boxes done and their rate, one line redrawn at most every
    0.2 s on a terminal, a plain line every PROGRESS_INTERVAL seconds otherwise (a log); nothing
    with ``quiet``."""

    def __init__(self, terminal: bool, quiet: bool = False):
        self.terminal, self.quiet, self.last, self.t0 = terminal, quiet, 0.0, time.perf_counter()
        self.shown = False

    def __call__(self, counts: dict) -> None:
        if self.quiet:
            return
        now = time.perf_counter()
        elapsed = now - self.t0
        if now - self.last < (0.2 if self.terminal else PROGRESS_INTERVAL) or (not self.terminal and elapsed < 1.0):
            return
        self.last = now
        rate = counts["boxes_processed"] / elapsed if elapsed > 0 else 0.0
        line = (f"  {elapsed:6.1f} s  boxes {counts['boxes_processed']:8d} ({rate:8.0f}/s)  pending "
                f"{counts['pending']:6d}  accepted {counts['accepted']:5d}")
        if self.terminal:
            print("\r" + line, end="", file=sys.stderr, flush=True)
            self.shown = True
        else:
            print(line, file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.shown:
            print(file=sys.stderr)


def _check_output_file(option: str, path: str, suffixes: tuple[str, ...]) -> Path:
    """An output file path checked before any work: a known suffix, not a directory, in an existing
    writable directory."""
    out = Path(path)
    if suffixes and out.suffix.lower() not in suffixes:
        raise ValueError(f"{option} {path}: expected a file name ending in {' or '.join(suffixes)}")
    if out.is_dir():
        raise ValueError(f"{option} {path}: is a directory; expected a file name")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"{option} {path}: the directory {parent} does not exist")
    atomic.check_writable(parent, f"{option} {path}")
    return out


class _Choices(list):
    """argparse choices that show ``names`` (in --help and argparse's "invalid choice" error) and also
    let ``refused`` through: names spherekin knows and refuses with a measured reason (an LP backend
    of REJECTED_LP_BACKENDS), which the strategy check then gives as the one-line error, exit 2."""

    def __init__(self, names, refused):
        super().__init__(names)
        self.refused = tuple(refused)

    def __contains__(self, name) -> bool:
        return list.__contains__(self, name) or name in self.refused


def _solve(args) -> int:
    from .mechanism import load_mechanism
    from .problem import compile as compile_problem
    from .results import format_number
    from .search.pruners import check_pruner

    check_pruner(args.pruner, args.lp_backend)   # a refused LP backend's reason, before any output
    mech = load_mechanism(args.file)
    inputs = _parse_angles("--inputs", args.inputs, mech.actuated, args.degrees, "one per actuated joint")
    values = mech.check_inputs(inputs)
    # every argument and output path is checked before the first line of output (compile checks
    # the strategy's names and numbers: --tol, --jobs)
    if args.json:
        _check_output_file("--json", args.json, (".json",))
    try:
        problem = compile_problem(mech, jobs=args.jobs, **{**_strategy(args), "system": args.system})
    except KeyboardInterrupt as exc:
        _write_unsearched(args.json, mech, values, exc)
        raise
    if args.plot:
        from .plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    unit = "deg" if args.degrees else "rad"
    shown = [math.degrees(v) if args.degrees else v for v in values]
    print(f"{mech.name or args.file}: direct kinematics at "
          + ", ".join(f"{n} = {format_number(v, '+.6g')} {unit}" for n, v in zip(mech.actuated, shown)), flush=True)
    progress = _Progress(sys.stderr.isatty(), quiet=args.quiet)
    try:
        report = problem.solve(values, progress=progress)
    except KeyboardInterrupt as exc:    # before the search could keep anything (a search keeps what it found)
        _write_unsearched(args.json, mech, values, exc)
        raise
    finally:
        progress.close()
    st = report.stats
    print(f"{report.count_text()}; passive joint angles in {'degrees' if args.degrees else 'radians'}:")
    print(report.table(degrees=args.degrees))
    used = report.settings
    print(f"{used.parameterization}, formulation {used.formulation}, pruner {used.pruner}"
          + (f" ({used.lp_backend or 'default backend'})" if used.pruner != "pp" else "")
          + f", tol {used.tol:g} rad: {st.charts} chart(s), {st.boxes_processed} boxes "
          f"({st.discarded} discarded, {st.split} split, {st.accepted} accepted, {st.isolated} isolated), "
          f"{st.lps_solved} LPs, {st.time_total:.3f} s")
    print(as_options(used.system_text(verbose=args.verbose)))
    if used.fallback:
        print(f"note: {as_options(used.fallback)}")
    limit = used.limit
    if limit and limit.interrupted:
        print(f"note: {as_options(limit.error)}: the entries above are what the search had found (polished and classified), "
              "not necessarily every solution")
    elif limit:
        print(f"note: {as_options(limit.error)}; the solution set was covered with boxes of {limit.covering_tol:g} rad "
              "instead (status continuum: its dimension and covering boxes are in the JSON evidence)")
    if used.refined_searches:
        print(f"note: {used.refined_searches} cluster(s) next to a singularity were searched again at "
              "a finer tolerance to separate their roots")
    if report.empty_reason is not None:
        print(f"note: {report.empty_reason.text()}")
    if args.json:
        import json  # only for --json (each import is paid by every process)

        from .mechanism.io import dumps_mechanism

        data = report.as_dict()
        data["mechanism_toml"] = dumps_mechanism(mech)
        atomic.write_text(args.json, json.dumps(data, indent=2))
        print(f"wrote {args.json}")
    if args.plot:
        from .plot import plot_solutions  # matplotlib: imported only when a plot is asked for

        plot_solutions(mech, values, report, args.plot, degrees=args.degrees)
        print(f"wrote {args.plot}")
    return 130 if limit and limit.interrupted else 0


def _write_unsearched(path, mech, values, exc: KeyboardInterrupt) -> None:
    """``solve --json``'s document when Ctrl-C (or SIGTERM, ``exc``) stopped the command before its
    search began (loading, compiling, setting up charts): nothing was searched, so no count and no
    solution, and the JSON says so (``searched``: false) rather than not being written (issue 42 item
    17). Nothing when no ``--json`` was asked for."""
    if not path:
        return
    import json

    from . import __version__
    from .mechanism.io import dumps_mechanism

    signal_name = str(exc) if isinstance(exc, Terminated) else "SIGINT"
    data = {"schema": "spherekin.solve/2", "spherekin_version": __version__,
            "settings": {"mechanism": mech.name, "actuated": list(mech.actuated), "inputs": [float(v) for v in values],
                         "limit": {"error": f"stopped by {signal_name} before the search began",
                                   "interrupted": True}},
            "searched": False, "unknowns": list(mech.loop_unknowns),
            "count": {"proven": None, "exact": False, "entries": 0}, "solutions": [],
            "mechanism_toml": dumps_mechanism(mech)}
    atomic.write_text(path, json.dumps(data, indent=2))
    print(f"wrote {path} (nothing searched)", file=sys.stderr)


# ------------------------------------------------------------------ families of inputs

#: A tracked pose and a solution of the full solve are the same assembly when their rotations (without an
#: output link: passive angles, radians) agree to this (largest entry): both are Newton limits accurate
#: to ~1e-14 (as problem.POSE_MATCH).
CHECK_MATCH = 1e-8
#: --home's joints off the plane must equal the plane's --fix readings to this (radians) for a free box
#: in the plane: the box is drawn and reported in that plane (a home elsewhere is --free all's); not 0:
#: the two options' degree conversions may differ in the last bit.
FIX_MATCH = 1e-9
#: Seconds between progress lines of a batch when stderr is not a terminal (a log): often enough to
#: see a job move, rarely enough that a run of hours leaves a log of a few hundred lines.
PROGRESS_INTERVAL = 10.0


class _BatchProgress:
    """Inputs done, rate and time left: one line redrawn on a terminal, a line every PROGRESS_INTERVAL
    seconds otherwise (a log)."""

    def __init__(self, terminal: bool, quiet: bool = False):
        self.terminal, self.t0, self.last, self.start_done = terminal, time.perf_counter(), 0.0, None
        self.quiet, self.pending = quiet, None

    def __call__(self, done: int, total: int) -> None:
        if self.quiet:
            return
        now = time.perf_counter()
        if self.start_done is None:
            self.start_done = done
        due = (now - self.last > 0.2) if self.terminal else (now - self.last >= PROGRESS_INTERVAL)
        # a job whose total grows (a branch map's refinements) reaches done == total once per round: on a
        # terminal the line is redrawn; a log gets it once, at close, not one line per round (issue 42 item 14)
        if not due and (done < total or not self.terminal):
            self.pending = (done, total)
            return
        self._draw(now, done, total)

    def _draw(self, now: float, done: int, total: int) -> None:
        self.last, self.pending = now, None
        elapsed = now - self.t0
        rate = (done - self.start_done) / elapsed if elapsed > 0 else 0.0
        eta = f"{(total - done) / rate:6.0f} s left" if rate > 0 and done < total else ""
        width = 30
        bar = "#" * int(width * done / max(total, 1))
        line = f"  [{bar:<{width}s}] {done}/{total} inputs ({100 * done / max(total, 1):5.1f}%)  {rate:7.1f}/s  {eta}"
        if self.terminal:
            print("\r" + line, end="", file=sys.stderr, flush=True)
        else:
            print(line.rstrip(), file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.quiet:
            return
        if self.pending is not None and not self.terminal:       # the last state, once
            self._draw(time.perf_counter(), *self.pending)
        if self.terminal and self.last:
            print(file=sys.stderr)


def _check_strategy(mech, args) -> None:
    """The strategy options, checked (by compiling the mechanism once here) before any output."""
    from .problem import compile as compile_problem

    compile_problem(mech, **_strategy(args))


def _strategy(args) -> dict:
    from .problem import DEFAULT_SYSTEM
    from .search.boxloop import MAX_TOL
    from .systems import ON_CAP_COVER

    if getattr(args, "degrees", False) and args.tol > MAX_TOL:    # the likeliest reading: a tolerance in degrees
        raise ValueError(f"--tol: expected at most {MAX_TOL:g} rad, got {args.tol:g}: --tol is in radians, also "
                         f"with --degrees ({args.tol:g} deg is {math.radians(args.tol):.3g} rad)")

    # --system only when asked for: the default strategy (and a batch's job name) stays as before
    chosen = {} if args.system == DEFAULT_SYSTEM else dict(system=args.system)
    if getattr(args, "on_cap", ON_CAP_COVER) != ON_CAP_COVER:
        chosen["on_cap"] = args.on_cap
    if getattr(args, "max_boxes", None) is not None:
        chosen["max_boxes"] = args.max_boxes
    return dict(formulation=args.formulation, pruner=args.pruner, lp_backend=args.lp_backend,
                parameterization=args.parameterization, tol=args.tol, isolate=not args.no_isolate, **chosen)


def _family_inputs(mech, args):
    from .batch import grid_inputs, read_inputs_csv

    if getattr(args, "inputs", None) and args.grid:
        raise ValueError("--inputs and --grid: expected one of them (a CSV file of inputs, or a grid)")
    if getattr(args, "inputs", None):
        if args.fix:
            raise ValueError("--fix: only with --grid (a CSV file gives every actuated joint a column)")
        return read_inputs_csv(mech, args.inputs, degrees=args.degrees)
    if not args.grid:
        raise ValueError("expected the inputs: --inputs FILE.csv or --grid name=lo:hi:n (with --fix for the others)")
    return grid_inputs(mech, args.grid, args.fix or (), degrees=args.degrees)


def _engine_note(summary) -> str:
    where = "in this process" if not summary.workers else f"on {summary.workers} Dask worker(s)"
    rate = summary.solved / summary.seconds if summary.seconds > 0 else 0.0
    return f"{summary.solved} input(s) solved {where} in {summary.seconds:.1f} s ({rate:.1f} per second)"


def _batch(args) -> int:
    from .batch import solve_to_file
    from .batch.sinks import check_output_path
    from .mechanism import load_mechanism

    mech = load_mechanism(args.file)
    inputs = _family_inputs(mech, args)
    check_output_path(args.out, args.resume, args.overwrite)
    _check_strategy(mech, args)
    print(f"{mech.name or args.file}: direct kinematics of {len(inputs)} input(s) ({inputs.source}) -> {args.out}"
          + (f" (--degrees: inputs read in degrees; {args.out} holds radians)" if args.degrees else ""))
    progress = _BatchProgress(sys.stderr.isatty(), quiet=args.quiet)
    try:
        summary = solve_to_file(mech, inputs, args.out, resume=args.resume, overwrite=args.overwrite,
                                scheduler=args.scheduler, workers=args.workers, chunk_size=args.chunk_size,
                                progress=progress, **_strategy(args))
    finally:
        progress.close()
    if summary.note:
        print(f"spherekin: note: {summary.note}", file=sys.stderr)
    if summary.skipped:
        print(f"{summary.skipped} input(s) were already in {args.out} (resumed)")
    print(f"{_engine_note(summary)}; {summary.written} row(s) written to {args.out}")
    if summary.interrupted:
        print(f"interrupted: {summary.skipped + summary.solved} of {summary.total} inputs are in {args.out}; "
              "run the same command with --resume to complete it", file=sys.stderr)
        return 130
    return 0


def _map(args) -> int:
    from .batch import assembly_map
    from .batch.sinks import check_output_path
    from .mechanism import load_mechanism

    mech = load_mechanism(args.file)
    if len(mech.actuated) == 1 or args.joint:   # one input: its branches and circuits
        return _branches(mech, args)
    if args.json:
        raise ValueError(f"--json: only for the branches of a mechanism with one actuated joint, got "
                         f"{len(mech.actuated)} ({', '.join(mech.actuated)}); --table writes a map of two inputs")
    if len(args.grid or ()) != 2:
        raise ValueError(f"--grid: a map needs exactly two grid axes (x, then y), got {len(args.grid or ())}")
    inputs = _family_inputs(mech, args)                     # every spec and range checked here
    if args.plot:
        from .plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    if args.out:
        check_output_path(args.out, args.resume, args.overwrite)
    if args.table and not str(args.table).lower().endswith(".csv"):
        raise ValueError(f"--table {args.table}: expected a .csv path")
    if args.table and not Path(args.table).resolve().parent.is_dir():
        raise ValueError(f"--table {args.table}: the directory does not exist")
    _check_strategy(mech, args)
    for option, value in (("--singular-tol", args.singular_tol), ("--singular-max-boxes", args.singular_max_boxes)):
        if value is not None and not args.singular:
            raise ValueError(f"{option}: only with --singular (the certified singular cells)")
    singular_tol = None
    if args.singular:
        from .singularities import SINGULAR_TOL, check_singular_tol

        singular_tol = check_singular_tol(SINGULAR_TOL if args.singular_tol is None else
                                          args.singular_tol * (math.pi / 180.0 if args.degrees else 1.0), "--singular-tol")
    x, y = inputs.axes
    print(f"{mech.name or args.file}: assembly-mode map over {x.name} x {y.name} "
          f"({len(x.values)} x {len(y.values)} inputs)"
          + ("" if singular_tol is None else f", with its certified singular set (cells <= {singular_tol:.3g} rad)"))
    progress = _BatchProgress(sys.stderr.isatty(), quiet=args.quiet)
    try:
        amap = assembly_map(mech, x, y, inputs.fixed, out=args.out, resume=args.resume, overwrite=args.overwrite,
                            scheduler=args.scheduler, workers=args.workers, chunk_size=args.chunk_size,
                            progress=progress, singular_tol=singular_tol,
                            singular_max_boxes=args.singular_max_boxes, **_strategy(args))
    finally:
        progress.close()
    print(amap.table())
    if args.table:
        atomic.write_text(args.table, amap.frame().to_csv(index=False))
        print(f"wrote {args.table}")
    if args.plot:
        from .plot import plot_assembly_map

        plot_assembly_map(amap, args.plot, degrees=args.degrees, measure=args.singularity)
        print(f"wrote {args.plot}")
    return 0


def _singular_names(args) -> dict[str, str]:
    """singular's Python names that are not its options' destinations: ``fixed`` is --fix."""
    return {"fixed": "--fix"}


def _singular(args) -> int:
    """``spherekin singular``: the certified parallel-singular set in a plane (or line) of inputs."""
    import json
    import math

    from .batch.inputs import parse_fix, parse_range
    from .mechanism import load_mechanism
    from .singularities import singular

    mech = load_mechanism(args.file)
    scale = math.pi / 180.0 if args.degrees else 1.0
    x = parse_range(args.x, "--x", degrees=args.degrees)
    y = parse_range(args.y, "--y", degrees=args.degrees) if args.y else None
    fixed: dict[str, float] = {}
    for spec in args.fix or ():
        name, value = parse_fix(spec, degrees=args.degrees)
        if name in fixed:
            raise ValueError(f"--fix {name}: given twice")
        fixed[name] = value
    if args.json:
        _check_output_file("--json", args.json, (".json",))
    if args.plot:
        from .plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    if (args.home is None) != (args.start_solution is None):
        raise ValueError("--home and --start-solution: expected both (the free box of solution K at home) or neither")
    home = None
    if args.home is not None:
        home = _parse_angles("--home", args.home, mech.actuated, args.degrees, "one per actuated joint")
        if args.free == "plane":
            for name, value in fixed.items():
                if abs(home[mech.actuated.index(name)] - value) > FIX_MATCH:
                    raise ValueError(f"--home: expected {name} = {value * (180 / math.pi if args.degrees else 1):.6g} "
                                     f"(the plane's --fix) for a free box in the plane, got "
                                     f"{home[mech.actuated.index(name)] * (180 / math.pi if args.degrees else 1):.6g} "
                                     "(or use --free all)")
        from .problem import compile as compile_problem

        problem = compile_problem(mech)
        n = len(problem.solve(home).solutions)         # milliseconds: checked before the cover's work
        if args.start_solution > n:
            raise ValueError(f"--start-solution: expected a solution number 1..{n} of the solve at --home "
                             f"({n} solution(s)), got {args.start_solution}")
    caps = {} if args.max_boxes is None else {"max_boxes": args.max_boxes}
    if args.mode_change and y is None:
        raise ValueError("--mode-change: expected a plane of two inputs (--y), got a line")
    from .budget import Budget

    if args.max_memory is not None and not (math.isfinite(args.max_memory) and args.max_memory > 0):
        raise ValueError(f"--max-memory: expected a positive number of GiB, got {args.max_memory!r}")
    budget = Budget() if args.max_memory is None else Budget(int(args.max_memory * 2 ** 30))
    with _signals_stop(budget) as signalled:
        sset = singular(mech, x, y, fixed, tol=args.tol * scale, budget=budget, **caps)   # every check before any work
    if signalled:                         # Ctrl-C or SIGTERM: report what was found, nothing more
        home, args.mode_change = None, False
    if home is not None:
        plane_inputs = (x[0],) if y is None else (x[0], y[0])
        window = {a[0]: (a[1], a[2]) for a in ((x,) if y is None else (x, y))}   # drawn in the plane: bound by it
        box = problem.free_box(home, start=args.start_solution - 1, bounds=window,
                               inputs=plane_inputs if args.free == "plane" else None, shape=args.free_shape)
        sset = dataclasses.replace(sset, free_box={**box.as_dict(), "start_solution": args.start_solution})
    if args.mode_change:
        from .singularities import mode_change

        sset = dataclasses.replace(sset, mode_change=mode_change(mech, sset))
    unit, show = ("deg", 180.0 / math.pi) if args.degrees else ("rad", 1.0)
    plane = x[0] if y is None else f"{x[0]} x {y[0]}"
    at = ", ".join(f"{k} = {v * show:.6g}" for k, v in fixed.items())
    print(f"{mech.name or args.file}: parallel singular set over {plane}" + (f" ({at})" if at else "")
          + f", cells <= {args.tol:.6g} {unit} ({sset.system} system)")
    print(f"{'status':<12} {'boxes':>7}")
    for status, n in sset.counts().items():
        print(f"{status:<12} {n:>7}")
    if sset.cusp_search == "searched":
        kinds = {k: sum(c.status == k for c in sset.cusps) for k in ("cusp", "unresolved")}
        print(f"cusps: {kinds['cusp']} proven, {kinds['unresolved']} unresolved")
    elif sset.cusp_search == "none_possible":
        print("cusps: none possible (one loop: its 3 passive joints have at most 2 assemblies, or a continuum)")
    elif sset.cusp_search == "not_searched":
        print("cusps: not searched " + ("(the run was stopped first)" if sset.stopped and sset.system == "platform" else
                                        "(the loop equations of several loops: only the platform system searches them)"))
    st = sset.stats
    if sset.cross_check is not None:
        print(sset.cross_check.text())
    why = (f"{sset.stopped}: the unprocessed part is unresolved" if sset.stopped else "the cross-check disagrees")
    print(f"complete: {'yes' if sset.complete else f'no ({why})'}; "
          f"boxes processed {st.boxes_processed}, {st.seconds:.2f} s")
    if st.crowded:
        print(f"crowded: {st.crowded} boxes set aside where the cover crowds (e.g. a continuum of singular "
              "configurations over one input): unresolved regions, not refined")
    if sset.free_box is not None:
        fb = sset.free_box
        sides = ", ".join(f"{k} [{lo * show:.6g}, {hi * show:.6g}]" for k, (lo, hi) in fb["inputs"].items())
        print(f"free box of solution {args.start_solution} at home: {sides} {unit} "
              f"({'proven' if fb['proven'] else 'none proven'}; {fb['cells']} cells; cube radius "
              f"{fb['radius'] * show:.6g} {unit}, limit: {fb['limit']})")
        if fb["shape"] == "box":
            at = {f"{f['input']} {f['side']}": fb["inputs"][f["input"]][0 if f["side"] == "lo" else 1] for f in fb["faces"]}
            print("  faces: " + ", ".join(f"{f['input']} {f['side']} = {at[f['input'] + ' ' + f['side']] * show:.6g} "
                                          f"({f['extent'] * show:.6g} from home; {f['limit']})" for f in fb["faces"]))
    if sset.mode_change is not None:
        mc = sset.mode_change
        if mc.found:
            print(f"mode change: solution {mc.start_solution} -> {mc.end_solution} around the cusp at "
                  f"({mc.cusp[0] * show:.6g}, {mc.cusp[1] * show:.6g}) {unit}, radius {mc.radius * show:.6g} {unit}, "
                  f"{mc.proven_steps} proven steps")
        else:
            print(f"mode change: none found (searched {mc.searched})")
    if args.json:
        doc = {**sset.as_dict(), "mechanism": mech.name or str(args.file)}
        atomic.write_text(args.json, json.dumps(doc, indent=2))
        print(f"wrote {args.json}")
    if args.plot:
        from .plot import plot_singular

        plot_singular(sset, args.plot, degrees=args.degrees)
        print(f"wrote {args.plot}")
    if signalled:
        written = [p for p in (args.json, args.plot) if p]
        print(f"spherekin: {'interrupted' if signalled[0] == 'SIGINT' else 'terminated'} ({signalled[0]}) after "
              f"{st.boxes_processed} boxes: the result is incomplete"
              + (f" ({', '.join(written)} written)" if written else ""), file=sys.stderr)
        return INTERRUPT_STATUS if signalled[0] == "SIGINT" else SIGTERM_STATUS
    return 0


@contextmanager
def _signals_stop(budget):
    """While a long search runs: the first Ctrl-C (SIGINT) or SIGTERM asks ``budget`` to stop (the search hands
    over what it found, which is then reported and written); a second one ends the command at once
    (KeyboardInterrupt or :class:`Terminated`). Yields the list of the signals' names received. The handlers
    found are restored afterwards. Main thread only."""
    import signal
    import threading

    got: list[str] = []
    if threading.current_thread() is not threading.main_thread():
        yield got
        return

    def handler(signum, frame):
        name = "SIGINT" if signum == signal.SIGINT else "SIGTERM"
        if got:
            raise KeyboardInterrupt() if signum == signal.SIGINT else Terminated(name)
        got.append(name)
        budget.stop(name)

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield got
    finally:
        for sig, h in previous.items():
            signal.signal(sig, h)


#: map's options that draw a map of two inputs, not the branches of one (refused there by name).
_TWO_INPUT_MAP_OPTIONS = (("fix", "--fix"), ("table", "--table"), ("out", "--out"), ("singularity", "--singularity"),
                          ("singular", "--singular"), ("singular_tol", "--singular-tol"),
                          ("singular_max_boxes", "--singular-max-boxes"),
                          ("resume", "--resume"), ("overwrite", "--overwrite"), ("scheduler", "--scheduler"),
                          ("workers", "--workers"), ("chunk_size", "--chunk-size"))


def _branches(mech, args) -> int:
    """``spherekin map`` of a mechanism with one actuated joint: its branches and circuits over that
    input (:mod:`spherekin.batch.branches`)."""
    import json

    from .batch.branches import branch_map, check_one_input

    name = check_one_input(mech, "--joint" if args.joint else args.file)
    for attr, option in _TWO_INPUT_MAP_OPTIONS:
        if getattr(args, attr):
            raise ValueError(f"{option}: only for a map of two inputs; this mechanism has one actuated joint "
                             f"({name}): map draws its branches (--grid, --joint, --json, --plot)")
    if len(args.grid or ()) > 1:
        raise ValueError(f"--grid: the branches of a one-input mechanism take one grid axis ({name}=lo:hi:n), "
                         f"got {len(args.grid)}")
    grid = None
    if args.grid:
        from .batch.inputs import parse_grid

        grid = parse_grid(args.grid[0], degrees=args.degrees)
    if args.json:
        _check_output_file("--json", args.json, (".json",))
    if args.plot:
        from .plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    _check_strategy(mech, args)
    progress = _BatchProgress(sys.stderr.isatty(), quiet=args.quiet)
    try:
        bmap = branch_map(mech, grid, joint=args.joint, progress=progress, **_strategy(args))   # checks first
    finally:
        progress.close()
    print(f"{mech.name or args.file}: branches and circuits over {name}")
    print(bmap.report(degrees=args.degrees))
    if args.json:
        atomic.write_text(args.json, json.dumps(bmap.as_dict(), indent=2))
        print(f"wrote {args.json}")
    if args.plot:
        from .plot import plot_branches

        plot_branches(bmap, args.plot, degrees=args.degrees)
        print(f"wrote {args.plot}")
    return 0


def _parse_numbers(key: str, text: str, n: int) -> list[float]:
    from .mechanism.checks import check_ascii

    check_ascii(key, text)                      # float() reads the digits of other scripts too
    try:
        values = [float(v) for v in text.replace(" ", ",").split(",") if v]
    except ValueError:
        raise ValueError(f"{key}: expected {n} comma-separated numbers, got {text!r}") from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{key}: expected {n} finite comma-separated numbers, got {text!r}")
    return values


def _ik(args) -> int:
    import numpy as np

    from .core.orientation import quaternions_from_rotations, rotation_from_euler, rotation_from_quaternion
    from .results import format_number
    from .mechanism import load_mechanism
    from .mechanism.checks import check_rotation

    given = [k for k in ("rotation", "quaternion", "euler") if getattr(args, k) is not None]
    if len(given) != 1:
        raise ValueError("expected the pose as exactly one of --rotation, --quaternion, --euler")
    if args.convention and args.euler is None:
        raise ValueError("--convention: only with --euler")
    mech = load_mechanism(args.file)
    if args.json:
        _check_output_file("--json", args.json, (".json",))
    if args.rotation is not None:
        rot = check_rotation("--rotation", np.array(_parse_numbers("--rotation", args.rotation, 9)).reshape(3, 3))
    elif args.quaternion is not None:
        rot = rotation_from_quaternion(_parse_numbers("--quaternion", args.quaternion, 4), "--quaternion")
    else:
        angles = _parse_angles("--euler", args.euler, ("a", "b", "c"), args.degrees, "three Euler angles")
        rot = rotation_from_euler(angles, args.convention or "ZYX", "--euler")
    from .problem import inverse_kinematics

    # numbered over every solution, then filtered: a solution keeps its number with --in-range
    every = list(enumerate(inverse_kinematics(mech, rot), start=1))
    numbered = [(k, s) for k, s in every if s.in_range or not args.in_range]
    sols = [s for _, s in every]
    scale, unit = (180.0 / math.pi, "degrees") if args.degrees else (1.0, "radians")
    q = quaternions_from_rotations(rot)
    print(f"{mech.name or args.file}: inverse kinematics at the {'platform' if mech.output == 'platform' else mech.output} "
          f"pose with quaternion w, x, y, z = {', '.join(format_number(c) for c in q)}"
          + ("" if mech.legs else " (solved on the loop equations: the output held, the inputs unknown)"))
    names = list(mech.actuated) + list(mech.passive)
    n_in = sum(s.in_range for s in sols)
    print(f"{len(sols)} solution(s) (working modes), {n_in} inside every joint range; joint angles in {unit}:")
    print("  #  mode  " + " ".join(f"{n:>11s}" for n in names) + "  in range" + ("" if mech.legs else "  status"))
    for k, s in numbered:
        mode = "".join("+" if m > 0 else "-" if m < 0 else "0" for m in s.working_mode) or "-"
        print(f"{k:3d}  {mode:>4s}  " + " ".join(format_number(s.joint_angles[n] * scale, "+11.6f") for n in names)
              + f"  {'yes' if s.in_range else 'no':>8s}" + ("" if s.status is None else f"  {s.status}"))
    if args.json:
        import json

        out = {"schema": "spherekin.ik/1", "mechanism": mech.name, "platform_rotation": rot.tolist(),
               "quaternion": q.tolist(),
               "solutions": [{"number": k, "working_mode": list(s.working_mode),       # numbered as printed
                              "inputs": dict(zip(mech.actuated, s.inputs)), "joint_angles": dict(s.joint_angles),
                              "in_range": s.in_range, "status": s.status} for k, s in numbered]}
        atomic.write_text(args.json, json.dumps(out, indent=2))
        print(f"wrote {args.json}")
    return 0


def _track(args) -> int:
    import numpy as np

    from .batch import read_inputs_csv
    from .core.orientation import quaternions_from_rotations, rotation_from_quaternion
    from .mechanism import load_mechanism
    from .mechanism.checks import check_rotation
    from .problem import compile as compile_problem
    from .results import format_number

    given = [k for k in ("start_rotation", "start_quaternion", "start_solution") if getattr(args, k) is not None]
    if len(given) != 1:
        raise ValueError("expected the start as exactly one of --start-rotation, --start-quaternion, --start-solution")
    mech = load_mechanism(args.file)
    path = read_inputs_csv(mech, args.path, degrees=args.degrees, key="--path")
    if args.start_rotation is not None:
        start = check_rotation("--start-rotation",
                               np.array(_parse_numbers("--start-rotation", args.start_rotation, 9)).reshape(3, 3))
    elif args.start_quaternion is not None:
        start = rotation_from_quaternion(_parse_numbers("--start-quaternion", args.start_quaternion, 4),
                                         "--start-quaternion")
    else:
        start = None        # --start-solution K (1..MAX_ASSEMBLIES, checked as read): below, after compiling
    if args.out:
        from .batch.sinks import check_output_path   # its locks and fingerprints: only for a written table

        check_output_path(args.out, False, True)
    if args.json:
        _check_output_file("--json", args.json, (".json",))
    if args.plot:
        from .plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    problem = compile_problem(mech)
    if args.start_solution is not None:          # numbered from 1, as solve prints them, the JSON and the CSV
        solutions = problem.solve(path.values[0]).solutions
        if args.start_solution > len(solutions):
            raise ValueError(f"--start-solution: expected a solution number 1..{len(solutions)} of the solve at "
                             f"the first input ({len(solutions)} solution(s)), got {args.start_solution}")
        start = solutions[args.start_solution - 1]
    print(f"{mech.name or args.file}: tracking one assembly mode along {len(path)} input(s) of {args.path}")
    t0 = time.perf_counter()
    track = problem.track(path.values, start=start)
    seconds = time.perf_counter() - t0
    scale, unit = (180.0 / math.pi, "degrees") if args.degrees else (1.0, "radians")
    names = list(track.actuated) + list(track.passive_joints)
    print(f"{len(track.poses)} of {len(path)} row(s) tracked, {track.proven_steps} proven step(s) "
          f"({track.rejected_steps} rejected), {seconds:.3f} s; joint angles in {unit}:")
    print("  row  " + " ".join(f"{n:>11s}" for n in names)
          + "   qw        qx        qy        qz     parallel_measure")
    quats = quaternions_from_rotations(track.rotations)
    for p, q in zip(track.poses, quats):
        vals = list(p.inputs.values()) + list(p.passive_angles.values())
        print(f"{p.row:5d}  " + " ".join(format_number(v * scale, "+11.6f") for v in vals)
              + "  " + " ".join(format_number(c) for c in q) + f"  {p.parallel_measure:16.4e}")
    st = track.stop
    if st is not None:
        last = ", ".join(format_number(v * scale, "+.12g") for v in st.last_proven_inputs.values())
        print(f"stopped between rows {st.between_rows[0]} and {st.between_rows[1]}: {st.reason}. ", end="")
        if st.kind == "range":
            print(f"Last input in range {last} ({st.fraction:.6g} of the way), {st.joint} = "
                  f"{st.joint_angle * scale:+.9g} {unit} there; it leaves within {st.bracket:.1e} rad of input "
                  f"further; parallel_measure there {st.parallel_measure:.3g}")
        else:
            print(f"Last proven input {last} ({st.fraction:.6g} of the way); the singular input, located by "
                  f"bisection to {st.bracket:.1e} rad: "
                  f"{', '.join(format_number(v * scale, '+.12g') for v in st.singular_inputs.values())} ({st.distance:.2e} rad "
                  f"further); parallel_measure at the last proven pose {st.parallel_measure:.3g}")
    data = track.as_dict()
    code = 0
    if args.check is not None:
        rows = sorted({*range(0, len(track.poses), args.check), len(track.poses) - 1})
        bad = []
        for k in rows:
            report = problem.solve(list(track.poses[k].inputs.values()))
            if not any(_same_assembly(s, track.poses[k]) for s in report.solutions):
                bad.append(k)
        data["check"] = {"rows": rows, "mismatched_rows": bad, "passed": not bad}
        if bad:
            print(f"check: the tracked pose is NOT among the solutions of the full solve at row(s) "
                  f"{', '.join(map(str, bad))}", file=sys.stderr)
            code = 1
        else:
            print(f"check: at {len(rows)} row(s) the tracked pose is one of the solutions of the full solve")
    if args.json:
        import json

        atomic.write_text(args.json, json.dumps(data, indent=2))
        print(f"wrote {args.json}")
    if args.out:
        from .batch.rows import track_table
        from .batch.sinks import open_sink

        with open_sink(args.out, mech, path.values[:len(track.poses)], resume=False) as sink:
            sink.write(0, len(track.poses), track_table(mech, track))
        print(f"wrote {args.out}")
    if args.plot:
        from .plot import plot_track

        plot_track(track, args.plot, degrees=args.degrees)
        print(f"wrote {args.plot}")
    return code


def _same_assembly(solution, pose) -> bool:
    """Whether a solution of the full solve is the tracked ``pose``: their rotations agree to
    CHECK_MATCH, or, without an output link, their passive angles do (modulo 2 pi)."""
    import numpy as np

    from .core.angles import wrap

    if pose.platform_rotation is not None:
        return (solution.platform_rotation is not None
                and np.abs(solution.platform_rotation - pose.platform_rotation).max() <= CHECK_MATCH)
    got = solution.passive_angles
    return all(abs(wrap(got[n] - v)) <= CHECK_MATCH for n, v in pose.passive_angles.items())


def _no_names(args) -> dict[str, str]:
    """A command whose errors' Python names do not depend on the options given."""
    return {}


def _track_names(args) -> dict[str, str]:
    """The Python names of track's errors that depend on the options given: ``start`` is the start
    option typed (with --start-solution the command hands Problem.track the Solution itself, whose
    messages carry no index)."""
    given = [o for o in ("start_rotation", "start_quaternion", "start_solution") if getattr(args, o, None) is not None]
    return {"start": "--" + given[0].replace("_", "-")} if len(given) == 1 else {}


def _add_engine_options(p) -> None:
    p.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://HOST:8786); default: an "
                                       "embedded local cluster (in this process for a handful of inputs)")
    p.add_argument("--workers", type=_whole(0, why=" (0: in this process)"),
                   help="worker processes of the embedded cluster (default: one per core; 0: in this process)")
    p.add_argument("--chunk-size", type=_whole(1), help="inputs per Dask task (default: up to 256, "
                   "fewer so that every worker gets several)")
    p.add_argument("--resume", action="store_true", help="complete a partial output without redoing finished inputs")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")


def _add_grid_options(p) -> None:
    p.add_argument("--grid", action="append", metavar="NAME=LO:HI:N",
                   help="sweep an actuated joint over N points from LO to HI (both included; e.g. beta1=-pi:pi:64); "
                        "repeat for each swept joint, the first varies slowest")
    p.add_argument("--fix", action="append", metavar="NAME=VALUE", help="hold an actuated joint at VALUE")
    p.add_argument("--degrees", action="store_true",
                   help="input angles (and printed angles) in degrees; written tables stay in radians")


def _verify(args) -> int:
    """Run ``python -m verification`` of the source checkout this package lives in.

    The verification (sympy, an independent geometric model) is not part of the package: it checks
    the paper and the package from outside. So the package never imports it; this command runs it
    as its own process when the checkout has it, and says where it lives otherwise.
    """
    import subprocess

    root = Path(__file__).resolve().parent.parent
    if not (root / "verification" / "__main__.py").is_file():
        print("spherekin: error: 'spherekin verify' runs the verification/ directory of a source checkout of "
              f"spherekin, and there is none next to this installation ({root}); clone the repository and run "
              "'make verify' (or 'python -m verification') there", file=sys.stderr)
        return 2
    argv = (["--quick"] if args.quick else []) + (["--report", args.report] if args.report else [])
    return subprocess.run([sys.executable, "-m", "verification", *argv], cwd=root).returncode


def _terminal_columns(fallback: int = 80) -> int:
    """Columns of the terminal, as :func:`shutil.get_terminal_size` reads them: $COLUMNS, else the
    terminal of ``sys.__stdout__``, else ``fallback``."""
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns or fallback


class _HelpFormatter(argparse.HelpFormatter):
    """argparse's help formatter with the width read by :func:`_terminal_columns`.

    argparse builds a formatter for every option added (to check its metavar), and its default
    width imports shutil (with bz2, lzma, zlib: ~1.5 ms, paid by every process, benchmarks/bench_process.py)
    only to read the terminal's width; the help printed is the same.
    """

    def __init__(self, prog, indent_increment=2, max_help_position=24, width=None):
        super().__init__(prog, indent_increment, max_help_position,
                         _terminal_columns() - 2 if width is None else width)


#: The start of every error the command line prints: its own checks, the package's ValueErrors and
#: argparse's usage errors alike, each one line, exit status 2.
ERROR_PREFIX = "spherekin: error: "

#: What `spherekin --help` says spherekin is (the commands follow, listed by argparse).
DESCRIPTION = ("Direct kinematics of parallel spherical mechanisms with Bernstein polynomials: every "
               "assembly of a mechanism inside its joint ranges, each one proven.")


class _Parser(argparse.ArgumentParser):
    """argparse's parser with spherekin's one error format: a usage error is the line
    "spherekin: error: --option: expected ..., got ... (see spherekin COMMAND --help)", exit status 2,
    instead of argparse's usage block and its "spherekin COMMAND: error:" line. The command parsers
    are of this class too (add_subparsers makes its parsers of the parser's own class)."""

    def add_subparsers(self, **kwargs):
        self._commands = super().add_subparsers(**kwargs)
        return self._commands

    def command(self, name: str | None) -> "_Parser":
        """The parser of command ``name`` (this parser when it has no such command)."""
        commands = getattr(self, "_commands", None)
        return commands.choices.get(name, self) if commands is not None and name else self

    def parse_args(self, args=None, namespace=None):
        # argparse reports a command's stray arguments from the top parser; the command's own parser
        # says it here, so that the hint names the command's --help
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            self.command(getattr(namespace, "command", None)).error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace

    def error(self, message):
        self.exit(2, f"{ERROR_PREFIX}{self.usage_error(message)} (see {self.prog} --help)\n")

    def options(self) -> dict[str, str]:
        """Python name -> the option that sets it, as typed (its long form), for every option of this
        parser: ``workers`` -> "--workers", ``chunk_size`` -> "--chunk-size" (each command its own)."""
        return {a.dest: max(a.option_strings, key=len) for a in self._actions if a.option_strings}

    def usage_error(self, message: str) -> str:
        """argparse's error ``message`` in spherekin's words: "argument --jobs: invalid int value:
        'x'" -> "--jobs: expected a whole number, got 'x'"; the command list for a missing or unknown
        command. Messages it does not know are kept."""
        commands = getattr(self, "_commands", None)
        names = ", ".join(commands.choices) if commands is not None else ""
        m = re.fullmatch(r"argument (?P<name>[^:]+): (?P<rest>.*)", message, re.S)
        if m:
            name, rest = m["name"].split("/")[-1], m["rest"]
            choice = re.fullmatch(r"invalid choice: (?P<value>.+?) \(choose from (?P<choices>.*)\)", rest, re.S)
            if commands is not None and name in (commands.dest, commands.metavar) and choice:
                return f"{choice['value']} is not a command; expected one of {names}"
            for pattern, words in ((r"invalid int value: (.+)", "expected a whole number, got {}"),
                                   (r"invalid float value: (.+)", "expected a number, got {}"),
                                   (r"expected one argument", "expected a value"),
                                   (r"expected (\d+) arguments?", "expected {} values"),
                                   (r"ignored explicit argument (.+)", "takes no value, got {}")):
                found = re.fullmatch(pattern, rest, re.S)
                if found:
                    rest = words.format(*found.groups())
                    break
            if choice:
                rest = (f"expected one of {', '.join(c.strip(chr(39)) for c in choice['choices'].split(', '))}, "
                        f"got {choice['value']}")
            return f"{name}: {rest}"
        m = re.fullmatch(r"the following arguments are required: (?P<names>.*)", message, re.S)
        if m:
            missing = m["names"].split(", ")
            if commands is not None and (commands.dest in missing or commands.metavar in missing):
                return f"expected a command, one of {names}"
            return f"{' and '.join(missing)}: required, not given"
        m = re.fullmatch(r"unrecognized arguments: (?P<args>.*)", message, re.S)
        if m:
            return f"{m['args']}: not an option or argument of {self.prog}"
        m = re.fullmatch(r"ambiguous option: (?P<option>\S+) could match (?P<matches>.*)", message, re.S)
        if m:
            return f"{m['option']}: ambiguous, could be {m['matches']}"
        return message


def _whole(minimum: int, maximum: int | None = None, why: str = ""):
    """The argparse type of a whole-number option: an int in [minimum, maximum] or the usage error
    "expected a whole number >= minimum{why}, got ..." (read with the other options: before any work)."""
    def whole(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum or (maximum is not None and value > maximum):
            span = f">= {minimum}" if maximum is None else f"from {minimum} to {maximum}"
            raise argparse.ArgumentTypeError(f"expected a whole number {span}{why}, got {text!r}")
        return value

    return whole


def _add_strategy_options(so) -> None:
    """The strategy options of solve, batch and map (choices read from the registries)."""
    from .search.lp_backends import LP_BACKENDS, REJECTED_LP_BACKENDS
    from .search.parameterizations import PARAMETERIZATIONS
    from .problem import DEFAULT_FORMULATION, DEFAULT_SYSTEM, formulation_choices
    from .search.pruners import PRUNERS
    from .systems import ON_CAP_CHOICES, ON_CAP_COVER, SYSTEMS, system_choices
    from .search.boxloop import DEFAULT_MAX_BOXES, DEFAULT_PARAMETERIZATION, DEFAULT_PRUNER, DEFAULT_TOL

    so.add_argument("--parameterization", default=DEFAULT_PARAMETERIZATION, choices=list(PARAMETERIZATIONS),
                    help="variables of the loop equations: tan-half: t = tan(theta/2), the paper's (charts for "
                         "full ranges); sin-cos: c = cos, s = sin with c^2 + s^2 = 1 (Section 5; one chart). "
                         "Default %(default)s")
    so.add_argument("--system", default=DEFAULT_SYSTEM, choices=system_choices(),
                    help="the system of equations, fastest first: "
                         + "; ".join(f"{name}: {cls.description}" for name, cls in SYSTEMS.items())
                         + "; auto: the first that accepts the mechanism (the report says why the faster ones "
                           "did not). Default %(default)s")
    so.add_argument("--formulation", default=DEFAULT_FORMULATION, choices=formulation_choices(),
                    help="platform: one equation per leg in the platform's orientation (quaternion charts; "
                         "3-RRR legs); paper: Eq. (10) only; transversal: three entries of F (simple roots) + "
                         "Eq. (10); halves: three entries of F + the loop closed in the middle, P = S^T; auto: "
                         "platform where it applies, else halves. Default %(default)s")
    so.add_argument("--pruner", default=DEFAULT_PRUNER, choices=list(PRUNERS),
                    help="pp: projected polyhedron, no LP; hybrid: pp, LPs where it stalls; "
                         "lp: the Eq. (12) linear programs on every box. Default %(default)s")
    so.add_argument("--lp-backend", default=None, choices=_Choices(LP_BACKENDS, REJECTED_LP_BACKENDS),
                    help=f"LP backend ({'; '.join(f'{n}: default {c.default_lp_backend}' for n, c in PRUNERS.items() if c.default_lp_backend)}); paper-faithful: clarabel"
                         + (f"; {', '.join(REJECTED_LP_BACKENDS)}: measured and refused (the error says why)"
                            if REJECTED_LP_BACKENDS else ""))
    so.add_argument("--tol", type=float, default=DEFAULT_TOL, help="tolerance in radians (default %(default)g)")
    so.add_argument("--max-boxes", type=_whole(1), default=None, metavar="N",
                    help=f"box cap of one input's search (default {DEFAULT_MAX_BOXES}); see --on-cap")
    so.add_argument("--on-cap", default=ON_CAP_COVER, choices=list(ON_CAP_CHOICES),
                    help="a search that reaches its box cap: cover: cover the solutions at a coarser tolerance "
                         "(a continuum), the count not proven and the line saying so; raise: stop with the "
                         "error. Default %(default)s")
    so.add_argument("--no-isolate", action="store_true",
                    help="subdivide every box down to the tolerance (no Krawczyk isolation; the paper's behaviour)")


def build_parser() -> argparse.ArgumentParser:
    from . import __version__
    from .paper_gosselin import DEFAULT_PASSIVE_RANGE
    from .singularities import SINGULAR_TOL
    from .systems.platform import MAX_ASSEMBLIES

    parser = _Parser(prog="spherekin", description=DESCRIPTION, formatter_class=_HelpFormatter,
                     epilog="'spherekin COMMAND --help' gives the options of a command; docs/howto/ has examples.")
    parser.add_argument("--version", action="version", version=f"spherekin {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, title="commands", metavar="COMMAND")

    def sub_add_parser(name, **kw):
        return commands.add_parser(name, formatter_class=_HelpFormatter, **kw)

    so = sub_add_parser("solve", help="direct kinematics of a mechanism file (all solutions in range)")
    so.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    so.add_argument("--inputs", required=True, help="actuator inputs, comma-separated (radians unless --degrees; "
                                                      "text such as pi/2 too)")
    so.add_argument("--degrees", action="store_true", help="inputs and printed angles in degrees")
    _add_strategy_options(so)
    so.add_argument("--jobs", type=_whole(1), default=1,
                    help="Dask worker processes over the charts of the loop equations, on a local cluster "
                         "(~2-3 s to start: for long solves; default %(default)s)")
    so.add_argument("--json", help="write the report (solutions, rotations, statistics) as JSON")
    so.add_argument("--plot", help="draw every solution on the unit sphere, one panel each (.png, .pdf or .svg)")
    so.add_argument("--quiet", action="store_true", help="no progress on stderr")
    so.add_argument("-v", "--verbose", action="store_true",
                    help="also say why each faster system did not accept the mechanism (always in the JSON)")
    so.set_defaults(func=_solve)
    ik = sub_add_parser("ik", help="inverse kinematics: every actuator solution of a platform pose")
    ik.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    ik.add_argument("--rotation", help="the platform rotation R, 9 numbers row-major (v_i = R v_i^0)")
    ik.add_argument("--quaternion", help="the platform rotation as a quaternion w,x,y,z (normalized first)")
    ik.add_argument("--euler", help="the platform rotation as three Euler angles a,b,c (radians unless "
                                     "--degrees; text such as pi/2 too)")
    ik.add_argument("--convention", help="Euler convention: upper case intrinsic (ZYX, the default; ZYZ, ...), "
                                         "lower case extrinsic (xyz, ...)")
    ik.add_argument("--degrees", action="store_true", help="Euler angles and printed angles in degrees")
    ik.add_argument("--in-range", action="store_true", help="only the solutions inside every joint range")
    ik.add_argument("--json", help="write the solutions as JSON")
    ik.set_defaults(func=_ik)
    b = sub_add_parser("batch", help="direct kinematics of many inputs (CSV or grid), on Dask, to Parquet or CSV")
    b.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    b.add_argument("--inputs", help="CSV file of inputs: a header naming the actuated joints, one row per input")
    _add_grid_options(b)
    b.add_argument("--out", required=True, help="results: a .parquet dataset (directory) or a .csv file, one row "
                                                "per solution (docs/results-format.md)")
    _add_engine_options(b)
    _add_strategy_options(b)
    b.set_defaults(func=_batch)
    mp = sub_add_parser("map", help="number of assembly modes over a 2-D grid of inputs, drawn as a map; "
                                    "one actuated joint: branches and circuits over its input")
    mp.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    _add_grid_options(mp)
    mp.add_argument("--plot", help="draw the map (.png, .pdf or .svg)")
    mp.add_argument("--singularity", action="store_true",
                    help="second panel: the smallest normalized parallel-singularity measure over the solutions "
                         "(numeric, per grid point; for the certified singular cells see --singular)")
    mp.add_argument("--singular", action="store_true",
                    help="also compute the certified parallel-singular set of the map's plane (as the singular "
                         "command does over the grid's ranges) and draw its cells over the colours: singular "
                         "filled, unresolved hatched (not the numeric --singularity panel)")
    mp.add_argument("--singular-tol", type=float, default=None, metavar="T",
                    help="with --singular: width bound of its cells (radians; degrees with --degrees; "
                         f"default: {SINGULAR_TOL})")
    mp.add_argument("--singular-max-boxes", type=_whole(1), default=None, metavar="N",
                    help="with --singular: cap on the boxes its cover processes (reached: the rest is unresolved)")
    mp.add_argument("--table", help="write the map, one row per grid point, as CSV")
    mp.add_argument("--out", help="also write the results table (one row per solution; .parquet or .csv)")
    mp.add_argument("--joint", help="one actuated joint: the passive joint whose angle the branches report and draw "
                                     "(default: the first passive joint)")
    mp.add_argument("--json", help="one actuated joint: write the branches, branch points and circuits as JSON")
    _add_engine_options(mp)
    _add_strategy_options(mp)
    mp.set_defaults(func=_map)
    sg = sub_add_parser("singular", help="the certified parallel (Type-2) singular set in a plane of two inputs "
                                         "(or on the line of one): cells proven singular or unresolved")
    sg.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    sg.add_argument("--x", required=True, metavar="NAME=LO:HI", help="the plane's first input and its range, "
                                                                      "e.g. beta1=-pi:pi")
    sg.add_argument("--y", metavar="NAME=LO:HI", help="the plane's second input and its range (omit: a line)")
    sg.add_argument("--fix", action="append", metavar="NAME=VALUE", help="hold an actuated joint at VALUE "
                                                                          "(every joint off the plane)")
    sg.add_argument("--tol", type=float, default=1e-2, metavar="T",
                    help="width bound of the cells (radians; degrees with --degrees; default: %(default)s)")
    sg.add_argument("--max-boxes", type=_whole(1), default=None, metavar="N",
                    help="cap on the boxes the cover processes (reached: the rest is reported unresolved)")
    sg.add_argument("--max-memory", type=float, default=None, metavar="GB",
                    help="cap on the process's memory (GiB; default: 3/4 of the machine's): reached, the run ends as "
                         "at --max-boxes (the rest reported unresolved)")
    sg.add_argument("--json", help="write the cells as JSON (schema spherekin.singular/1, docs/results-format.md)")
    sg.add_argument("--plot", help="draw the plane with the cells coloured by status (.png, .pdf or .svg)")
    sg.add_argument("--home", metavar="B1,B2,...", help="a home input (one per actuated joint): with "
                                                         "--start-solution, the largest box around it proven free")
    sg.add_argument("--start-solution", metavar="K",
                    type=_whole(1, MAX_ASSEMBLIES, f" (as solve numbers them; at most {MAX_ASSEMBLIES} assemblies)"),
                    help="the assembly at --home: solution K of the solve there (numbered from 1)")
    sg.add_argument("--mode-change", action="store_true",
                    help="look for a proven assembly-mode change: a closed loop of inputs around a cusp, tracked "
                         "with every step proven, that returns in another assembly")
    sg.add_argument("--free", choices=("plane", "all"), default="plane",
                    help="the free box's inputs: the plane's (the others at home; default) or all of them")
    from .trust.free_box import SHAPES as FREE_SHAPES

    sg.add_argument("--free-shape", choices=FREE_SHAPES, default=FREE_SHAPES[0],
                    help="the free box: 'box' (default: the largest cube about home, then each face pushed out "
                         "as far as it is proven) or 'cube' (home +- r, one r for every input)")
    sg.add_argument("--degrees", action="store_true", help="input angles, --tol and printed angles in degrees")
    sg.set_defaults(func=_singular, python_names=_singular_names)
    tk = sub_add_parser("track", help="follow one assembly mode along a path of inputs, every step proven")
    tk.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    tk.add_argument("--path", required=True, help="CSV of inputs (a header naming the actuated joints, one row each)")
    tk.add_argument("--start-rotation", help="the platform rotation R at the first input, 9 numbers row-major")
    tk.add_argument("--start-quaternion", help="the platform rotation at the first input as w,x,y,z")
    tk.add_argument("--start-solution", metavar="K",
                    type=_whole(1, MAX_ASSEMBLIES, f" (as solve numbers them; a mechanism track follows, three R-R-R "
                                                   f"legs, has at most {MAX_ASSEMBLIES} assemblies at an input)"),
                    help="start from solution K (as solve numbers them, from 1) of the full solve at the first input")
    tk.add_argument("--degrees", action="store_true", help="path inputs and printed angles in degrees")
    tk.add_argument("--check", type=_whole(1), metavar="N", help="also solve fully at every N-th row (and the last) and "
                                                          "confirm the tracked pose is one of the solutions")
    tk.add_argument("--json", help="write one entry per path row (and the stop) as JSON")
    tk.add_argument("--out", help="write the rows as a results table (.csv or .parquet, the columns of batch)")
    tk.add_argument("--plot", help="draw the orientation along the path and the singularity measure (.png, .pdf, .svg)")
    tk.set_defaults(func=_track, python_names=_track_names)
    g = sub_add_parser("gosselin", help="summary of the paper's Gosselin loop equations")
    g.add_argument("--beta", nargs=3, default=list(DEFAULT_BETAS), metavar=("B1", "B2", "B3"),
                   help="actuator angles in radians, numbers or text such as pi/2 (default: %(default)s)")
    g.add_argument("--range", nargs=2, default=list(DEFAULT_PASSIVE_RANGE), metavar=("LO", "HI"),
                   help="range of every passive joint in radians (default: +-0.9 pi)")
    g.add_argument("--samples", type=_whole(1), default=10000, help="random points for the sampled range")
    g.add_argument("--seed", type=_whole(0), default=0, help="seed of the random sample")
    g.set_defaults(func=_gosselin)
    v = sub_add_parser("verify", help="verify every claim of the paper and write the errata report")
    v.add_argument("--quick", action="store_true", help="small sizes, as in the test suite")
    v.add_argument("--report", help="where to write the markdown report (default: verification/REPORT.md)")
    v.set_defaults(func=_verify)
    return parser


#: An option's value that argparse would take for an option (it starts with "-") but is a number,
#: a list of numbers or an angle: -0.3,0.2 / -pi/2 / -1e-3 / -.5
_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d|pi)")
#: A plain negative number, which argparse itself reads as a value (its own pattern): left alone, so
#: that options of several values (--beta -0.3 0.2 0.5) keep them apart.
_PLAIN_NEGATIVE = re.compile(r"^-\d+$|^-\d*\.\d+$")


def protect_negative_values(argv: list[str]) -> list[str]:
    """``-0.3,0.2`` -> ``" -0.3,0.2"``: argparse takes a token starting with "-" (other than a plain
    negative number such as -0.3, which it reads itself) for an option and stops with "expected one
    argument"; negative angles (-pi/2, -1e-3, lists) are the common case and never an option's name,
    so each gets a leading space, which argparse reads as a value (of a one-value option or of one with
    several, ``--beta -pi/2 0 0``) and every angle reader ignores."""
    return [f" {tok}" if _NEGATIVE_VALUE.match(tok) and not _PLAIN_NEGATIVE.match(tok) else tok for tok in argv]


#: Python keyword names of the strategy (those of spherekin.compile) and the options that set them:
#: the words of every command with strategy options, and the default of :func:`as_options`.
_OPTION_OF = {"lp_backend": "--lp-backend", "pruner": "--pruner", "formulation": "--formulation", "system": "--system",
              "parameterization": "--parameterization", "tol": "--tol", "jobs": "--jobs", "isolate": "--no-isolate"}
#: A keyword's value in the words of the command line, where it is not "--option value".
_VALUE_WORDS = {("isolate", "True"): "isolation (no --no-isolate)", ("isolate", "False"): "--no-isolate"}


def as_options(message: str, options: dict[str, str] = _OPTION_OF) -> str:
    """An error message of the Python API in the words of one command: ``options`` maps each Python
    name to the option the user typed (the command's own, :meth:`_Parser.options`: track's ``path``
    is --path, batch has none; default: the strategy's). ``lp_backend=None`` -> "no --lp-backend",
    ``pruner='lp'`` -> "--pruner lp", a leading ``workers:`` or ``inputs (beta1):`` -> "--workers:",
    "--inputs (beta1):". Only names of ``options``, and only as keyword=value or at the head of the
    message: the same word elsewhere in a sentence is left alone."""
    if not options:
        return message
    names = "|".join(sorted(map(re.escape, options), key=len, reverse=True))

    def value(m):
        key, val = m["key"], m["value"].strip("'")
        if (key, val) in _VALUE_WORDS:
            return _VALUE_WORDS[key, val]
        return f"no {options[key]}" if val == "None" else f"{options[key]} {val}"

    message = re.sub(rf"\b(?P<key>{names})=(?P<value>None|'[^']*'|[^\s,;)]+)", value, message)
    return re.sub(rf"^(?P<key>{names})(?=[:\s(\[])", lambda m: options[m["key"]], message)


def error_line(message: str, options: dict[str, str] = _OPTION_OF) -> str:
    """The one line the command line prints for a refused input (exit status 2): ERROR_PREFIX and the
    message in the command's words (:func:`as_options`), its line breaks made spaces."""
    return ERROR_PREFIX + " ".join(as_options(str(message), options).split())


def main(argv=None, parser: argparse.ArgumentParser | None = None) -> int:
    """Run the command ``argv`` (default: sys.argv[1:]) and return its exit status (a usage error or
    a refused input: 2, one line on stderr, nothing else printed); ``parser``: one :func:`build_parser` made."""
    parser = parser or build_parser()
    try:
        args = parser.parse_args(protect_negative_values(list(sys.argv[1:] if argv is None else argv)))
    except SystemExit as exc:    # --help or --version (0), or a usage error with its one line printed (2)
        return exc.code if isinstance(exc.code, int) else 2
    for key, value in vars(args).items():        # the space protect_negative_values added, gone again
        if isinstance(value, str):
            setattr(args, key, value.strip())
        elif isinstance(value, list):
            setattr(args, key, [v.strip() if isinstance(v, str) else v for v in value])
    # the package's Python names in this command's words: its options, and names that depend on them
    options = {**_OPTION_OF, **parser.command(args.command).options(),
               **getattr(args, "python_names", _no_names)(args)}
    with _sigterm_as_interrupt() as terminated:
        code = _run_command(args, options)
    return SIGTERM_STATUS if terminated and code == INTERRUPT_STATUS else code


#: Exit status after Ctrl-C (SIGINT) and after SIGTERM: 128 + the signal's number, as a shell reports
#: a process the signal ended (so a scheduler or script sees how the command stopped).
INTERRUPT_STATUS, SIGTERM_STATUS = 130, 143


#: Seconds before an interrupt dropped inside a finalizer is sent again: long enough for the hook that
#: saw it to return (its handler must not run inside the hook), short beside any command's run.
RESEND_DELAY = 0.01


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread by :func:`main`'s handler. A KeyboardInterrupt, so that it
    stops a command as Ctrl-C does (a search hands over what it found, a batch keeps its finished
    chunks); its text names the signal."""


@contextmanager
def _sigterm_as_interrupt():
    """While a command runs: SIGTERM raises :class:`Terminated` (the yielded list gets the signal),
    and the handler found is restored afterwards. Only in the main thread (where Python runs handlers)."""
    import signal
    import threading

    got: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield got
        return

    def handler(signum, frame):
        if not got:                     # a second SIGTERM while stopping: let the first one finish
            got.append(signum)
            raise Terminated("SIGTERM")

    previous_hook = sys.unraisablehook

    def unraisable(report):
        # Python runs a signal handler at the next bytecode of the main thread, and that can be
        # inside a finalizer (a dask Future's __del__ did it on CI): an exception raised there is
        # printed and dropped, and the command would run to its end and exit 0. So a dropped
        # interrupt is sent again, from another thread a moment later (sent from here, its handler
        # would run inside this hook, where a raise is dropped too), to be raised where the command
        # can see it.
        if isinstance(report.exc_value, KeyboardInterrupt):
            terminated = isinstance(report.exc_value, Terminated)
            if terminated:
                got.clear()
            threading.Timer(RESEND_DELAY, os.kill,
                            (os.getpid(), signal.SIGTERM if terminated else signal.SIGINT)).start()
            return
        previous_hook(report)

    previous = signal.signal(signal.SIGTERM, handler)
    sys.unraisablehook = unraisable
    try:
        yield got
    finally:
        sys.unraisablehook = previous_hook
        signal.signal(signal.SIGTERM, previous)


def _run_command(args, options: dict[str, str]) -> int:
    import warnings

    from .problem import CappedSearchWarning

    try:
        with warnings.catch_warnings():
            # the count line says it (SearchLimit.text: the tolerance asked for and the covering's)
            warnings.simplefilter("ignore", CappedSearchWarning)
            return args.func(args)
    except ValueError as exc:  # bad input: a clear message, not a traceback
        print(error_line(str(exc), options), file=sys.stderr)
        return 2
    except RuntimeError as exc:  # a solve that failed on a worker, a cluster lost: what was written stays
        print(f"{ERROR_PREFIX}{' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        print(f"\nspherekin: {'terminated (' + str(exc) + ')' if isinstance(exc, Terminated) else 'interrupted'}",
              file=sys.stderr)
        return INTERRUPT_STATUS
    except BrokenPipeError:      # the reader went away (spherekin ... | head): nothing left to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


def run() -> None:
    """The console entry point (``spherekin ...`` and ``python -m spherekin``): the imports with the
    garbage collector paused, :func:`main`, then a fast exit.

    Importing numpy and the package allocates ~10^5 objects that live as long as the process and
    hold no garbage, and the cyclic collector's passes over them cost ~4 ms per process
    (benchmarks/bench_process.py). So the collector is paused while :func:`build_parser` imports
    every module a command uses, those objects are then moved out of its reach (``gc.freeze``: later
    passes do not walk them) and it is enabled again before the command does any work: a long
    solve collects as before.

    Once main has returned (every file written and closed, every worker stopped), the output is
    flushed and the process ends with ``os._exit``: Python's interpreter teardown (finalizing
    numpy's and every module's objects) costs ~20 ms per process (benchmarks/bench_process.py)
    and changes nothing a command produced. An exception or Ctrl-C leaves by the normal path.
    """
    gc.disable()
    try:
        parser = build_parser()
        gc.freeze()
    finally:
        gc.enable()
    code = main(parser=parser)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except BrokenPipeError:     # the reader went away (spherekin ... | head): nothing left to say
        pass
    os._exit(code if isinstance(code, int) else 1)


if __name__ == "__main__":
    run()
