"""``spherekin solve``: direct kinematics of a mechanism file, every solution inside the joint ranges."""

from __future__ import annotations

import math
import sys

from .. import atomic
from .errors import Terminated, as_options
from .options import (add_strategy_options, add_tolerances_option, check_output_file, parse_angles, strategy_keywords,
                      whole, with_tolerances)
from .progress import Progress


def command(args) -> int:
    from ..mechanism import load_mechanism
    from ..problem import compile as compile_problem
    from ..results import format_number
    from ..search.pruners import check_pruner

    check_pruner(args.pruner, args.lp_backend)   # a refused LP backend's reason, before any output
    mech = with_tolerances(load_mechanism(args.file), args)
    inputs = parse_angles("--inputs", args.inputs, mech.actuated, args.degrees, "one per actuated joint")
    values = mech.check_inputs(inputs)
    # every argument and output path is checked before the first line of output (compile checks
    # the strategy's names and numbers: --tol, --jobs)
    if args.json:
        check_output_file("--json", args.json, (".json",))
    try:
        problem = compile_problem(mech, jobs=args.jobs, **{**strategy_keywords(args), "system": args.system})
    except KeyboardInterrupt as exc:
        _write_unsearched(args.json, mech, values, exc)
        raise
    if args.plot:
        from ..plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    unit = "deg" if args.degrees else "rad"
    shown = [math.degrees(v) if args.degrees else v for v in values]
    print(f"{mech.name or args.file}: direct kinematics at "
          + ", ".join(f"{n} = {format_number(v, '+.6g')} {unit}" for n, v in zip(mech.actuated, shown)), flush=True)
    progress = Progress(sys.stderr.isatty(), quiet=args.quiet)
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
    if used.system == "complete":         # no box search: what was proven, and its time
        print(f"{used.parameterization}, formulation complete: {st.isolated} complex roots proven, the count complete "
              f"by Bezout's bound (no box search), {st.time_total:.3f} s")
    else:
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
    if report.tolerances is not None:
        print(report.tolerances.text())
    if args.json:
        import json  # only for --json (each import is paid by every process)

        from ..mechanism.io import dumps_mechanism

        data = report.as_dict()
        data["mechanism_toml"] = dumps_mechanism(mech)
        atomic.write_text(args.json, json.dumps(data, indent=2))
        print(f"wrote {args.json}")
    if args.plot:
        from ..plot import plot_solutions  # matplotlib: imported only when a plot is asked for

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

    from .. import __version__
    from ..mechanism.io import dumps_mechanism
    from ..results import SOLVE_SCHEMA

    signal_name = str(exc) if isinstance(exc, Terminated) else "SIGINT"
    data = {"schema": SOLVE_SCHEMA, "spherekin_version": __version__,
            "settings": {"mechanism": mech.name, "actuated": list(mech.actuated), "inputs": [float(v) for v in values],
                         "limit": {"error": f"stopped by {signal_name} before the search began",
                                   "interrupted": True}},
            "searched": False, "unknowns": list(mech.loop_unknowns),
            "count": {"proven": None, "exact": False, "entries": 0}, "solutions": [],
            "mechanism_toml": dumps_mechanism(mech)}
    atomic.write_text(path, json.dumps(data, indent=2))
    print(f"wrote {path} (nothing searched)", file=sys.stderr)


def add_parser(sub_add_parser) -> None:
    """The ``solve`` subcommand and its options."""
    so = sub_add_parser("solve", help="direct kinematics of a mechanism file (all solutions in range)")
    so.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    so.add_argument("--inputs", required=True, help="actuator inputs, comma-separated (radians unless --degrees; "
                                                      "text such as pi/2 too)")
    so.add_argument("--degrees", action="store_true", help="inputs and printed angles in degrees")
    add_strategy_options(so)
    so.add_argument("--jobs", type=whole(1), default=1,
                    help="Dask worker processes over the charts of the loop equations, on a local cluster "
                         "(~2-3 s to start: for long solves; default %(default)s)")
    add_tolerances_option(so)
    so.add_argument("--json", help="write the report (solutions, rotations, statistics) as JSON")
    so.add_argument("--plot", help="draw every solution on the unit sphere, one panel each (.png, .pdf or .svg)")
    so.add_argument("--quiet", action="store_true", help="no progress on stderr")
    so.add_argument("-v", "--verbose", action="store_true",
                    help="also say why each faster system did not accept the mechanism (always in the JSON)")
    so.set_defaults(func=command)
