"""Mechanism files (TOML): load, validate, write. The format is documented in docs/mechanism-format.md.

Three kinds, one model (every kind builds the same graph of links and joints, :mod:`.graph`):

* ``kind = "graph"``: ``ground`` (the fixed link), optional ``output`` (the link whose rotation is
  the pose) and ``name``, and ``[[joints]]`` tables (``name``, ``links = [a, b]`` (the joint turns
  b relative to a), ``axis`` (in the reference assembly, where every joint reads 0), optional
  ``actuated``, ``range``); the loops are found by the program;

* ``kind = "3-RRR"``: keys ``base_axes``, ``elbow_axes_at_zero``, ``platform_axes``,
  ``distal_link_angles`` (radians), optional ``joint_ranges`` (table joint name -> [lo, hi];
  default: every joint unlimited), ``name``, ``reference_leg``; built by :func:`~.rrr.three_rrr`.
* ``kind = "general"``: ``[[legs]]`` tables, each with optional ``name`` and ``[[legs.joints]]``
  tables (``name``, ``axis``, optional ``actuated``, ``range``, ``reference_angle``), listed from
  the base to the platform; optional ``name``, ``reference_leg``, ``platform_reference``.

Every kind may carry a ``[tolerances]`` table (``axes_deg``, ``inputs_deg``, ``[tolerances.joints]``:
:mod:`.tolerances`): the mechanism as built.

Angles are numbers in radians or text such as "pi/2" (see :func:`~.model.parse_angle`). Every
problem raises :class:`MechanismFileError` (a ValueError) with one message naming the file, the
key and the problem.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
from pathlib import Path
from typing import Mapping

import numpy as np

from .checks import shown
from .graph import Joint, MechanismGraph
from .model import Leg, SphericalMechanism
from .rrr import THREE_RRR_KEYS, three_rrr
from .tolerances import tolerances_from_table

__all__ = ["MechanismFileError", "KINDS", "load_mechanism", "mechanism_from_dict", "dumps_mechanism"]

KINDS = ("3-RRR", "general", "graph")
_RRR_OPTIONAL = ("name", "reference_leg", "joint_ranges", "joint_offsets")
_GENERAL_REQUIRED = ("legs",)
_GENERAL_OPTIONAL = ("name", "reference_leg", "platform_reference")
_LEG_KEYS = ("name", "joints")
_JOINT_KEYS = ("name", "axis", "actuated", "range", "reference_angle")
_GRAPH_REQUIRED = ("ground", "joints")
_GRAPH_OPTIONAL = ("name", "output")
_GRAPH_JOINT_REQUIRED = ("name", "links", "axis")
_GRAPH_JOINT_OPTIONAL = ("actuated", "range", "reference_angle")

_KEY_HELP = {
    "base_axes": "the 3 base (actuated) joint axes u_i, unit vectors in the base frame",
    "elbow_axes_at_zero": "the 3 elbow axes w_i^0 at zero actuator angle, unit vectors in the base frame",
    "platform_axes": "the 3 platform joint axes v_i^0, unit vectors in the platform frame",
    "distal_link_angles": "the 3 angles alpha2_i = angle(w_i, v_i) in radians",
    "legs": "the legs, as [[legs]] tables each holding [[legs.joints]] tables",
    "ground": "the name of the fixed link",
    "joints": "the joints, as [[joints]] tables (name, links, axis, optional actuated and range)",
    "links": "the two links the joint joins, [a, b]: the joint turns b relative to a",
}


class MechanismFileError(ValueError):
    """A mechanism file (or dict) that cannot be read or does not describe a valid mechanism."""


def load_mechanism(path) -> SphericalMechanism:
    """Read, validate and build the mechanism described by the TOML file at ``path``."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise MechanismFileError(f"{p}: cannot read the file: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8-sig")       # a byte-order mark (some editors write one) is not TOML: dropped
    except UnicodeDecodeError as exc:
        raise MechanismFileError(f"{p}: not UTF-8 text: {exc.reason} at byte {exc.start}") from None
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise MechanismFileError(f"{p}: not valid TOML for spherekin: arrays or tables nested too deeply") from None
    except tomllib.TOMLDecodeError as exc:
        raise MechanismFileError(f"{p}: not valid TOML: {exc}") from None
    except ValueError as exc:                # Python's limit on the digits of an integer
        raise MechanismFileError(f"{p}: not valid TOML for spherekin: a number with more digits than Python "
                                 f"reads ({str(exc).split(':')[0]})") from None
    return mechanism_from_dict(data, source=str(p))


