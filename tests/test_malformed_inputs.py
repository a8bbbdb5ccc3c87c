"""Inputs that cannot be misread (issue 28, items 5-7): the fuzz corpus of malformed mechanism and
input files (tests/data/malformed/, its expected errors in expected.toml) through the command line,
joint names against the columns of the results, the bound on the angles of a mechanism, a TOML file
with a byte-order mark, digits of other scripts, and a CSV header of 80,000 columns."""

from __future__ import annotations

import math
import tomllib
from fractions import Fraction
from pathlib import Path

import mpmath
import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

import spherekin
from spherekin.batch import read_results
from spherekin.cli import main
from spherekin.core.angles import MAX_GEOMETRY_ANGLE, RANGE_TOL, TWO_PI, wrap
from spherekin.core.columns import RESERVED_COLUMNS
from spherekin.mechanism import Joint, general_3rrr, load_mechanism, three_rrr
from spherekin.mechanism.checks import check_range

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "data" / "malformed"
EXPECTED = tomllib.loads((CORPUS / "expected.toml").read_text(encoding="utf-8"))
GOSSELIN = str(ROOT / "examples" / "gosselin.toml")
FOUR_BAR = ROOT / "examples" / "four_bar.toml"


def _command(path: Path, tmp_path: Path) -> list[str]:
    if path.suffix == ".toml":
        return ["solve", str(path), "--inputs", "0"]
    return ["batch", GOSSELIN, "--inputs", str(path), "--out", str(tmp_path / "out.csv")]


def _refused(argv, capsys) -> str:
    """The one error line of a command that must be refused: exit 2, nothing on stdout."""
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err[:2000]
    assert lines[0].startswith("spherekin: error: ")
    return lines[0]


