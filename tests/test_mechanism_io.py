"""Tests for spherekin.mechanism.io: mechanism files load, round-trip, and bad files are rejected with
one message that names the file, the key and the problem (never a numpy traceback)."""

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spherekin.core.columns import RESERVED_COLUMNS
from spherekin.mechanism import (
    PRESETS,
    MechanismFileError,
    dumps_mechanism,
    load_mechanism,
    parse_angle,
    preset,
    three_rrr,
)

GOOD_RRR = """\
kind = "3-RRR"
base_axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]
elbow_axes_at_zero = [[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]
platform_axes = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
distal_link_angles = ["pi/2", "pi/2", 1.5707963267948966]
"""

GOOD_GENERAL = """\
kind = "general"
name = "4R"

[[legs]]
name = "crank"
[[legs.joints]]
name = "A"
axis = [0.0, 0.0, 1.0]
actuated = true
range = ["-pi/2", "pi/2"]
[[legs.joints]]
name = "B"
axis = [0.0, 0.5, 0.8660254037844387]

[[legs]]
name = "rocker"
[[legs.joints]]
name = "D"
axis = [0.9848077530122081, 0.0, 0.17364817766693044]
[[legs.joints]]
name = "C"
axis = [0.5242414154116771, 0.8463950507266184, -0.09373556674308138]
"""


