"""Validation of mechanism data: angles (numbers or text with pi), names, unit vectors, ranges, rotations.

Shared by the general model, the 3-RRR constructor and the file loader. Every function takes the
name of the argument or file key first and raises ValueError("<key>: expected ..., got ...").
"""

from __future__ import annotations

import math
import re
from typing import Mapping, Sequence

import numpy as np

from ..core.angles import check_geometry_angle
from ..core.columns import RESERVED_COLUMNS

__all__ = ["UNIT_TOL", "ROTATION_TOL", "NAME_FORBIDDEN", "parse_angle", "check_ascii", "shown", "check_name",
           "check_joint_name", "check_unit_vector", "given_unit_vector", "normalized_floats", "check_range",
           "check_rotation"]

#: |norm - 1| allowed for an axis before it is normalized. Reason: axes are often typed by hand in
#: mechanism files with 6-8 significant digits; anything further from unit length is a mistake
#: (a direction that was meant to be normalized, or a typo), not rounding.
UNIT_TOL = 1e-6

#: |R R^T - I| and |det R - 1| allowed for a rotation given as input. Reason: rotations computed
#: in double precision are orthonormal to ~1e-15; 1e-9 accepts typed decimals while catching
#: matrices that are not rotations.
ROTATION_TOL = 1e-9

#: Characters a joint name may not hold, besides whitespace and control characters. Reason: a joint
#: names a column of the CSV results (a comma or a quote there shifts or merges the columns of the
#: header) and is typed as ``name=value`` after --fix and --grid (an '=' in it splits it wrongly).
NAME_FORBIDDEN = ",\"'="

#: Longest text of a value quoted in an error message. Reason: an error is one line; a value of a
#: file (a 100 KB string, a 4000-digit integer) is shown by its start and its length.
SHOWN_CHARS = 60

_TWO_PI = 2.0 * math.pi

_PI_EXPR = re.compile(
    r"^\s*(?P<sign>[+-])?\s*(?P<num>\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\d+)?\s*(?P<star>\*)?\s*"
    r"(?P<pi>pi)?\s*(?:/\s*(?P<den>\d+(?:\.\d*)?|\.\d+))?\s*$", re.ASCII
)


def shown(value) -> str:
    """``repr(value)`` for an error message, at most about SHOWN_CHARS characters: an integer too
    long for that as its number of digits, a longer text by its start and its length."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10 ** SHOWN_CHARS:
        return f"an integer of about {int(abs(value).bit_length() * math.log10(2)) + 1} digits"
    if isinstance(value, (list, tuple, dict)) and len(value) > SHOWN_CHARS:   # not written out only to be cut
        return f"a {type(value).__name__} of {len(value)} items"
    text = repr(value)
    return text if len(text) <= SHOWN_CHARS else f"{text[:SHOWN_CHARS]}... ({len(text)} characters)"


def check_ascii(key: str, text: str) -> str:
    """``text`` when it is ASCII, else ValueError naming ``key`` and its first other character.

    A number is written in the digits 0-9: Python's float() and int() also read the digits of other
    scripts ('\u0663', ARABIC-INDIC DIGIT THREE, as 3), which a file of angles should not hold
    unnoticed."""
    if text.isascii():
        return text
    import unicodedata  # only for this message

    ch = next(c for c in text if not c.isascii())
    raise ValueError(f"{key}: expected a number in the ASCII digits 0-9, got {shown(text)} "
                     f"(holds U+{ord(ch):04X} {unicodedata.name(ch, 'a non-ASCII character')})")


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
        raise ValueError(f"{key}: expected an angle in radians (a number or text like \"pi/2\"), got {shown(value)}")
    if isinstance(value, str):
        m = _PI_EXPR.match(check_ascii(key, value))
        ok = m is not None and bool(m["num"] or m["pi"]) and (not m["star"] or bool(m["num"] and m["pi"]))
        if not ok:
            raise ValueError(
                f"{key}: expected an angle in radians (a number or text like \"pi/2\", \"-3*pi/4\"), got {shown(value)}"
            )
        out = float(m["num"]) if m["num"] else 1.0
        if m["pi"]:
            out *= math.pi
        if m["den"]:
            den = float(m["den"])
            if den == 0.0:
                raise ValueError(f"{key}: division by zero in {value!r}")
            out /= den
        if not math.isfinite(out):                  # "1e400", "1e308*pi": beyond the range of a float
            raise ValueError(f"{key}: expected a finite angle in radians, got {shown(value)}")
        return -out if m["sign"] == "-" else out
    try:
        out = float(value)
    except OverflowError:                           # an integer beyond the range of a float
        raise ValueError(f"{key}: expected a finite angle in radians, got {shown(value)}") from None
    except (TypeError, ValueError):
        raise ValueError(
            f"{key}: expected an angle in radians (a number or text like \"pi/2\"), got {shown(value)}"
        ) from None
    if not math.isfinite(out):
        raise ValueError(f"{key}: expected a finite angle in radians, got {shown(value)}")
    return out


def check_name(key: str, value) -> str:
    """A name (of a mechanism, a leg, a joint): non-empty text."""
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{key}: expected a non-empty name (text), got {shown(value)}")
    if not value.isascii():
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:             # a lone surrogate (from Python, never from a file): no file holds it
            raise ValueError(f"{key}: name {value!r} is not Unicode text (it holds a lone surrogate, which no "
                             "mechanism file or results table can hold)") from None
    return value


def check_joint_name(key: str, value) -> str:
    """A joint's name: non-empty text that can name a column of the results and be typed after
    --fix/--grid: no whitespace, control character or character of NAME_FORBIDDEN, and none of the
    fixed columns of spherekin's tables (:data:`~spherekin.core.columns.RESERVED_COLUMNS`)."""
    check_name(key, value)
    bad = next((c for c in value if c in NAME_FORBIDDEN or c.isspace() or not c.isprintable()), None)
    if bad is not None:
        raise ValueError(f"{key}: joint name {shown(value)} holds {bad!r}; expected a name without whitespace, "
                         "commas, quotes or '=' (it names a column of the CSV results and is typed as "
                         "name=value after --fix and --grid)")
    if value in RESERVED_COLUMNS:
        raise ValueError(f"{key}: joint name {value!r} is the name of a column of the results table; choose "
                         f"another (reserved: {', '.join(RESERVED_COLUMNS)})")
    return value


