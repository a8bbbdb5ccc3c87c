"""Option parsing shared by the commands: angles, numbers, output paths, the strategy and engine options, the grid."""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

from .. import atomic


def parse_angles(key: str, text: str, names, degrees: bool, what: str) -> list[float]:
    """The angles of ``names`` (radians) from the comma-separated ``text`` of option ``key``: each a
    number or text such as "pi/2", read as the mechanism files, --grid and --fix read angles
    (:func:`~spherekin.mechanism.checks.parse_angle`; degrees with ``degrees``). ``what``: what the
    values are, for the error when there are not as many as names."""
    from ..mechanism.checks import parse_angle

    parts = text.split(",")
    if len(parts) != len(names):
        raise ValueError(f"{key}: expected {len(names)} values ({what}: {', '.join(names)}), comma-separated, "
                         f"got {len(parts)} in {text!r}")
    return [parse_angle(f"{key} ({name})", part, degrees=degrees) for name, part in zip(names, parts)]


def parse_numbers(key: str, text: str, n: int) -> list[float]:
    from ..mechanism.checks import check_ascii

    check_ascii(key, text)                      # float() reads the digits of other scripts too
    try:
        values = [float(v) for v in text.replace(" ", ",").split(",") if v]
    except ValueError:
        raise ValueError(f"{key}: expected {n} comma-separated numbers, got {text!r}") from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{key}: expected {n} finite comma-separated numbers, got {text!r}")
    return values


def check_output_file(option: str, path: str, suffixes: tuple[str, ...]) -> Path:
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


class Choices(list):
    """argparse choices that show ``names`` (in --help and argparse's "invalid choice" error) and also
    let ``refused`` through: names spherekin knows and refuses with a measured reason (an LP backend
    of REJECTED_LP_BACKENDS), which the strategy check then gives as the one-line error, exit 2."""

    def __init__(self, names, refused):
        super().__init__(names)
        self.refused = tuple(refused)

    def __contains__(self, name) -> bool:
        return list.__contains__(self, name) or name in self.refused


def whole(minimum: int, maximum: int | None = None, why: str = ""):
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


def check_strategy(mech, args) -> None:
    """The strategy options, checked (by compiling the mechanism once here) before any output."""
    from ..problem import compile as compile_problem

    compile_problem(mech, **strategy_keywords(args))


def strategy_keywords(args) -> dict:
    from ..problem import DEFAULT_SYSTEM
    from ..search.boxloop import MAX_TOL
    from ..systems import ON_CAP_COVER

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


def family_inputs(mech, args):
    from ..batch import grid_inputs, read_inputs_csv

    if getattr(args, "inputs", None) and args.grid:
        raise ValueError("--inputs and --grid: expected one of them (a CSV file of inputs, or a grid)")
    if getattr(args, "inputs", None):
        if args.fix:
            raise ValueError("--fix: only with --grid (a CSV file gives every actuated joint a column)")
        return read_inputs_csv(mech, args.inputs, degrees=args.degrees)
    if not args.grid:
        raise ValueError("expected the inputs: --inputs FILE.csv or --grid name=lo:hi:n (with --fix for the others)")
    return grid_inputs(mech, args.grid, args.fix or (), degrees=args.degrees)


def add_tolerances_option(p) -> None:
    """``--tolerances``: the mechanism as built (over the file's ``[tolerances]``)."""
    p.add_argument("--tolerances", metavar="KEY=DEG,...",
                   help="the mechanism as built: axes_deg=D (each joint axis within D degrees of the file's), "
                        "inputs_deg=E (each input within +-E degrees), <joint>=D (that joint's axis); over the "
                        "file's [tolerances] table (docs/mechanism-format.md)")