def test_every_file_of_the_corpus_has_an_expected_error():
    files = sorted(p.name for p in CORPUS.iterdir() if p.name != "expected.toml")
    assert files == sorted(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_a_malformed_file_is_one_clear_error_naming_it(name, tmp_path, capsys):
    path = CORPUS / name
    line = _refused(_command(path, tmp_path), capsys)
    assert str(path) in line
    assert EXPECTED[name] in line
    assert len(line) < 500                         # one readable line, whatever the file holds
    assert not (tmp_path / "out.csv").exists()


def test_a_header_of_80000_columns_is_refused_in_a_short_message(tmp_path, capsys):
    # the header check is linear (a Counter, not list.count per column); the message names the first
    # few columns and counts the rest (it printed 790 KB)
    wide, twice = tmp_path / "wide.csv", tmp_path / "twice.csv"
    wide.write_text(",".join(f"c{k}" for k in range(80_000)) + "\n" + ",".join("0" * 80_000) + "\n")
    twice.write_text(",".join(f"c{k % 40_000}" for k in range(80_000)) + "\n" + ",".join("0" * 80_000) + "\n")
    line = _refused(["batch", GOSSELIN, "--inputs", str(wide), "--out", str(tmp_path / "o.csv")], capsys)
    assert "unexpected column(s) 'c0', 'c1', 'c2', 'c3', 'c4' and 79995 more" in line and len(line) < 400
    line = _refused(["batch", GOSSELIN, "--inputs", str(twice), "--out", str(tmp_path / "o.csv")], capsys)
    assert "columns c0, c1, c2, c3, c4 and 39995 more appear more than once" in line and len(line) < 400


def test_an_angle_beyond_a_turn_is_refused_on_the_command_line_and_in_a_csv(tmp_path, capsys):
    # 1e17 rad reduced modulo 2 pi in doubles keeps no digit: refused, not solved for another angle
    line = _refused(["solve", GOSSELIN, "--inputs", "1e17,0,0"], capsys)
    assert "--inputs (beta1): 1e+17 is more than a full turn in radians" in line
    path = CORPUS / "angle_1e17.csv"
    assert str(path) in _refused(_command(path, tmp_path), capsys)


def test_non_ascii_digits_are_refused_in_every_angle_and_count_typed(tmp_path, capsys):
    # float("٣") == 3.0 and int("٣") == 3 in Python: each reader of typed numbers refuses them
    assert float("\u0663") == 3.0
    line = _refused(["solve", GOSSELIN, "--inputs", "\u0663,0,0"], capsys)
    assert "--inputs (beta1): expected a number in the ASCII digits 0-9" in line and "U+0663" in line
    line = _refused(["batch", GOSSELIN, "--grid", "beta1=0:1:\u0663", "--fix", "beta2=0", "--fix", "beta3=0",
                     "--out", str(tmp_path / "o.csv")], capsys)
    assert "--grid beta1: expected a whole number of points n >= 2 (digits 0-9), got '\u0663'" in line
    line = _refused(["batch", GOSSELIN, "--grid", "beta1=0:1:3", "--fix", "beta2=0.\u0665", "--fix", "beta3=0",
                     "--out", str(tmp_path / "o.csv")], capsys)
    assert "--fix beta2: expected a number in the ASCII digits 0-9" in line
    line = _refused(["ik", GOSSELIN, "--quaternion", "1,0,0,\u0660"], capsys)
    assert "--quaternion: expected a number in the ASCII digits 0-9, got '1,0,0,\u0660'" in line


def test_a_mechanism_file_with_a_byte_order_mark_reads_as_without(tmp_path):
    plain = FOUR_BAR.read_bytes()
    marked = tmp_path / "bom.toml"
    marked.write_bytes(b"\xef\xbb\xbf" + plain)
    a, b = load_mechanism(FOUR_BAR), load_mechanism(marked)
    assert a.joints == b.joints and a.name == b.name and a.reference_leg == b.reference_leg


# ------------------------------------------------------------------ joint names and columns

def test_the_reserved_names_are_the_fixed_columns_of_every_table(tmp_path, capsys):
    # independent of RESERVED_COLUMNS' construction: the columns of the tables actually written
    # (a batch's results, a map's table, a track's frame) that are not joints are all reserved
    assert main(["batch", GOSSELIN, "--grid", "beta1=0:0.2:2", "--fix", "beta2=0", "--fix", "beta3=0",
                 "--out", str(tmp_path / "r.csv"), "--quiet"]) == 0
    table = pd.read_csv(tmp_path / "r.csv")
    joints = {f"{p}{i}" for p in ("beta", "gamma", "delta") for i in (1, 2, 3)}
    fixed = [c for c in table.columns if c not in joints]
    assert fixed == ["input", "solution", "status", "qw", "qx", "qy", "qz", *(f"r{i}{j}" for i in (1, 2, 3)
                     for j in (1, 2, 3)), "residual", "singularity", "parallel_measure"]
    assert set(fixed) <= set(RESERVED_COLUMNS)
    assert main(["map", GOSSELIN, "--grid", "beta1=0:0.2:2", "--grid", "beta2=0:0.2:2", "--fix", "beta3=0",
                 "--table", str(tmp_path / "m.csv")]) == 0
    capsys.readouterr()
    assert {c for c in pd.read_csv(tmp_path / "m.csv").columns if c not in joints} <= set(RESERVED_COLUMNS)
    problem = spherekin.compile(general_3rrr())
    frame = problem.track([[-3.1, 0.0, 0.5], [-3.075, 0.0, 0.5]], start=0).frame()    # a track's frame
    assert {c for c in frame.columns if c not in problem.mechanism.joint_names} <= set(RESERVED_COLUMNS)


@pytest.mark.parametrize("name", ["residual", "qw", "r11", "status", "B,x", "B x", "B=x", 'B"x', "B\nx", "B\u00a0x",
                                  "B\x07x"])
def test_a_joint_is_not_named_like_a_column_or_with_csv_syntax(name):
    with pytest.raises(ValueError, match=r"^name: joint name .*(holds|is the name of a column)"):
        Joint(name, (0.0, 0.0, 1.0))


def test_unusual_joint_names_write_a_csv_and_a_parquet_that_read_back_equal(tmp_path, capsys):
    names = {'"A"': '"β-1"', '"B"': '"a:b"', '"D"': '"NA"', '"C"': '"#c/1"'}
    text = FOUR_BAR.read_text()
    for old, new in names.items():
        assert f"name = {old}" in text
        text = text.replace(f"name = {old}", f"name = {new}")
    mech_file = tmp_path / "odd.toml"
    mech_file.write_text(text)
    inputs = tmp_path / "in.csv"
    inputs.write_text("β-1\n0.1\n0.5\n-0.4\n")
    frames = {}
    for suffix in (".csv", ".parquet"):
        out = tmp_path / f"out{suffix}"
        assert main(["batch", str(mech_file), "--inputs", str(inputs), "--out", str(out), "--quiet"]) == 0
        frames[suffix] = read_results(out)
        raw = pd.read_csv(out) if suffix == ".csv" else pd.concat(
            [pd.read_parquet(p) for p in sorted(out.glob("part-*.parquet"))], ignore_index=True)
        assert list(raw.columns[:7]) == ["input", "β-1", "solution", "status", "a:b", "NA", "#c/1"]
        assert list(raw.columns) == list(frames[suffix].columns)
    capsys.readouterr()
    csv_frame, pq_frame = frames[".csv"], frames[".parquet"]
    pd.testing.assert_frame_equal(csv_frame, pq_frame, check_dtype=False, rtol=0, atol=1e-15)
    assert sorted(set(csv_frame["β-1"])) == [-0.4, 0.1, 0.5]
    assert len(csv_frame) > 0
    # columns not shifted: the crank leg's joints (β-1 about z, a:b about (0, 0.5, sqrt 3/2), reference
    # readings 0) give the platform rotation of each row (product of exponentials, by scipy)
    mech = load_mechanism(mech_file)
    a, b = (np.array(j.axis) for j in mech.leg("crank").joints)
    for _, row in csv_frame.iterrows():
        rot = (Rotation.from_rotvec(a * row["β-1"]) * Rotation.from_rotvec(b * row["a:b"])).as_matrix()
        got = row[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(float).reshape(3, 3)
        np.testing.assert_allclose(got, rot @ mech.platform_reference_matrix, atol=1e-12)


# ------------------------------------------------------------------ the bound on a mechanism's angles

def test_the_geometry_bound_keeps_the_reduction_within_the_range_tolerance():
    # the reason of MAX_GEOMETRY_ANGLE, checked with exact arithmetic: the double nearest the bound,
    # reduced modulo 2 pi as the package does (wrap), against its reduction with pi to 50 digits
    def exactly_reduced(theta: float) -> float:
        with mpmath.workdps(50):
            x = mpmath.mpf(Fraction(theta).numerator) / Fraction(theta).denominator     # the double, exactly
            return float(x - 2 * mpmath.pi * mpmath.floor((x + mpmath.pi) / (2 * mpmath.pi)))

    for theta in (MAX_GEOMETRY_ANGLE, -MAX_GEOMETRY_ANGLE, 12345.678, math.nextafter(MAX_GEOMETRY_ANGLE, 0.0)):
        assert abs(exactly_reduced(theta) - wrap(theta)) < RANGE_TOL / 4
    # far beyond it the reduction is off by radians: 1e17 / 2 pi turns times the error of the double 2 pi
    assert abs(exactly_reduced(1e17) - wrap(1e17)) > 0.1


def test_angles_of_a_mechanism_beyond_the_bound_are_refused_with_the_reason():
    beyond = math.nextafter(MAX_GEOMETRY_ANGLE, math.inf)
    assert Joint("j", (0.0, 0.0, 1.0), reference_angle=MAX_GEOMETRY_ANGLE).reference_angle == MAX_GEOMETRY_ANGLE
    with pytest.raises(ValueError, match="^reference_angle: expected an angle within 100000 rad of 0, got 100000: "
                                         "angles are read modulo 2 pi, and reducing this one would lose digits"):
        Joint("j", (0.0, 0.0, 1.0), reference_angle=beyond)
    assert check_range("r", (MAX_GEOMETRY_ANGLE - 1.0, MAX_GEOMETRY_ANGLE)) == (MAX_GEOMETRY_ANGLE - 1.0, MAX_GEOMETRY_ANGLE)
    with pytest.raises(ValueError, match=r"^r\[1\]: expected an angle within 100000 rad"):
        check_range("r", (MAX_GEOMETRY_ANGLE - 1.0, beyond))
    with pytest.raises(ValueError, match=r"^r\[0\]: expected a finite angle in radians, got an integer of about 401 digits"):
        check_range("r", (10 ** 400, 0))
    eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]
    elbows = [[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]
    platform = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    with pytest.raises(ValueError, match=r"^joint_offsets.gamma2: expected an angle within 100000 rad of 0, got 1e\+300"):
        three_rrr(eye, elbows, platform, ["pi/2"] * 3, joint_offsets={"gamma2": 1e300})
    # an offset within the bound moves the reading by exactly that much, reduced modulo 2 pi
    plain = three_rrr(eye, elbows, platform, ["pi/2"] * 3)
    moved = three_rrr(eye, elbows, platform, ["pi/2"] * 3, joint_offsets={"gamma2": 1000.0})
    shift = plain.joint("gamma2").reference_angle - moved.joint("gamma2").reference_angle
    assert abs(math.remainder(shift - 1000.0, TWO_PI)) < 1e-12
