"""``spherekin singular``: the certified parallel (Type-2) singular set in a plane of two inputs (or on a line)."""

from __future__ import annotations

import dataclasses
import sys

from .. import atomic
from .errors import INTERRUPT_STATUS, SIGTERM_STATUS, signals_stop
from .options import add_tolerances_option, check_output_file, parse_angles, whole, with_tolerances
from .track import FIX_MATCH


def _singular_names(args) -> dict[str, str]:
    """singular's Python names that are not its options' destinations: ``fixed`` is --fix."""
    return {"fixed": "--fix"}


def command(args) -> int:
    """``spherekin singular``: the certified parallel-singular set in a plane (or line) of inputs."""
    import json
    import math

    from ..batch.inputs import parse_fix, parse_range
    from ..mechanism import load_mechanism
    from ..singularities import singular

    mech = with_tolerances(load_mechanism(args.file), args)
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
        check_output_file("--json", args.json, (".json",))
    if args.plot:
        from ..plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    if (args.home is None) != (args.start_solution is None):
        raise ValueError("--home and --start-solution: expected both (the free box of solution K at home) or neither")
    home = None
    if args.home is not None:
        home = parse_angles("--home", args.home, mech.actuated, args.degrees, "one per actuated joint")
        if args.free == "plane":
            for name, value in fixed.items():
                if abs(home[mech.actuated.index(name)] - value) > FIX_MATCH:
                    raise ValueError(f"--home: expected {name} = {value * (180 / math.pi if args.degrees else 1):.6g} "
                                     f"(the plane's --fix) for a free box in the plane, got "
                                     f"{home[mech.actuated.index(name)] * (180 / math.pi if args.degrees else 1):.6g} "
                                     "(or use --free all)")
        from ..problem import compile as compile_problem

        problem = compile_problem(mech)
        n = len(problem.solve(home).solutions)         # milliseconds: checked before the cover's work
        if args.start_solution > n:
            raise ValueError(f"--start-solution: expected a solution number 1..{n} of the solve at --home "
                             f"({n} solution(s)), got {args.start_solution}")
    caps = {} if args.max_boxes is None else {"max_boxes": args.max_boxes}
    if args.mode_change and y is None:
        raise ValueError("--mode-change: expected a plane of two inputs (--y), got a line")
    from ..budget import Budget

    if args.max_memory is not None and not (math.isfinite(args.max_memory) and args.max_memory > 0):
        raise ValueError(f"--max-memory: expected a positive number of GiB, got {args.max_memory!r}")
    budget = Budget() if args.max_memory is None else Budget(int(args.max_memory * 2 ** 30))
    if mech.tolerances is not None:
        for option, value in (("--home", args.home), ("--mode-change", args.mode_change), ("--max-boxes", args.max_boxes)):
            if value:
                raise ValueError(f"{option}: not with tolerances (the singular set under tolerances is cells of the "
                                 "plane proven free for every geometry; drop --tolerances or the file's [tolerances])")
        from ..singularities import tolerant_singular

        with signals_stop(budget) as signalled:
            sset = tolerant_singular(mech, mech.tolerances, x, y, fixed, tol=args.tol * scale, budget=budget)
    else:
        with signals_stop(budget) as signalled:
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
        from ..singularities import mode_change

        sset = dataclasses.replace(sset, mode_change=mode_change(mech, sset))
    unit, show = ("deg", 180.0 / math.pi) if args.degrees else ("rad", 1.0)
    plane = x[0] if y is None else f"{x[0]} x {y[0]}"
    at = ", ".join(f"{k} = {v * show:.6g}" for k, v in fixed.items())
    if sset.system == "tolerances":
        t = mech.tolerances
        print(f"{mech.name or args.file}: parallel singular set over {plane}" + (f" ({at})" if at else "")
              + f" for every geometry within the tolerances (axes {t.axes_deg:g} deg, inputs {t.inputs_deg:g} deg), "
              f"cells <= {args.tol:.6g} {unit}: outside the cells, proven free for every such mechanism")
    else:
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
    elif sset.cusp_search == "not_searched" and sset.system == "tolerances":
        print("cusps: not searched (under tolerances: the cells cover every geometry's singular curve)")
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
        from ..plot import plot_singular

        plot_singular(sset, args.plot, degrees=args.degrees)
        print(f"wrote {args.plot}")
    if signalled:
        written = [p for p in (args.json, args.plot) if p]
        print(f"spherekin: {'interrupted' if signalled[0] == 'SIGINT' else 'terminated'} ({signalled[0]}) after "
              f"{st.boxes_processed} boxes: the result is incomplete"
              + (f" ({', '.join(written)} written)" if written else ""), file=sys.stderr)
        return INTERRUPT_STATUS if signalled[0] == "SIGINT" else SIGTERM_STATUS
    return 0


def add_parser(sub_add_parser) -> None:
    """The ``singular`` subcommand and its options."""
    from ..systems.platform import MAX_ASSEMBLIES

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
    sg.add_argument("--max-boxes", type=whole(1), default=None, metavar="N",
                    help="cap on the boxes the cover processes (reached: the rest is reported unresolved)")
    sg.add_argument("--max-memory", type=float, default=None, metavar="GB",
                    help="cap on the process's memory (GiB; default: 3/4 of the machine's): reached, the run ends as "
                         "at --max-boxes (the rest reported unresolved)")
    add_tolerances_option(sg)
    sg.add_argument("--json", help="write the cells as JSON (schema spherekin.singular/1, docs/results-format.md)")
    sg.add_argument("--plot", help="draw the plane with the cells coloured by status (.png, .pdf or .svg)")
    sg.add_argument("--home", metavar="B1,B2,...", help="a home input (one per actuated joint): with "
                                                         "--start-solution, the largest box around it proven free")
    sg.add_argument("--start-solution", metavar="K",
                    type=whole(1, MAX_ASSEMBLIES, f" (as solve numbers them; at most {MAX_ASSEMBLIES} assemblies)"),
                    help="the assembly at --home: solution K of the solve there (numbered from 1)")
    sg.add_argument("--mode-change", action="store_true",
                    help="look for a proven assembly-mode change: a closed loop of inputs around a cusp, tracked "
                         "with every step proven, that returns in another assembly")
    sg.add_argument("--free", choices=("plane", "all"), default="plane",
                    help="the free box's inputs: the plane's (the others at home; default) or all of them")
    from ..trust.free_box import SHAPES as FREE_SHAPES

    sg.add_argument("--free-shape", choices=FREE_SHAPES, default=FREE_SHAPES[0],
                    help="the free box: 'box' (default: the largest cube about home, then each face pushed out "
                         "as far as it is proven) or 'cube' (home +- r, one r for every input)")
    sg.add_argument("--degrees", action="store_true", help="input angles, --tol and printed angles in degrees")
    sg.set_defaults(func=command, python_names=_singular_names)
