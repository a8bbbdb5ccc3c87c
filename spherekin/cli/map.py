"""``spherekin map``: the number of assembly modes over a 2-D grid of inputs; for one actuated joint, the branches and circuits over its input."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from .. import atomic
from .options import (add_engine_options, add_grid_options, add_strategy_options, add_tolerances_option,
                      check_output_file, check_strategy, family_inputs, strategy_keywords, whole, with_tolerances)
from .progress import BatchProgress


#: map's options that draw a map of two inputs, not the branches of one (refused there by name).
_TWO_INPUT_MAP_OPTIONS = (("fix", "--fix"), ("table", "--table"), ("tolerances", "--tolerances"), ("out", "--out"), ("singularity", "--singularity"),
                          ("singular", "--singular"), ("singular_tol", "--singular-tol"),
                          ("singular_max_boxes", "--singular-max-boxes"),
                          ("resume", "--resume"), ("overwrite", "--overwrite"), ("scheduler", "--scheduler"),
                          ("workers", "--workers"), ("chunk_size", "--chunk-size"))


def command(args) -> int:
    from ..batch import assembly_map
    from ..batch.sinks import check_output_path
    from ..mechanism import load_mechanism

    mech = with_tolerances(load_mechanism(args.file), args)
    if len(mech.actuated) == 1 or args.joint:   # one input: its branches and circuits
        return _branches(mech, args)
    if args.json:
        raise ValueError(f"--json: only for the branches of a mechanism with one actuated joint, got "
                         f"{len(mech.actuated)} ({', '.join(mech.actuated)}); --table writes a map of two inputs")
    if len(args.grid or ()) != 2:
        raise ValueError(f"--grid: a map needs exactly two grid axes (x, then y), got {len(args.grid or ())}")
    inputs = family_inputs(mech, args)                     # every spec and range checked here
    if args.plot:
        from ..plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    if args.out:
        check_output_path(args.out, args.resume, args.overwrite)
    if args.table and not str(args.table).lower().endswith(".csv"):
        raise ValueError(f"--table {args.table}: expected a .csv path")
    if args.table and not Path(args.table).resolve().parent.is_dir():
        raise ValueError(f"--table {args.table}: the directory does not exist")
    check_strategy(mech, args)
    for option, value in (("--singular-tol", args.singular_tol), ("--singular-max-boxes", args.singular_max_boxes)):
        if value is not None and not args.singular:
            raise ValueError(f"{option}: only with --singular (the certified singular cells)")
    singular_tol = None
    if args.singular:
        from ..singularities import SINGULAR_TOL, check_singular_tol

        singular_tol = check_singular_tol(SINGULAR_TOL if args.singular_tol is None else
                                          args.singular_tol * (math.pi / 180.0 if args.degrees else 1.0), "--singular-tol")
    x, y = inputs.axes
    print(f"{mech.name or args.file}: assembly-mode map over {x.name} x {y.name} "
          f"({len(x.values)} x {len(y.values)} inputs)"
          + ("" if singular_tol is None else f", with its certified singular set (cells <= {singular_tol:.3g} rad)"))
    progress = BatchProgress(sys.stderr.isatty(), quiet=args.quiet)
    try:
        amap = assembly_map(mech, x, y, inputs.fixed, out=args.out, resume=args.resume, overwrite=args.overwrite,
                            scheduler=args.scheduler, workers=args.workers, chunk_size=args.chunk_size,
                            progress=progress, singular_tol=singular_tol,
                            singular_max_boxes=args.singular_max_boxes, **strategy_keywords(args))
    finally:
        progress.close()
    print(amap.table())
    if args.table:
        atomic.write_text(args.table, amap.frame().to_csv(index=False))
        print(f"wrote {args.table}")
    if args.plot:
        from ..plot import plot_assembly_map

        plot_assembly_map(amap, args.plot, degrees=args.degrees, measure=args.singularity)
        print(f"wrote {args.plot}")
    return 0


def _branches(mech, args) -> int:
    """``spherekin map`` of a mechanism with one actuated joint: its branches and circuits over that
    input (:mod:`spherekin.batch.branches`)."""
    import json

    from ..batch.branches import branch_map, check_one_input

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
        from ..batch.inputs import parse_grid

        grid = parse_grid(args.grid[0], degrees=args.degrees)
    if args.json:
        check_output_file("--json", args.json, (".json",))
    if args.plot:
        from ..plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    check_strategy(mech, args)
    progress = BatchProgress(sys.stderr.isatty(), quiet=args.quiet)
    try:
        bmap = branch_map(mech, grid, joint=args.joint, progress=progress, **strategy_keywords(args))   # checks first
    finally:
        progress.close()
    print(f"{mech.name or args.file}: branches and circuits over {name}")
    print(bmap.report(degrees=args.degrees))
    if args.json:
        atomic.write_text(args.json, json.dumps(bmap.as_dict(), indent=2))
        print(f"wrote {args.json}")
    if args.plot:
        from ..plot import plot_branches

        plot_branches(bmap, args.plot, degrees=args.degrees)
        print(f"wrote {args.plot}")
    return 0


def add_parser(sub_add_parser) -> None:
    """The ``map`` subcommand and its options."""
    from ..singularities import SINGULAR_TOL

    mp = sub_add_parser("map", help="number of assembly modes over a 2-D grid of inputs, drawn as a map; "
                                    "one actuated joint: branches and circuits over its input")
    mp.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    add_grid_options(mp)
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
    mp.add_argument("--singular-max-boxes", type=whole(1), default=None, metavar="N",
                    help="with --singular: cap on the boxes its cover processes (reached: the rest is unresolved)")
    add_tolerances_option(mp)
    mp.add_argument("--table", help="write the map, one row per grid point, as CSV")
    mp.add_argument("--out", help="also write the results table (one row per solution; .parquet or .csv)")
    mp.add_argument("--joint", help="one actuated joint: the passive joint whose angle the branches report and draw "
                                     "(default: the first passive joint)")
    mp.add_argument("--json", help="one actuated joint: write the branches, branch points and circuits as JSON")
    add_engine_options(mp)
    add_strategy_options(mp)
    mp.set_defaults(func=command)
