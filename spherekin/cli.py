"""Command-line interface: ``spherekin <command>``.

Commands:
    solve      direct kinematics of a mechanism file: every solution inside the joint ranges
    gosselin   summary of the paper's two Gosselin closure loops in Bernstein form (Section 2.1, Eq. 10)
    verify     symbolic verification of every claim of the paper; writes verification/REPORT.md
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import sys
import time
from pathlib import Path

# numpy and the package's modules are imported by the functions that use them (build_parser imports
# every strategy module): importing this module stays light, so that run() can pause the garbage
# collector before the heavy imports.

#: Default actuator angles (radians) of the example: arbitrary, generic values (no symmetry).
DEFAULT_BETAS = (0.3, -0.2, 0.5)


def _gosselin(args) -> int:
    import numpy as np

    from .core import bernstein
    from .paper_gosselin import paper_gosselin_loops

    t0 = time.perf_counter()
    loops = paper_gosselin_loops(args.beta, tuple(args.range), corrected=True)
    rng = np.random.default_rng(args.seed)
    print("Gosselin platform: the paper's two closure loops in Bernstein form (Section 2.1, Eq. 10);")
    print("  loop 2 with its first and last factors swapped back (erratum s21-final-loop2, verification/REPORT.md)")
    print(f"  actuators beta = ({', '.join(f'{b:+.4f}' for b in args.beta)}) rad; "
          f"passive joints in [{args.range[0]:+.4f}, {args.range[1]:+.4f}] rad")
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


def _parse_inputs(text: str, degrees: bool) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"--inputs: expected comma-separated numbers such as 0.1,-0.2,0.3, got {text!r}") from None
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"--inputs: expected finite numbers, got {text!r}")
    return [math.radians(v) for v in values] if degrees else values


class _Progress:
    """One status line on stderr, redrawn at most every 0.2 s, only when stderr is a terminal."""

    def __init__(self, enabled: bool):
        self.enabled, self.last, self.t0 = enabled, 0.0, time.perf_counter()

    def __call__(self, counts: dict) -> None:
        now = time.perf_counter()
        if self.enabled and now - self.last > 0.2:
            self.last = now
            print(f"\r  {now - self.t0:6.1f} s  boxes {counts['boxes_processed']:8d}  pending {counts['pending']:6d}"
                  f"  accepted {counts['accepted']:5d}", end="", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.enabled and self.last:
            print(file=sys.stderr)


def _solve(args) -> int:
    from .mechanism import load_mechanism
    from .problem import solve

    mech = load_mechanism(args.file)
    inputs = _parse_inputs(args.inputs, args.degrees)
    if len(inputs) != len(mech.actuated):
        raise ValueError(f"--inputs: expected {len(mech.actuated)} values (one per actuated joint "
                         f"{', '.join(mech.actuated)}), got {len(inputs)}")
    unit = "deg" if args.degrees else "rad"
    shown = [math.degrees(v) if args.degrees else v for v in inputs]
    print(f"{mech.name or args.file}: direct kinematics at "
          + ", ".join(f"{n} = {v:+.6g} {unit}" for n, v in zip(mech.actuated, shown)))
    progress = _Progress(sys.stderr.isatty())
    try:
        report = solve(mech, inputs, formulation=args.formulation, pruner=args.pruner, lp_backend=args.lp_backend,
                       parameterization=args.parameterization, tol=args.tol, isolate=not args.no_isolate,
                       jobs=args.jobs, progress=progress)
    finally:
        progress.close()
    st = report.stats
    print(f"{report.count_text()}; passive joint angles in {'degrees' if args.degrees else 'radians'}:")
    print(report.table(degrees=args.degrees))
    used = report.settings
    print(f"{used.parameterization}, formulation {used.formulation}, pruner {args.pruner}"
          + (f" ({used.lp_backend or 'default backend'})" if args.pruner != "pp" else "")
          + f", tol {args.tol:g} rad: {st.charts} chart(s), {st.boxes_processed} boxes "
          f"({st.discarded} discarded, {st.split} split, {st.accepted} accepted, {st.isolated} isolated), "
          f"{st.lps_solved} LPs, {st.time_total:.3f} s")
    if used.fallback:
        print(f"note: {used.fallback}")
    limit = used.limit
    if limit:
        print(f"note: {limit.error}; the solution set was covered with boxes of {limit.covering_tol:g} rad "
              "instead (status continuum: its dimension and covering boxes are in the JSON evidence)")
    if used.refined_searches:
        print(f"note: {used.refined_searches} cluster(s) next to a singularity were searched again at "
              "a finer tolerance to separate their roots")
    if args.json:
        import json  # only for --json (each import is paid by every process)

        Path(args.json).write_text(json.dumps(report.as_dict(), indent=2))
        print(f"wrote {args.json}")
    if args.plot:
        from .plot import plot_solutions  # matplotlib: imported only when a plot is asked for

        print(f"wrote {plot_solutions(mech, inputs, report, args.plot, degrees=args.degrees)}")
    return 0


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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="spherekin", description=__doc__.splitlines()[0],
                                     formatter_class=_HelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    from .search.lp_backends import LP_BACKENDS
    from .search.parameterizations import PARAMETERIZATIONS
    from .problem import DEFAULT_FORMULATION, formulation_choices
    from .search.pruners import PRUNERS
    from .search.boxloop import DEFAULT_PARAMETERIZATION, DEFAULT_PRUNER, DEFAULT_TOL
    from .paper_gosselin import DEFAULT_PASSIVE_RANGE

    so = sub.add_parser("solve", help="direct kinematics of a mechanism file (all solutions in range)",
                        formatter_class=_HelpFormatter)
    so.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    so.add_argument("--inputs", required=True, help="actuator inputs, comma-separated (radians unless --degrees)")
    so.add_argument("--degrees", action="store_true", help="inputs and printed angles in degrees")
    so.add_argument("--parameterization", default=DEFAULT_PARAMETERIZATION, choices=list(PARAMETERIZATIONS),
                    help="variables of the loop equations: tan-half: t = tan(theta/2), the paper's (charts for "
                         "full ranges); sin-cos: c = cos, s = sin with c^2 + s^2 = 1 (Section 5; one chart). "
                         "Default %(default)s")
    so.add_argument("--formulation", default=DEFAULT_FORMULATION, choices=formulation_choices(),
                    help="platform: one equation per leg in the platform's orientation (quaternion charts; "
                         "3-RRR legs); paper: Eq. (10) only; transversal: three entries of F (simple roots) + "
                         "Eq. (10); halves: three entries of F + the loop closed in the middle, P = S^T; auto: "
                         "platform where it applies, else halves. Default %(default)s")
    so.add_argument("--pruner", default=DEFAULT_PRUNER, choices=list(PRUNERS),
                    help="pp: projected polyhedron, no LP; hybrid: pp, LPs where it stalls; "
                         "lp: the Eq. (12) linear programs on every box. Default %(default)s")
    so.add_argument("--lp-backend", default=None, choices=list(LP_BACKENDS),
                    help=f"LP backend ({'; '.join(f'{n}: default {c.default_lp_backend}' for n, c in PRUNERS.items() if c.default_lp_backend)}); paper-faithful: clarabel")
    so.add_argument("--tol", type=float, default=DEFAULT_TOL, help="tolerance in radians (default %(default)g)")
    so.add_argument("--no-isolate", action="store_true",
                    help="subdivide every box down to the tolerance (no Krawczyk isolation; the paper's behaviour)")
    so.add_argument("--jobs", type=int, default=1, help="worker processes for the charts (default %(default)s)")
    so.add_argument("--json", help="write the report (solutions, rotations, statistics) as JSON")
    so.add_argument("--plot", help="draw every solution on the unit sphere, one panel each (.png, .pdf or .svg)")
    so.set_defaults(func=_solve)
    g = sub.add_parser("gosselin", help="summary of the paper's Gosselin loop equations", formatter_class=_HelpFormatter)
    g.add_argument("--beta", type=float, nargs=3, default=list(DEFAULT_BETAS), metavar=("B1", "B2", "B3"),
                   help="actuator angles in radians (default: %(default)s)")
    g.add_argument("--range", type=float, nargs=2, default=list(DEFAULT_PASSIVE_RANGE), metavar=("LO", "HI"),
                   help="range of every passive joint in radians (default: +-0.9 pi)")
    g.add_argument("--samples", type=int, default=10000, help="random points for the sampled range")
    g.add_argument("--seed", type=int, default=0, help="seed of the random sample")
    g.set_defaults(func=_gosselin)
    v = sub.add_parser("verify", help="verify every claim of the paper and write the errata report",
                       formatter_class=_HelpFormatter)
    v.add_argument("--quick", action="store_true", help="small sizes, as in the test suite")
    v.add_argument("--report", help="where to write the markdown report (default: verification/REPORT.md)")
    v.set_defaults(func=_verify)
    return parser


def main(argv=None, parser: argparse.ArgumentParser | None = None) -> int:
    """Run the command ``argv`` (default: sys.argv[1:]); ``parser``: one :func:`build_parser` made."""
    parser = parser or build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:  # bad input: a clear message, not a traceback
        print(f"spherekin: error: {exc}", file=sys.stderr)
        return 2


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
