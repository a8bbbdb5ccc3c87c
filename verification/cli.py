"""Command line of the verification: ``python -m verification [--quick] [--report PATH]``.

Runs every registered check, prints one line per claim, writes the markdown report and exits 0 if
every check ran, 1 if any check raised (2 for bad command-line arguments).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .registry import run
from .report import DEFAULT_REPORT, write_report
from .result import CheckError

__all__ = ["build_parser", "main"]


def build_parser(prog: str = "python -m verification") -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=prog, description="Verify every claim of the paper (sympy, geometric model) and write the errata report.")
    parser.add_argument("--quick", action="store_true",
                        help="small sizes (n <= 4, few samples), as in the test suite; default: full size")
    parser.add_argument("--report", type=Path, default=DEFAULT_REPORT,
                        help="where to write the markdown report (default: verification/REPORT.md)")
    return parser


def _print_line(result, seconds: float) -> None:
    print(f"{result.summary_line()}  [{seconds:.1f} s]", flush=True)


def main(argv=None) -> int:
    """Entry point; ``argv`` as for argparse (None: sys.argv[1:]). Returns the exit status."""
    args = build_parser().parse_args(argv)
    start = time.perf_counter()
    print(f"verifying the paper's claims ({'quick' if args.quick else 'full'} mode)", flush=True)
    result = run(args.quick, progress=_print_line)
    try:
        path = write_report(result, args.report)
    except ValueError as exc:
        print(f"verification: error: --report: {exc}", file=sys.stderr)
        return 2
    verdicts = {}
    for r in result.claims:
        verdicts[r.verdict] = verdicts.get(r.verdict, 0) + 1
    print(f"{len(result.claims)} claims ({', '.join(f'{n} {v}' for v, n in verdicts.items())}), "
          f"{len(result.implementation_checks)} implementation checks, {len(result.errors)} errors; "
          f"report written to {path} in {time.perf_counter() - start:.1f} s")
    for err in result.errors:
        if isinstance(err, CheckError) and err.traceback:
            print(f"\n{err.check} raised:\n{err.traceback}", file=sys.stderr)
    return 0 if result.ok else 1