def with_tolerances(mech, args):
    """``mech`` with ``--tolerances`` applied over its own (unchanged without the option)."""
    text = getattr(args, "tolerances", None)
    if text is None:
        return mech
    import dataclasses

    from ..mechanism import parse_tolerances_option

    tolerances = parse_tolerances_option(text, mech.tolerances)
    try:
        tolerances.check_joints(mech.joint_names)
    except ValueError as exc:
        raise ValueError(f"--tolerances: {exc}") from None
    return dataclasses.replace(mech, tolerances=tolerances)


def engine_note(summary) -> str:
    where = "in this process" if not summary.workers else f"on {summary.workers} Dask worker(s)"
    rate = summary.solved / summary.seconds if summary.seconds > 0 else 0.0
    return f"{summary.solved} input(s) solved {where} in {summary.seconds:.1f} s ({rate:.1f} per second)"


def no_names(args) -> dict[str, str]:
    """A command whose errors' Python names do not depend on the options given."""
    return {}


def add_strategy_options(so) -> None:
    """The strategy options of solve, batch and map (choices read from the registries)."""
    from ..search.lp_backends import LP_BACKENDS, REJECTED_LP_BACKENDS
    from ..search.parameterizations import PARAMETERIZATIONS
    from ..problem import DEFAULT_FORMULATION, DEFAULT_SYSTEM, formulation_choices
    from ..search.pruners import PRUNERS
    from ..systems import ON_CAP_CHOICES, ON_CAP_COVER, SYSTEMS, system_choices
    from ..search.boxloop import DEFAULT_MAX_BOXES, DEFAULT_PARAMETERIZATION, DEFAULT_PRUNER, DEFAULT_TOL

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
    so.add_argument("--lp-backend", default=None, choices=Choices(LP_BACKENDS, REJECTED_LP_BACKENDS),
                    help=f"LP backend ({'; '.join(f'{n}: default {c.default_lp_backend}' for n, c in PRUNERS.items() if c.default_lp_backend)}); paper-faithful: clarabel"
                         + (f"; {', '.join(REJECTED_LP_BACKENDS)}: measured and refused (the error says why)"
                            if REJECTED_LP_BACKENDS else ""))
    so.add_argument("--tol", type=float, default=DEFAULT_TOL, help="tolerance in radians (default %(default)g)")
    so.add_argument("--max-boxes", type=whole(1), default=None, metavar="N",
                    help=f"box cap of one input's search (default {DEFAULT_MAX_BOXES}); see --on-cap")
    so.add_argument("--on-cap", default=ON_CAP_COVER, choices=list(ON_CAP_CHOICES),
                    help="a search that reaches its box cap: cover: cover the solutions at a coarser tolerance "
                         "(a continuum), the count not proven and the line saying so; raise: stop with the "
                         "error. Default %(default)s")
    so.add_argument("--no-isolate", action="store_true",
                    help="subdivide every box down to the tolerance (no Krawczyk isolation; the paper's behaviour)")


def add_engine_options(p) -> None:
    p.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://HOST:8786); default: an "
                                       "embedded local cluster (in this process for a handful of inputs)")
    p.add_argument("--workers", type=whole(0, why=" (0: in this process)"),
                   help="worker processes of the embedded cluster (default: one per core; 0: in this process)")
    p.add_argument("--chunk-size", type=whole(1), help="inputs per Dask task (default: up to 256, "
                   "fewer so that every worker gets several)")
    p.add_argument("--resume", action="store_true", help="complete a partial output without redoing finished inputs")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")


def add_grid_options(p) -> None:
    p.add_argument("--grid", action="append", metavar="NAME=LO:HI:N",
                   help="sweep an actuated joint over N points from LO to HI (both included; e.g. beta1=-pi:pi:64); "
                        "repeat for each swept joint, the first varies slowest")
    p.add_argument("--fix", action="append", metavar="NAME=VALUE", help="hold an actuated joint at VALUE")
    p.add_argument("--degrees", action="store_true",
                   help="input angles (and printed angles) in degrees; written tables stay in radians")


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