def mechanism_from_dict(data: Mapping, source: str = "<mechanism>") -> SphericalMechanism:
    """Build a mechanism from parsed TOML data (a dict); errors are prefixed with ``source``."""
    try:
        return _build(data)
    except MechanismFileError:
        raise
    except ValueError as exc:
        raise MechanismFileError(f"{source}: {exc}") from None
    except RecursionError:                   # a value nested deeper than Python's recursion limit
        raise MechanismFileError(f"{source}: a value is nested too deeply (lists in lists)") from None


def _check_keys(where: str, table: Mapping, required, optional) -> None:
    prefix = f"{where}." if where else ""
    valid = tuple(required) + tuple(optional)
    for key in required:
        if key not in table:
            hint = f" ({_KEY_HELP[key]})" if key in _KEY_HELP else ""
            # a typo'd key (grond for ground) is the likeliest reason a required one is missing: name it
            unknown = [k for k in table if k not in valid]
            near = difflib.get_close_matches(key, [str(k) for k in unknown], n=1)
            typo = f"; did you mean {key!r} for the unknown key {near[0]!r}?" if near else ""
            raise ValueError(f"{prefix}{key}: missing key{hint}{typo}")
    for key in table:
        if key not in valid:
            raise ValueError(f"{prefix}{key}: unknown key; valid keys here: {', '.join(valid)}")


def _build(data) -> SphericalMechanism:
    if not isinstance(data, Mapping):
        raise ValueError(f"expected a table of keys, got {type(data).__name__}")
    if "tolerances" in data:                         # any kind: the mechanism as built
        tolerances = tolerances_from_table(data["tolerances"])
        mech = _build({k: v for k, v in data.items() if k != "tolerances"})
        try:
            tolerances.check_joints(mech.joint_names)
        except ValueError as exc:
            raise ValueError(str(exc)) from None
        return dataclasses.replace(mech, tolerances=tolerances)
    if "kind" not in data:
        raise ValueError(f"kind: missing key; expected one of {KINDS}")
    kind = data["kind"]
    if kind not in KINDS:
        raise ValueError(f"kind: expected one of {KINDS}, got {shown(kind)}")
    body = {k: v for k, v in data.items() if k != "kind"}
    if kind == "3-RRR":
        _check_keys("", body, THREE_RRR_KEYS, _RRR_OPTIONAL)
        return three_rrr(
            body["base_axes"], body["elbow_axes_at_zero"], body["platform_axes"], body["distal_link_angles"],
            body.get("joint_ranges"), name=body.get("name", "3-RRR"), reference_leg=body.get("reference_leg", "leg1"),
            joint_offsets=body.get("joint_offsets"),
        )
    if kind == "graph":
        return _build_graph(body)
    _check_keys("", body, _GENERAL_REQUIRED, _GENERAL_OPTIONAL)
    legs = []
    for i, (where, leg) in enumerate(_tables("legs", body["legs"], "legs")):
        _check_keys(where, leg, ("joints",), ("name",))
        joints = []
        for jwhere, j in _tables(f"{where}.joints", leg["joints"], "legs.joints"):
            _check_keys(jwhere, j, ("name", "axis"), ("actuated", "range", "reference_angle"))
            joints.append(_joint(jwhere, j))
        try:
            legs.append(Leg(leg.get("name", f"leg{i + 1}"), tuple(joints)))
        except ValueError as exc:
            raise ValueError(f"{where}.{exc}") from None
    kwargs = {}
    if "platform_reference" in body:
        kwargs["platform_reference"] = body["platform_reference"]
    return SphericalMechanism(
        legs=tuple(legs), name=body.get("name", "mechanism"), reference_leg=body.get("reference_leg"), **kwargs,
    )


def _tables(key: str, raw, array: str):
    """(where, table) of each table of the TOML array of tables ``[[array]]`` read at ``key``: ValueError
    naming the key when it is not a non-empty list of tables."""
    if not isinstance(raw, list) or not raw:
        raise ValueError(f"{key}: expected one or more [[{array}]] tables, got {shown(raw)}")
    for k, table in enumerate(raw):
        if not isinstance(table, Mapping):
            raise ValueError(f"{key}[{k}]: expected a [[{array}]] table, got {shown(table)}")
        yield f"{key}[{k}]", table


def _joint(where: str, j: Mapping) -> Joint:
    """The :class:`Joint` of a joint table (its keys checked by the caller); errors name ``where``."""
    try:
        return Joint(j["name"], j["axis"], j.get("actuated", False), j.get("range"), j.get("reference_angle", 0.0))
    except ValueError as exc:
        raise ValueError(f"{where}.{exc}") from None


