"""Command-line interface: ``spherekin <command>``, one module per command (in the manner of pip's and
dask's ``commands/``), what they share in one module each.

Commands (each module's ``command(args)`` runs it, its ``add_parser`` declares its options):
    solve      direct kinematics of a mechanism file: every solution inside the joint ranges
    ik         inverse kinematics: every actuator solution (working mode) of a platform pose
    batch      direct kinematics of many inputs (a CSV or a grid) on Dask, written as they finish
    map        the number of assembly modes over a 2-D grid of inputs, drawn as a map; for one
               actuated joint, the branches and circuits over its input
    singular   the certified parallel (Type-2) singular set in a plane of two inputs (or on a line)
    track      follow one assembly mode along a path of inputs, every step proven
    gosselin   summary of the paper's two Gosselin closure loops in Bernstein form (Section 2.1, Eq. 10)
    verify     symbolic verification of every claim of the paper; writes verification/REPORT.md

Shared: :mod:`.options` (parsing angles, numbers, paths; the strategy, engine and grid options),
:mod:`.errors` (one line naming the option; exit statuses; SIGTERM as an interrupt), :mod:`.progress`
(stderr progress), :mod:`.parser` (the parser, from each command's options). This package imports no
numpy at import: :func:`run` pauses the garbage collector while :func:`build_parser` imports the rest.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys

from .errors import ERROR_PREFIX, INTERRUPT_STATUS, OPTION_OF, SIGTERM_STATUS, Terminated, error_line, sigterm_as_interrupt
from .options import no_names, protect_negative_values
from .errors import as_options
from .parser import build_parser

__all__ = ["main", "run", "build_parser", "protect_negative_values", "as_options", "error_line", "Terminated"]


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
    options = {**OPTION_OF, **parser.command(args.command).options(),
               **getattr(args, "python_names", no_names)(args)}
    with sigterm_as_interrupt() as terminated:
        code = _run_command(args, options)
    return SIGTERM_STATUS if terminated and code == INTERRUPT_STATUS else code


def _run_command(args, options: dict[str, str]) -> int:
    import warnings

    from ..problem import CappedSearchWarning

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
