"""``spherekin track``: follow one assembly mode along a path of inputs, every step proven."""

from __future__ import annotations

import math
import sys
import time

from .. import atomic
from .options import add_tolerances_option, check_output_file, parse_numbers, whole, with_tolerances


#: A tracked pose and a solution of the full solve are the same assembly when their rotations (without an
#: output link: passive angles, radians) agree to this (largest entry): both are Newton limits accurate
#: to ~1e-14 (as problem.POSE_MATCH).
CHECK_MATCH = 1e-8


#: --home's joints off the plane must equal the plane's --fix readings to this (radians) for a free box
#: in the plane: the box is drawn and reported in that plane (a home elsewhere is --free all's); not 0:
#: the two options' degree conversions may differ in the last bit.
FIX_MATCH = 1e-9


def command(args) -> int:
    import numpy as np

    from ..batch import read_inputs_csv
    from ..core.orientation import quaternions_from_rotations, rotation_from_quaternion
    from ..mechanism import load_mechanism
    from ..mechanism.checks import check_rotation
    from ..problem import compile as compile_problem
    from ..results import format_number

    given = [k for k in ("start_rotation", "start_quaternion", "start_solution") if getattr(args, k) is not None]
    if len(given) != 1:
        raise ValueError("expected the start as exactly one of --start-rotation, --start-quaternion, --start-solution")
    mech = with_tolerances(load_mechanism(args.file), args)
    path = read_inputs_csv(mech, args.path, degrees=args.degrees, key="--path")
    if args.start_rotation is not None:
        start = check_rotation("--start-rotation",
                               np.array(parse_numbers("--start-rotation", args.start_rotation, 9)).reshape(3, 3))
    elif args.start_quaternion is not None:
        start = rotation_from_quaternion(parse_numbers("--start-quaternion", args.start_quaternion, 4),
                                         "--start-quaternion")
    else:
        start = None        # --start-solution K (1..MAX_ASSEMBLIES, checked as read): below, after compiling
    if args.out:
        from ..batch.sinks import check_output_path   # its locks and fingerprints: only for a written table

        check_output_path(args.out, False, True)
    if args.json:
        check_output_file("--json", args.json, (".json",))
    if args.plot:
        from ..plot import check_plot_path

        check_plot_path(args.plot, "--plot")
    problem = compile_problem(mech)
    if args.start_solution is not None:          # numbered from 1, as solve prints them, the JSON and the CSV
        solutions = problem.solve(path.values[0]).solutions
        if args.start_solution > len(solutions):
            raise ValueError(f"--start-solution: expected a solution number 1..{len(solutions)} of the solve at "
                             f"the first input ({len(solutions)} solution(s)), got {args.start_solution}")
        start = solutions[args.start_solution - 1]
    print(f"{mech.name or args.file}: tracking one assembly mode along {len(path)} input(s) of {args.path}")
    t0 = time.perf_counter()
    track = problem.track(path.values, start=start)
    seconds = time.perf_counter() - t0
    scale, unit = (180.0 / math.pi, "degrees") if args.degrees else (1.0, "radians")
    names = list(track.actuated) + list(track.passive_joints)
    print(f"{len(track.poses)} of {len(path)} row(s) tracked, {track.proven_steps} proven step(s) "
          f"({track.rejected_steps} rejected), {seconds:.3f} s; joint angles in {unit}:")
    print("  row  " + " ".join(f"{n:>11s}" for n in names)
          + "   qw        qx        qy        qz     parallel_measure")
    quats = quaternions_from_rotations(track.rotations)
    for p, q in zip(track.poses, quats):
        vals = list(p.inputs.values()) + list(p.passive_angles.values())
        print(f"{p.row:5d}  " + " ".join(format_number(v * scale, "+11.6f") for v in vals)
              + "  " + " ".join(format_number(c) for c in q) + f"  {p.parallel_measure:16.4e}")
    st = track.stop
    if st is not None:
        last = ", ".join(format_number(v * scale, "+.12g") for v in st.last_proven_inputs.values())
        print(f"stopped between rows {st.between_rows[0]} and {st.between_rows[1]}: {st.reason}. ", end="")
        if st.kind == "range":
            print(f"Last input in range {last} ({st.fraction:.6g} of the way), {st.joint} = "
                  f"{st.joint_angle * scale:+.9g} {unit} there; it leaves within {st.bracket:.1e} rad of input "
                  f"further; parallel_measure there {st.parallel_measure:.3g}")
        else:
            print(f"Last proven input {last} ({st.fraction:.6g} of the way); the singular input, located by "
                  f"bisection to {st.bracket:.1e} rad: "
                  f"{', '.join(format_number(v * scale, '+.12g') for v in st.singular_inputs.values())} ({st.distance:.2e} rad "
                  f"further); parallel_measure at the last proven pose {st.parallel_measure:.3g}")
    if mech.tolerances is not None and track.poses:
        print(_tolerance_summary(track, mech.tolerances))
    data = track.as_dict()
    code = 0
    if args.check is not None:
        rows = sorted({*range(0, len(track.poses), args.check), len(track.poses) - 1})
        bad = []
        for k in rows:
            report = problem.solve(list(track.poses[k].inputs.values()))
            if not any(_same_assembly(s, track.poses[k]) for s in report.solutions):
                bad.append(k)
        data["check"] = {"rows": rows, "mismatched_rows": bad, "passed": not bad}
        if bad:
            print(f"check: the tracked pose is NOT among the solutions of the full solve at row(s) "
                  f"{', '.join(map(str, bad))}", file=sys.stderr)
            code = 1
        else:
            print(f"check: at {len(rows)} row(s) the tracked pose is one of the solutions of the full solve")
    if args.json:
        import json

        atomic.write_text(args.json, json.dumps(data, indent=2))
        print(f"wrote {args.json}")
    if args.out:
        from ..batch.rows import track_table
        from ..batch.sinks import open_sink

        with open_sink(args.out, mech, path.values[:len(track.poses)], resume=False) as sink:
            sink.write(0, len(track.poses), track_table(mech, track))
        print(f"wrote {args.out}")
    if args.plot:
        from ..plot import plot_track

        plot_track(track, args.plot, degrees=args.degrees)
        print(f"wrote {args.plot}")
    return code