def write(tmp_path, text, name="mech.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_good_files_load(tmp_path):
    rrr = load_mechanism(write(tmp_path, GOOD_RRR))
    assert rrr.kind == "3-RRR" and rrr.actuated == ("beta1", "beta2", "beta3")
    assert all(r is None for r in rrr.ranges.values())  # default: every joint unlimited
    assert rrr.geometry.distal_link_angles == (math.pi / 2,) * 3
    gen = load_mechanism(write(tmp_path, GOOD_GENERAL, "g.toml"))
    assert gen.name == "4R" and gen.actuated == ("A",) and gen.passive == ("B", "D", "C")
    assert gen.ranges["A"] == (-math.pi / 2, math.pi / 2) and gen.reference_leg == "crank"


def test_3rrr_joint_ranges_table(tmp_path):
    text = GOOD_RRR + '\n[joint_ranges]\nbeta1 = [-1.0, 1.0]\ngamma3 = ["-pi", "pi/4"]\n'
    mech = load_mechanism(write(tmp_path, text))
    assert mech.ranges["beta1"] == (-1.0, 1.0) and mech.ranges["gamma3"] == (-math.pi, math.pi / 4)
    assert mech.ranges["beta2"] is None


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_dump_and_load_round_trip(tmp_path, name):
    mech = preset(name)
    back = load_mechanism(write(tmp_path, dumps_mechanism(mech)))
    assert (back.name, back.kind, back.actuated, back.reference_leg) == (mech.name, mech.kind, mech.actuated,
                                                                         mech.reference_leg)
    for a, b in zip(mech.joints, back.joints):
        np.testing.assert_allclose(a.axis, b.axis, atol=1e-15)
        assert a.reference_angle == pytest.approx(b.reference_angle, abs=1e-12)


def test_the_files_numbers_are_kept_as_given(tmp_path):
    """The numbers of a file are the mechanism (issue 40): a joint's axis and a 3-RRR's vectors keep their
    floats as given (``given_axis``, ``geometry.given_axes``: what the proofs in extended precision
    normalize exactly), the float model uses them normalized in floats, and a file written back holds the
    same numbers, so that it loads to the same mechanism (equal, also for a batch's fingerprint)."""
    import dataclasses
    import tomllib
    from pathlib import Path

    examples = Path(__file__).resolve().parents[1] / "examples"
    for name in ("watt_six_bar.toml", "four_bar.toml"):
        data = tomllib.loads((examples / name).read_text())
        mech = load_mechanism(examples / name)
        raw = {j["name"]: tuple(float(t) for t in j["axis"])
               for j in data.get("joints", [j for leg in data.get("legs", []) for j in leg["joints"]])}
        for j in mech.joints:
            assert j.given_axis == raw[j.name]
            assert j.axis == tuple(float(t) for t in np.array(raw[j.name]) / np.linalg.norm(raw[j.name]))
            assert dataclasses.replace(j, range=None).given_axis == raw[j.name]     # kept by a copy
        back = load_mechanism(write(tmp_path, dumps_mechanism(mech)))
        assert back == mech and [j.given_axis for j in back.joints] == [j.given_axis for j in mech.joints]
    data = tomllib.loads((examples / "general_3rrr.toml").read_text())
    mech = load_mechanism(examples / "general_3rrr.toml")
    assert mech.geometry.given_axes == tuple(tuple(tuple(float(t) for t in v) for v in data[key])
                                             for key in ("base_axes", "elbow_axes_at_zero", "platform_axes"))
    assert mech.geometry.given_axes != (mech.geometry.base_axes, mech.geometry.elbow_axes_at_zero,
                                        mech.geometry.platform_axes)      # normalizing in floats moves them
    moved = three_rrr(*mech.geometry.given_axes, mech.geometry.distal_link_angles, joint_offsets={"gamma2": 0.25})
    for m in (mech, moved):
        back = load_mechanism(write(tmp_path, dumps_mechanism(m)))
        assert back == m and back.geometry.joint_offsets == m.geometry.joint_offsets
    assert moved.geometry.joint_offsets == (("gamma2", 0.25),)


def test_a_joint_given_a_new_axis_is_the_new_axis():
    from spherekin.mechanism import Joint

    j = Joint("A", (0.0, 0.6, 0.8000001))
    assert j.given_axis == (0.0, 0.6, 0.8000001) and j.axis != j.given_axis
    import dataclasses
    k = dataclasses.replace(j, axis=(1.0, 0.0, 0.0))
    assert k.given_axis == k.axis == (1.0, 0.0, 0.0)
    assert Joint("A", j.axis, given_axis=j.given_axis) == j


def test_dump_keeps_ranges(tmp_path):
    x, y, z = np.eye(3)
    mech = three_rrr([x, y, -z], [y, -z, x], [z, x, y], [math.pi / 2] * 3, {"delta2": (-1.0, 2.0)})
    back = load_mechanism(write(tmp_path, dumps_mechanism(mech)))
    assert back.ranges["delta2"] == (-1.0, 2.0)


@pytest.mark.parametrize(
    "text, value",
    [("pi/2", math.pi / 2), ("-3*pi/4", -3 * math.pi / 4), ("2pi", 2 * math.pi), (" 0.25 ", 0.25),
     ("-pi", -math.pi), ("1.5 * pi / 3", 0.5 * math.pi), (0.5, 0.5), (2, 2.0)],
)
def test_parse_angle(text, value):
    assert parse_angle("k", text) == pytest.approx(value, abs=1e-15)


@pytest.mark.parametrize("text", ["pi/0", "*pi", "tau", "", "pi pi", "1/2/3", True, None, float("nan")])
def test_parse_angle_rejects(text):
    with pytest.raises(ValueError, match="^k: "):
        parse_angle("k", text)


def replace(text, old, new):
    assert old in text
    return text.replace(old, new)


BAD_FILES = [
    # (description, text, key in the message, problem in the message)
    ("missing key", replace(GOOD_RRR, 'distal_link_angles = ["pi/2", "pi/2", 1.5707963267948966]\n', ""),
     "distal_link_angles", "missing key"),
    ("missing kind", replace(GOOD_RRR, 'kind = "3-RRR"\n', ""), "kind", "missing key"),
    ("wrong kind", replace(GOOD_RRR, '"3-RRR"', '"3-RPR"'), "kind", "expected one of"),
    ("unknown key", GOOD_RRR + "base_axis = 1\n", "base_axis", "unknown key"),
    ("non-unit vector", replace(GOOD_RRR, "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]",
                                "[[1.0, 0.0, 0.0], [0.0, 1.1, 0.0], [0.0, 0.0, -1.0]]"),
     "base_axes[1]", "expected a unit vector (norm 1"),
    ("zero vector", replace(GOOD_RRR, "[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]",
                            "[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]"),
     "platform_axes[0]", "zero vector"),
    ("text vector", replace(GOOD_RRR, "[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]",
                            '[[0.0, 0.0, 1.0], "x", [0.0, 1.0, 0.0]]'),
     "platform_axes[1]", "expected a unit vector"),
    ("wrong count of vectors", replace(GOOD_RRR, "[[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]",
                                       "[[0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]"),
     "elbow_axes_at_zero", "expected 3 unit vectors"),
    ("wrong count of components", replace(GOOD_RRR, "[1.0, 0.0, 0.0]]\nplatform", "[1.0, 0.0]]\nplatform"),
     "elbow_axes_at_zero[2]", "3 components"),
    ("wrong count of angles", replace(GOOD_RRR, '["pi/2", "pi/2", 1.5707963267948966]', '["pi/2", "pi/2"]'),
     "distal_link_angles", "expected 3 angles"),
    ("bad angle", replace(GOOD_RRR, '["pi/2", "pi/2", 1.5707963267948966]', '["pi/2", "90 deg", 1.0]'),
     "distal_link_angles[1]", "expected an angle in radians"),
    ("angle out of (0, pi)", replace(GOOD_RRR, '["pi/2", "pi/2", 1.5707963267948966]', '["pi/2", "pi", 1.0]'),
     "distal_link_angles[1]", "strictly between 0 and pi"),
    ("lo >= hi", GOOD_RRR + "[joint_ranges]\nbeta1 = [1.0, 1.0]\n", "joint_ranges.beta1", "expected lo < hi"),
    ("range too wide", GOOD_RRR + "[joint_ranges]\nbeta1 = [-4.0, 4.0]\n", "joint_ranges.beta1", "width"),
    ("range not a pair", GOOD_RRR + "[joint_ranges]\nbeta1 = [1.0]\n", "joint_ranges.beta1", "expected a range"),
    ("unknown joint in ranges", GOOD_RRR + "[joint_ranges]\ntheta1 = [0.0, 1.0]\n", "joint_ranges", "unknown joint"),
    ("inconsistent geometry: elbow on base axis",
     replace(GOOD_RRR, "[[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]",
             "[[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]"),
     "elbow_axes_at_zero[0]", "inconsistent geometry"),
    ("inconsistent geometry: cannot assemble",
     replace(replace(GOOD_RRR, "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]",
                     "[[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]"),
             "[[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]",
             "[[0.1, 0.0, 0.99498743710662], [0.1, 0.0, 0.99498743710662], [0.1, 0.0, 0.99498743710662]]")
     .replace('["pi/2", "pi/2", 1.5707963267948966]', "[0.1, 0.1, 0.1]"),
     "base_axes, elbow_axes_at_zero, platform_axes, distal_link_angles", "no platform pose assembles"),
    ("bad reference leg", GOOD_RRR + 'reference_leg = "leg4"\n', "reference_leg", "expected one of"),
    # general kind
    ("general: missing legs", 'kind = "general"\nname = "x"\n', "legs", "missing key"),
    ("general: one leg", GOOD_GENERAL.split("[[legs]]\nname = \"rocker\"")[0], "legs", "at least 2 legs"),
    ("general: missing axis", replace(GOOD_GENERAL, "axis = [0.0, 0.5, 0.8660254037844387]\n", ""),
     "legs[0].joints[1].axis", "missing key"),
    ("general: non-unit axis", replace(GOOD_GENERAL, "[0.0, 0.5, 0.8660254037844387]", "[0.0, 0.5, 0.8]"),
     "legs[0].joints[1].axis", "expected a unit vector (norm 1"),
    ("general: lo >= hi", replace(GOOD_GENERAL, 'range = ["-pi/2", "pi/2"]', "range = [0.5, 0.1]"),
     "legs[0].joints[0].range", "expected lo < hi"),
    ("general: actuated not a bool", replace(GOOD_GENERAL, "actuated = true", 'actuated = "yes"'),
     "legs[0].joints[0].actuated", "expected true or false"),
    ("general: unknown joint key", replace(GOOD_GENERAL, "actuated = true", "actuated = true\ndriven = true"),
     "legs[0].joints[0].driven", "unknown key"),
    ("general: coaxial joints in a leg", replace(GOOD_GENERAL, "[0.0, 0.5, 0.8660254037844387]", "[0.0, 0.0, -1.0]"),
     "legs[0].joints[0], joints[1]", "inconsistent geometry"),
    ("general: duplicate joint", replace(GOOD_GENERAL, 'name = "C"', 'name = "A"'),
     "legs[1].joints[1].name", "used twice"),
    ("general: no actuator", replace(GOOD_GENERAL, "actuated = true\n", ""), "legs", "at least one actuated joint"),
    ("general: platform_reference not a rotation", 'platform_reference = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]\n'
     + GOOD_GENERAL, "platform_reference", "expected a rotation matrix"),
    ("general: platform_reference wrong shape", 'platform_reference = [[1, 0, 0], [0, 1, 0]]\n' + GOOD_GENERAL,
     "platform_reference", "expected a finite 3x3"),
]


@pytest.mark.parametrize("desc, text, key, problem", BAD_FILES, ids=[b[0] for b in BAD_FILES])
def test_bad_file_gives_one_message_with_file_key_and_problem(tmp_path, desc, text, key, problem):
    path = write(tmp_path, text, "bad.toml")
    with pytest.raises(MechanismFileError) as info:
        load_mechanism(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: "), msg
    assert key in msg and problem in msg, msg
    assert "\n" not in msg and "Traceback" not in msg
    assert info.value.__cause__ is None and info.value.__suppress_context__  # no chained numpy traceback


def test_invalid_toml_and_missing_file(tmp_path):
    path = write(tmp_path, 'kind = "3-RRR"\nbase_axes = [[1, 0, 0]\n', "broken.toml")
    with pytest.raises(MechanismFileError, match=r"broken.toml: not valid TOML"):
        load_mechanism(path)
    with pytest.raises(MechanismFileError, match=r"nope.toml: cannot read the file"):
        load_mechanism(tmp_path / "nope.toml")
    assert issubclass(MechanismFileError, ValueError)


def test_examples_in_the_format_document_load(tmp_path):
    """Every ```toml block of docs/mechanism-format.md is a valid mechanism file."""
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "mechanism-format.md").read_text()
    blocks = [b.split("```", 1)[0] for b in doc.split("```toml\n")[1:]]
    assert len(blocks) >= 2
    rrr = None
    for k, block in enumerate(blocks):
        if "kind =" not in block:             # a fragment (the [tolerances] table, naming beta1): appended to a 3-RRR
            assert rrr is not None and block.lstrip().startswith("[")
            block = rrr + "\n" + block
        elif 'kind = "3-RRR"' in block:
            rrr = block
        mech = load_mechanism(write(tmp_path, block, f"doc{k}.toml"))
        ref = {j.name: j.reference_angle for j in mech.joints}
        assert max(mech.forward(ref).loop_residuals) < 1e-12
    first_rrr = next(k for k, b in enumerate(blocks) if 'kind = "3-RRR"' in b)      # the 3-RRR section's robot
    robot = load_mechanism(tmp_path / f"doc{first_rrr}.toml")
    sols = robot.inverse_kinematics(np.eye(3))
    assert len(sols) == 8 and any(s.in_range for s in sols)


def test_a_typoed_required_key_is_named_beside_the_missing_one(tmp_path):
    """`grond = "ground"` (issue 42 item 17): the error says the required key is missing and names the unknown
    key next to it, not only "missing key"."""
    from spherekin.mechanism import load_mechanism

    text = (Path(__file__).resolve().parent.parent / "examples" / "four_bar_graph.toml").read_text()
    path = tmp_path / "typo.toml"
    path.write_text(text.replace('ground = "ground"', 'grond = "ground"', 1))
    with pytest.raises(ValueError, match=r"ground: missing key.*did you mean 'ground' for the unknown key 'grond'"):
        load_mechanism(path)


def test_huge_axis_components_are_one_error_and_no_numpy_warning(tmp_path):
    """Axes of 1e308 (issue 42 item 12): the norm is not computed by squaring (an overflow warning on stderr
    before the error); the error alone, as an exception, with no warning."""
    import warnings

    from spherekin.mechanism import load_mechanism

    text = (Path(__file__).resolve().parent.parent / "examples" / "four_bar_graph.toml").read_text()
    path = tmp_path / "huge.toml"
    path.write_text(text.replace("axis = [0.0, 0.0, 1.0]", "axis = [1e308, 1e308, 1.0]", 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"joints\[0\]\.axis: expected a unit vector .* got norm 1.414"):
            load_mechanism(path)


_NAMES = st.text(min_size=1, max_size=12).filter(lambda s: s.strip())
_JOINT_NAMES = st.text(st.characters(blacklist_categories=("Cs", "Cc", "Z"), blacklist_characters=',"\'=\\'),
                       min_size=1, max_size=8).filter(str.isprintable)


@settings(max_examples=60, deadline=None)
@given(mech_name=_NAMES, link=_NAMES, joint_name=_JOINT_NAMES)
def test_any_name_survives_dump_and_load(tmp_path_factory, mech_name, link, joint_name):
    """Issue 42 item 12: a joint named with an emoji was written as a JSON surrogate pair, which TOML
    refuses. Any name the format accepts (a mechanism's, a link's: any text; a joint's: printable,
    no whitespace) is written so that it loads back equal, whatever its characters (beyond U+FFFF,
    DEL, quotes, backslashes, control characters)."""
    from spherekin.mechanism import mechanism_from_dict

    names = {"A", "B", "C", joint_name}
    if len(names) < 4 or joint_name in RESERVED_COLUMNS or link in ("ground", "crank", "rocker"):
        return
    joints = [{"name": n, "links": list(pair), "axis": list(axis), "actuated": n == "A"} for n, pair, axis in (
        ("A", ("ground", "crank"), (0.0, 0.0, 1.0)), ("B", ("crank", link), (0.0, 0.6, 0.8)),
        (joint_name, (link, "rocker"), (0.6, 0.8, 0.0)), ("C", ("ground", "rocker"), (1.0, 0.0, 0.0)))]
    mech = mechanism_from_dict({"kind": "graph", "name": mech_name, "ground": "ground", "joints": joints})
    path = tmp_path_factory.mktemp("names") / "m.toml"
    path.write_bytes(dumps_mechanism(mech).encode("utf-8"))
    back = load_mechanism(path)
    assert back.name == mech_name and back.joint_names == mech.joint_names
    assert back.link_graph.link_names == mech.link_graph.link_names


def test_an_emoji_joint_name_is_written_as_itself():
    from spherekin.mechanism import mechanism_from_dict
    import tomllib

    joints = [{"name": n, "links": list(pair), "axis": list(axis), "actuated": n == "A"} for n, pair, axis in (
        ("A", ("ground", "crank"), (0.0, 0.0, 1.0)), ("\U0001F9BE", ("crank", "coupler"), (0.0, 0.6, 0.8)),
        ("C", ("coupler", "rocker"), (0.6, 0.8, 0.0)), ("D", ("ground", "rocker"), (1.0, 0.0, 0.0)))]
    text = dumps_mechanism(mechanism_from_dict({"kind": "graph", "name": "arm\x7f", "ground": "ground",
                                                "joints": joints}))
    assert 'name = "\U0001F9BE"' in text and 'name = "arm\\u007f"' in text
    assert [j["name"] for j in tomllib.loads(text)["joints"]] == ["A", "\U0001F9BE", "C", "D"]


def test_a_name_with_a_lone_surrogate_is_refused_where_it_is_given():
    from spherekin.mechanism import mechanism_from_dict

    joints = [{"name": n, "links": list(pair), "axis": list(axis), "actuated": n == "A"} for n, pair, axis in (
        ("A", ("ground", "crank"), (0.0, 0.0, 1.0)), ("B", ("crank", "coupler"), (0.0, 0.6, 0.8)),
        ("C", ("coupler", "rocker"), (0.6, 0.8, 0.0)), ("D", ("ground", "rocker"), (1.0, 0.0, 0.0)))]
    with pytest.raises(ValueError, match=r"name: name '\\ud83e' is not Unicode text"):
        mechanism_from_dict({"kind": "graph", "name": "\ud83e", "ground": "ground", "joints": joints})