def _build_graph(body: Mapping) -> SphericalMechanism:
    _check_keys("", body, _GRAPH_REQUIRED, _GRAPH_OPTIONAL)
    joints, links = [], []
    for where, j in _tables("joints", body["joints"], "joints"):
        _check_keys(where, j, _GRAPH_JOINT_REQUIRED, _GRAPH_JOINT_OPTIONAL)
        joints.append(_joint(where, j))
        pair = j["links"]
        if not isinstance(pair, list) or len(pair) != 2 or not all(isinstance(x, str) for x in pair):
            raise ValueError(f"{where}.links: expected two link names [a, b], got {shown(pair)}")
        links.append(tuple(pair))
    for key in ("ground", "output"):
        if key in body and not isinstance(body[key], str):
            raise ValueError(f"{key}: expected a link name (text), got {shown(body[key])}")
    graph = MechanismGraph(tuple(joints), tuple(links), body["ground"], body.get("output"))
    return SphericalMechanism(graph=graph, name=body.get("name", "mechanism"), kind="graph")


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------


def _num(x: float) -> str:
    return repr(float(x))


def _vec(v) -> str:
    return "[" + ", ".join(_num(c) for c in v) + "]"


def _str(s: str) -> str:
    import json  # only when writing a mechanism file (every import is paid by every process)

    # A JSON string is a TOML basic string but for two things: an ASCII-only JSON escapes a character
    # beyond U+FFFF as a surrogate pair, which TOML refuses (issue 42 item 12: a joint named with an
    # emoji did not load back), so the text is kept as it is; and DEL, which TOML requires escaped.
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007f")


def dumps_mechanism(mech: SphericalMechanism) -> str:
    """The TOML text of a mechanism (the kind it was built as: graph, 3-RRR or general; its tolerances
    when it has them); loads back equal."""
    text = _dumps_body(mech)
    t = mech.tolerances
    if t is None:
        return text
    lines = ["", "[tolerances]", f"axes_deg = {_num(t.axes_deg)}", f"inputs_deg = {_num(t.inputs_deg)}"]
    if t.joints:
        lines += ["", "[tolerances.joints]"] + [f"{_str(n)} = {_num(v)}" for n, v in t.joints]
    return text + "\n".join(lines) + "\n"


def _dumps_body(mech: SphericalMechanism) -> str:
    lines = []
    if mech.kind == "3-RRR" and mech.geometry is not None:
        g = mech.geometry
        lines += ['kind = "3-RRR"', f"name = {_str(mech.name)}", f"reference_leg = {_str(mech.reference_leg)}"]
        for key, vectors in zip(("base_axes", "elbow_axes_at_zero", "platform_axes"), g.given_axes):
            lines.append(f"{key} = [" + ", ".join(_vec(v) for v in vectors) + "]")     # the floats as given
        lines.append("distal_link_angles = [" + ", ".join(_num(a) for a in g.distal_link_angles) + "]")
        ranged = [j for j in mech.joints if j.range is not None]
        if ranged:
            lines += ["", "[joint_ranges]"] + [f"{j.name} = {_vec(j.range)}" for j in ranged]
        if g.joint_offsets:
            lines += ["", "[joint_offsets]"] + [f"{n} = {_num(v)}" for n, v in g.joint_offsets]
        return "\n".join(lines) + "\n"
    if mech.graph is not None:
        g = mech.graph
        lines += ['kind = "graph"', f"name = {_str(mech.name)}", f"ground = {_str(g.ground)}"]
        if g.output is not None:
            lines.append(f"output = {_str(g.output)}")
        for j, (a, b) in zip(g.joints, g.links):
            lines += ["", "[[joints]]", f"name = {_str(j.name)}", f"links = [{_str(a)}, {_str(b)}]",
                      *_joint_lines(j)]
        return "\n".join(lines) + "\n"
    lines += ['kind = "general"', f"name = {_str(mech.name)}", f"reference_leg = {_str(mech.reference_leg)}"]
    if not np.array_equal(mech.platform_reference_matrix, np.eye(3)):
        lines.append("platform_reference = [" + ", ".join(_vec(r) for r in mech.platform_reference) + "]")
    for leg in mech.legs:
        lines += ["", "[[legs]]", f"name = {_str(leg.name)}"]
        for j in leg.joints:
            lines += ["", "[[legs.joints]]", f"name = {_str(j.name)}", *_joint_lines(j)]
    return "\n".join(lines) + "\n"


def _joint_lines(j) -> list[str]:
    """A joint's axis (its floats as given) and, when not the defaults, actuated, range and
    reference_angle (both kinds)."""
    lines = [f"axis = {_vec(j.given_axis)}"]
    if j.actuated:
        lines.append("actuated = true")
    if j.range is not None:
        lines.append(f"range = {_vec(j.range)}")
    if j.reference_angle != 0.0 or math.copysign(1.0, j.reference_angle) < 0:
        lines.append(f"reference_angle = {_num(j.reference_angle)}")
    return lines