def given_unit_vector(key: str, value) -> tuple[float, float, float]:
    """The floats of a unit 3-vector exactly as given (norm 1 within UNIT_TOL), not normalized.

    These are the numbers that define the direction (a mechanism file's axis): the proofs of
    :mod:`spherekin.trust.extended` normalize them exactly; :func:`check_unit_vector` rounds the
    direction to floats for everything else."""
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{key}: expected a unit vector [x, y, z], got {shown(value)}")
    if len(value) != 3:
        raise ValueError(f"{key}: expected a unit vector of 3 components [x, y, z], got {len(value)} components")
    comps = []
    for i, c in enumerate(value):
        if isinstance(c, (bool, np.bool_)) or not isinstance(c, (int, float, np.integer, np.floating)):
            raise ValueError(f"{key}: expected 3 real numbers [x, y, z], got component {i} = {shown(c)}")
        try:
            comps.append(float(c))
        except OverflowError:                       # an integer beyond the range of a float
            raise ValueError(f"{key}: expected 3 finite numbers [x, y, z], got component {i} = {shown(c)}") from None
    vec = np.array(comps)
    if not np.all(np.isfinite(vec)):
        raise ValueError(f"{key}: expected finite components, got {comps}")
    norm = math.hypot(*comps)          # scaled: no overflow (and no numpy warning) for 1e308 components
    if norm == 0.0:
        raise ValueError(f"{key}: expected a unit vector, got the zero vector")
    if abs(norm - 1.0) > UNIT_TOL:
        raise ValueError(f"{key}: expected a unit vector (norm 1 within {UNIT_TOL:g}), got norm {norm:.9g} for {comps}")
    return (comps[0], comps[1], comps[2])


def normalized_floats(vec) -> tuple[float, float, float]:
    """vec / |vec| in floats (the direction of a given vector rounded to floats, ~1e-16 off)."""
    v = np.array(vec, dtype=float)
    v = v / float(np.linalg.norm(v))
    return (float(v[0]), float(v[1]), float(v[2]))


def check_unit_vector(key: str, value) -> tuple[float, float, float]:
    """A unit 3-vector (norm 1 within UNIT_TOL), returned normalized to full precision (in floats:
    :func:`given_unit_vector` keeps the numbers as given)."""
    return normalized_floats(given_unit_vector(key, value))


def check_range(key: str, value) -> tuple[float, float] | None:
    """A joint range (lo, hi) in radians with lo < hi and hi - lo < 2 pi, each end within
    :data:`~spherekin.core.angles.MAX_GEOMETRY_ANGLE` of 0, or None (full circle)."""
    if value is None:
        return None
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)) or len(value) != 2:
        raise ValueError(f"{key}: expected a range [lo, hi] in radians, got {shown(value)}")
    lo = check_geometry_angle(f"{key}[0]", parse_angle(f"{key}[0]", value[0]))
    hi = check_geometry_angle(f"{key}[1]", parse_angle(f"{key}[1]", value[1]))
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
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{key}: expected a 3x3 rotation matrix of finite real numbers, got {shown(value)}") from None
    if mat.shape != (3, 3) or not np.all(np.isfinite(mat)):
        raise ValueError(f"{key}: expected a finite 3x3 rotation matrix, got shape {mat.shape}")
    err = max(np.abs(mat @ mat.T - np.eye(3)).max(), abs(np.linalg.det(mat) - 1.0))
    if err > ROTATION_TOL:
        raise ValueError(
            f"{key}: expected a rotation matrix (R R^T = I, det R = 1 within {ROTATION_TOL:g}), "
            f"got an error of {err:.3g}"
        )
    return mat
