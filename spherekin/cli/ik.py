"""``spherekin ik``: inverse kinematics, every actuator solution (working mode) of a platform pose."""

from __future__ import annotations

import math

from .. import atomic
from .options import check_output_file, parse_angles, parse_numbers


def command(args) -> int:
    import numpy as np

    from ..core.orientation import quaternions_from_rotations, rotation_from_euler, rotation_from_quaternion
    from ..results import format_number
    from ..mechanism import load_mechanism
    from ..mechanism.checks import check_rotation

    given = [k for k in ("rotation", "quaternion", "euler") if getattr(args, k) is not None]
    if len(given) != 1:
        raise ValueError("expected the pose as exactly one of --rotation, --quaternion, --euler")
    if args.convention and args.euler is None:
        raise ValueError("--convention: only with --euler")
    mech = load_mechanism(args.file)
    if args.json:
        check_output_file("--json", args.json, (".json",))
    if args.rotation is not None:
        rot = check_rotation("--rotation", np.array(parse_numbers("--rotation", args.rotation, 9)).reshape(3, 3))
    elif args.quaternion is not None:
        rot = rotation_from_quaternion(parse_numbers("--quaternion", args.quaternion, 4), "--quaternion")
    else:
        angles = parse_angles("--euler", args.euler, ("a", "b", "c"), args.degrees, "three Euler angles")
        rot = rotation_from_euler(angles, args.convention or "ZYX", "--euler")
    from ..problem import inverse_kinematics

    # numbered over every solution, then filtered: a solution keeps its number with --in-range
    every = list(enumerate(inverse_kinematics(mech, rot), start=1))
    numbered = [(k, s) for k, s in every if s.in_range or not args.in_range]
    sols = [s for _, s in every]
    scale, unit = (180.0 / math.pi, "degrees") if args.degrees else (1.0, "radians")
    q = quaternions_from_rotations(rot)
    print(f"{mech.name or args.file}: inverse kinematics at the {'platform' if mech.output == 'platform' else mech.output} "
          f"pose with quaternion w, x, y, z = {', '.join(format_number(c) for c in q)}"
          + ("" if mech.legs else " (solved on the loop equations: the output held, the inputs unknown)"))
    names = list(mech.actuated) + list(mech.passive)
    n_in = sum(s.in_range for s in sols)
    print(f"{len(sols)} solution(s) (working modes), {n_in} inside every joint range; joint angles in {unit}:")
    print("  #  mode  " + " ".join(f"{n:>11s}" for n in names) + "  in range" + ("" if mech.legs else "  status"))
    for k, s in numbered:
        mode = "".join("+" if m > 0 else "-" if m < 0 else "0" for m in s.working_mode) or "-"
        print(f"{k:3d}  {mode:>4s}  " + " ".join(format_number(s.joint_angles[n] * scale, "+11.6f") for n in names)
              + f"  {'yes' if s.in_range else 'no':>8s}" + ("" if s.status is None else f"  {s.status}"))
    if args.json:
        import json

        out = {"schema": "spherekin.ik/1", "mechanism": mech.name, "platform_rotation": rot.tolist(),
               "quaternion": q.tolist(),
               "solutions": [{"number": k, "working_mode": list(s.working_mode),       # numbered as printed
                              "inputs": dict(zip(mech.actuated, s.inputs)), "joint_angles": dict(s.joint_angles),
                              "in_range": s.in_range, "status": s.status} for k, s in numbered]}
        atomic.write_text(args.json, json.dumps(out, indent=2))
        print(f"wrote {args.json}")
    return 0


def add_parser(sub_add_parser) -> None:
    """The ``ik`` subcommand and its options."""
    ik = sub_add_parser("ik", help="inverse kinematics: every actuator solution of a platform pose")
    ik.add_argument("file", help="mechanism file (TOML, see docs/mechanism-format.md)")
    ik.add_argument("--rotation", help="the platform rotation R, 9 numbers row-major (v_i = R v_i^0)")
    ik.add_argument("--quaternion", help="the platform rotation as a quaternion w,x,y,z (normalized first)")
    ik.add_argument("--euler", help="the platform rotation as three Euler angles a,b,c (radians unless "
                                     "--degrees; text such as pi/2 too)")
    ik.add_argument("--convention", help="Euler convention: upper case intrinsic (ZYX, the default; ZYZ, ...), "
                                         "lower case extrinsic (xyz, ...)")
    ik.add_argument("--degrees", action="store_true", help="Euler angles and printed angles in degrees")
    ik.add_argument("--in-range", action="store_true", help="only the solutions inside every joint range")
    ik.add_argument("--json", help="write the solutions as JSON")
    ik.set_defaults(func=command)
