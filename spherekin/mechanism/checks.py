"""Validation of mechanism data: angles (numbers or text with pi), names, unit vectors, ranges, rotations.

Shared by the general model, the 3-RRR constructor and the file loader. Every function takes the
name of the argument or file key first and raises ValueError("<key>: expected ..., got ...").
"""

from __future__ import annotations

import math
import re
from typing import Mapping, Sequence

import numpy as np

__all__ = ["UNIT_TOL", "ROTATION_TOL", "parse_angle", "check_name", "check_unit_vector", "check_range",
           "check_rotation"]

#: |norm - 1| allowed for an axis before it is normalized. Reason: axes are often typed by hand in
#: mechanism files with 6-8 significant digits; anything further from unit length is a mistake
#: (a direction that was meant to be normalized, or a typo), not rounding.
UNIT_TOL = 1e-6

#: |R R^T - I| and |det R - 1| allowed for a rotation given as input. Reason: rotations computed
#: in double precision are orthonormal to ~1e-15; 1e-9 accepts typed decimals while catching
#: matrices that are not rotations.
ROTATION_TOL = 1e-9

_TWO_PI = 2.0 * math.pi

_PI_EXPR = re.compile(
    r"^\s*(?P<sign>[+-])?\s*(?P<num>\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\d+)?\s*(?P<star>\*)?\s*"
    r"(?P<pi>pi)?\s*(?:/\s*(?P<den>\d+(?:\.\d*)?|\.\d+))?\s*$"
)


def parse_angle(key: str, value, *, degrees: bool = False) -> float:
    """An angle in radians: a real number, or a string such as "pi/2", "-3*pi/4", "2pi", "0.25".

    With ``degrees`` the value is a number of degrees (text with pi is refused: it is radians),
    returned in radians. The one reader of angles typed by a user: mechanism files, --inputs, --euler,
    --grid, --fix and CSV cells. Raises ValueError naming ``key`` for anything else (booleans, NaN,
    infinities, other text).
    """
    if degrees:
        if isinstance(value, str) and "pi" in value:
            raise ValueError(f"{key}: with --degrees, expected a number of degrees, got {value.strip()!r} (radians)")
        return math.radians(parse_angle(key, value))
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{key}: expected an angle in radians (a number or text like \"pi/2\"), got {value!r}")
    if isinstance(value, str):
        m = _PI_EXPR.match(value)
        ok = m is not None and bool(m["num"] or m["pi"]) and (not m["star"] or bool(m["num"] and m["pi"]))
        if not ok:
            raise ValueError(
                f"{key}: expected an angle in radians (a number or text like \"pi/2\", \"-3*pi/4\"), got {value!r}"
            )
        out = float(m["num"]) if m["num"] else 1.0
        if m["pi"]:
            out *= math.pi
        if m["den"]:
            den = float(m["den"])
            if den == 0.0:
                raise ValueError(f"{key}: division by zero in {value!r}")
            out /= den
        return -out if m["sign"] == "-" else out
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ValueError(
            f"{key}: expected an angle in radians (a number or text like \"pi/2\"), got {value!r}"
        ) from None
    if not math.isfinite(out):
        raise ValueError(f"{key}: expected a finite angle in radians, got {value!r}")
    return out


def check_name(key: str, value) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{key}: expected a non-empty name (text), got {value!r}")
    return value


def check_unit_vector(key: str, value) -> tuple[float, float, float]:
    """A unit 3-vector (norm 1 within UNIT_TOL), returned normalized to full precision."""
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{key}: expected a unit vector [x, y, z], got {value!r}")
    if len(value) != 3:
        raise ValueError(f"{key}: expected a unit vector of 3 components [x, y, z], got {len(value)} components")
    comps = []
    for i, c in enumerate(value):
        if isinstance(c, (bool, np.bool_)) or not isinstance(c, (int, float, np.integer, np.floating)):
            raise ValueError(f"{key}: expected 3 real numbers [x, y, z], got component {i} = {c!r}")
        comps.append(float(c))
    vec = np.array(comps)
    if not np.all(np.isfinite(vec)):
        raise ValueError(f"{key}: expected finite components, got {comps}")
    norm = float(np.linalg.norm(vec))
    if norm == 0.0:
        raise ValueError(f"{key}: expected a unit vector, got the zero vector")
    if abs(norm - 1.0) > UNIT_TOL:
        raise ValueError(f"{key}: expected a unit vector (norm 1 within {UNIT_TOL:g}), got norm {norm:.9g} for {comps}")
    vec = vec / norm
    return (float(vec[0]), float(vec[1]), float(vec[2]))


def check_range(key: str, value) -> tuple[float, float] | None:
    """A joint range (lo, hi) in radians with lo < hi and hi - lo < 2 pi, or None (full circle)."""
    if value is None:
        return None
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)) or len(value) != 2:
        raise ValueError(f"{key}: expected a range [lo, hi] in radians, got {value!r}")
    lo, hi = parse_angle(f"{key}[0]", value[0]), parse_angle(f"{key}[1]", value[1])
    if not lo < hi:
        raise ValueError(f"{key}: expected lo < hi, got lo = {lo!r} >= hi = {hi!r}")
    if not hi - lo < _TWO_PI:
        raise ValueError(
            f"{key}: expected a width hi - lo < 2*pi, got {hi - lo!r}; "
            "leave the range out for an unlimited joint (the full circle)"
        )
    return (lo, hi)


def check_rotation(key: str, value) -> np.ndarray:
    """A 3x3 rotation matrix (orthonormal, det +1 within ROTATION_TOL)."""
    try:
        mat = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected a 3x3 rotation matrix of real numbers, got {value!r}") from None
    if mat.shape != (3, 3) or not np.all(np.isfinite(mat)):
        raise ValueError(f"{key}: expected a finite 3x3 rotation matrix, got shape {mat.shape}")
    err = max(np.abs(mat @ mat.T - np.eye(3)).max(), abs(np.linalg.det(mat) - 1.0))
    if err > ROTATION_TOL:
        raise ValueError(
            f"{key}: expected a rotation matrix (R R^T = I, det R = 1 within {ROTATION_TOL:g}), "
            f"got an error of {err:.3g}"
        )
    return mat
