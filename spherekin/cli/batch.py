"""``spherekin batch``: direct kinematics of many inputs (a CSV or a grid) on Dask, written as they finish."""

from __future__ import annotations

import sys

from .options import (add_engine_options, add_grid_options, add_strategy_options, add_tolerances_option, engine_note,
                      family_inputs, strategy_keywords, with_tolerances)
from .progress import BatchProgress


def command(args) -> int:
    """Read the mechanism and the inputs, build one checked job (:func:`spherekin.batch.prepare_to_file`:
    output path, strategy, fingerprint), then run it; the API neither checks nor compiles it again."""
    from ..batch import prepare_to_file, run_to_file
    from ..mechanism import load_mechanism

    mech = with_tolerances(load_mechanism(args.file), args)
    inputs = family_inputs(mech, args)
    job = prepare_to_file(mech, inputs, args.out, resume=args.resume, overwrite=args.overwrite, **strategy_keywords(args))
    print(f"{mech.name or args.file}: direct kinematics of {len(inputs)} input(s) ({inputs.source}) -> {args.out}"
          + (f" (--degrees: inputs read in degrees; {args.out} holds radians)" if args.degrees else ""))
    progress = BatchProgress(sys.stderr.isatty(), quiet=args.quiet)
    try:
        summary = run_to_file(job, scheduler=args.scheduler, workers=args.workers, chunk_size=args.chunk_size,
                              progress=progress)
    finally:
        progress.close()
    if summary.note:
        print(f"spherekin: note: {summary.note}", file=sys.stderr)
    if summary.skipped:
        print(f"{summary.skipped} input(s) were already in {args.out} (resumed)")
    print(f"{engine_note(summary)}; {summary.written} row(s) written to {args.out}")
    if summary.interrupted:
        print(f"interrupted: {summary.skipped + summary.solved} of {summary.total} inputs are in {args.out}; "
              "run the same command with --resume to complete it", file=sys.stderr)
        return 130
    return 0


def add_parser(sub_add_parser) -> None:
    """The ``batch`` subcommand and its options."""
    b = sub_add_parser("batch", help="direct kinematics of many inputs (CSV or grid), on Dask, to Parquet or CSV")
    b.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    b.add_argument("--inputs", help="CSV file of inputs: a header naming the actuated joints, one row per input")
    add_grid_options(b)
    b.add_argument("--out", required=True, help="results: a .parquet dataset (directory) or a .csv file, one row "
                                                "per solution (docs/results-format.md)")
    add_tolerances_option(b)
    add_engine_options(b)
    add_strategy_options(b)
    b.set_defaults(func=command)
