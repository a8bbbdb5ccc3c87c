"""``spherekin verify``: symbolic verification of every claim of the paper (the checkout's verification/, run as its own process)."""

from __future__ import annotations

import sys
from pathlib import Path


def command(args) -> int:
    """Run ``python -m verification`` of the source checkout this package lives in.

    The verification (sympy, an independent geometric model) is not part of the package: it checks
    the paper and the package from outside. So the package never imports it; this command runs it
    as its own process when the checkout has it, and says where it lives otherwise.
    """
    import subprocess

    root = Path(__file__).resolve().parents[2]          # the checkout: spherekin/cli/verify.py
    if not (root / "verification" / "__main__.py").is_file():
        print("spherekin: error: 'spherekin verify' runs the verification/ directory of a source checkout of "
              f"spherekin, and there is none next to this installation ({root}); clone the repository and run "
              "'make verify' (or 'python -m verification') there", file=sys.stderr)
        return 2
    argv = (["--quick"] if args.quick else []) + (["--report", args.report] if args.report else [])
    return subprocess.run([sys.executable, "-m", "verification", *argv], cwd=root).returncode


def add_parser(sub_add_parser) -> None:
    """The ``verify`` subcommand and its options."""
    v = sub_add_parser("verify", help="verify every claim of the paper and write the errata report")
    v.add_argument("--quick", action="store_true", help="small sizes, as in the test suite")
    v.add_argument("--report", help="where to write the markdown report (default: verification/REPORT.md)")
    v.set_defaults(func=command)
