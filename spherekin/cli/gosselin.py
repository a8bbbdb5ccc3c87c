"""``spherekin gosselin``: summary of the paper's two Gosselin closure loops in Bernstein form (Section 2.1, Eq. 10)."""

from __future__ import annotations

import time

from .options import whole


#: Default actuator angles (radians) of the example: arbitrary, generic values (no symmetry).
DEFAULT_BETAS = (0.3, -0.2, 0.5)


def command(args) -> int:
    import numpy as np

    from ..core import bernstein
    from ..mechanism.checks import check_range, parse_angle
    from ..paper_gosselin import paper_gosselin_loops
    from ..results import format_number

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


def add_parser(sub_add_parser) -> None:
    """The ``gosselin`` subcommand and its options."""
    from ..paper_gosselin import DEFAULT_PASSIVE_RANGE

    g = sub_add_parser("gosselin", help="summary of the paper's Gosselin loop equations")
    g.add_argument("--beta", nargs=3, default=list(DEFAULT_BETAS), metavar=("B1", "B2", "B3"),
                   help="actuator angles in radians, numbers or text such as pi/2 (default: %(default)s)")
    g.add_argument("--range", nargs=2, default=list(DEFAULT_PASSIVE_RANGE), metavar=("LO", "HI"),
                   help="range of every passive joint in radians (default: +-0.9 pi)")
    g.add_argument("--samples", type=whole(1), default=10000, help="random points for the sampled range")
    g.add_argument("--seed", type=whole(0), default=0, help="seed of the random sample")
    g.set_defaults(func=command)