def _tolerance_summary(track, tolerances) -> str:
    """One line: the largest proven worst-case rotation error along the path and where the count may change."""
    reports = [p.tolerances for p in track.poses]
    errors = [(r.assemblies[0].worst_case_rotation_error, p.row) for r, p in zip(reports, track.poses)]
    proven = [(e, row) for e, row in errors if e is not None]
    t = tolerances
    head = f"under tolerances (axes {t.axes_deg:g} deg, inputs {t.inputs_deg:g} deg): "
    if proven:
        e, row = max(proven)
        head += (f"worst-case rotation error up to {e:.3e} rad ({math.degrees(e):.4f} deg, row {row}), proven at "
                 f"{len(proven)} of {len(errors)} row(s)")
    else:
        head += f"no worst-case rotation error proven ({reports[0].assemblies[0].reason})"
    changes = [p.row for r, p in zip(reports, track.poses) if r.count_constant_over_tolerances is False]
    open_ = [p.row for r, p in zip(reports, track.poses) if r.count_constant_over_tolerances is None]
    head += (f"; count proven constant at {len(errors) - len(changes) - len(open_)} row(s), proven to change at "
             f"{len(changes)}{' (rows ' + ', '.join(map(str, changes[:8])) + ')' if changes else ''}, undecided at "
             f"{len(open_)}")
    return head


def _same_assembly(solution, pose) -> bool:
    """Whether a solution of the full solve is the tracked ``pose``: their rotations agree to
    CHECK_MATCH, or, without an output link, their passive angles do (modulo 2 pi)."""
    import numpy as np

    from ..core.angles import wrap

    if pose.platform_rotation is not None:
        return (solution.platform_rotation is not None
                and np.abs(solution.platform_rotation - pose.platform_rotation).max() <= CHECK_MATCH)
    got = solution.passive_angles
    return all(abs(wrap(got[n] - v)) <= CHECK_MATCH for n, v in pose.passive_angles.items())


def _track_names(args) -> dict[str, str]:
    """The Python names of track's errors that depend on the options given: ``start`` is the start
    option typed (with --start-solution the command hands Problem.track the Solution itself, whose
    messages carry no index)."""
    given = [o for o in ("start_rotation", "start_quaternion", "start_solution") if getattr(args, o, None) is not None]
    return {"start": "--" + given[0].replace("_", "-")} if len(given) == 1 else {}


def add_parser(sub_add_parser) -> None:
    """The ``track`` subcommand and its options."""
    from ..systems.platform import MAX_ASSEMBLIES

    tk = sub_add_parser("track", help="follow one assembly mode along a path of inputs, every step proven")
    tk.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    tk.add_argument("--path", required=True, help="CSV of inputs (a header naming the actuated joints, one row each)")
    tk.add_argument("--start-rotation", help="the platform rotation R at the first input, 9 numbers row-major")
    tk.add_argument("--start-quaternion", help="the platform rotation at the first input as w,x,y,z")
    tk.add_argument("--start-solution", metavar="K",
                    type=whole(1, MAX_ASSEMBLIES, f" (as solve numbers them; a mechanism track follows, three R-R-R "
                                                   f"legs, has at most {MAX_ASSEMBLIES} assemblies at an input)"),
                    help="start from solution K (as solve numbers them, from 1) of the full solve at the first input")
    tk.add_argument("--degrees", action="store_true", help="path inputs and printed angles in degrees")
    tk.add_argument("--check", type=whole(1), metavar="N", help="also solve fully at every N-th row (and the last) and "
                                                          "confirm the tracked pose is one of the solutions")
    add_tolerances_option(tk)
    tk.add_argument("--json", help="write one entry per path row (and the stop) as JSON")
    tk.add_argument("--out", help="write the rows as a results table (.csv or .parquet, the columns of batch)")
    tk.add_argument("--plot", help="draw the orientation along the path and the singularity measure (.png, .pdf, .svg)")
    tk.set_defaults(func=command, python_names=_track_names)
