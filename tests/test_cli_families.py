"""The ik, batch and map commands (in-process through spherekin.cli.main; the Dask runs are in
test_batch_engine.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from spherekin.cli import join_negative_values, main
from spherekin.mechanism import general_3rrr

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = str(ROOT / "examples" / "general_3rrr.toml")


def test_negative_values_are_joined_to_their_option():
    assert join_negative_values(["solve", "f", "--inputs", "-0.3,0.2", "--tol", "1e-6"]) == \
        ["solve", "f", "--inputs=-0.3,0.2", "--tol", "1e-6"]
    assert join_negative_values(["--euler", "-pi/2", "--x", "-.5"]) == ["--euler=-pi/2", "--x", "-.5"]
    assert join_negative_values(["--degrees", "--fix", "beta3=-1"]) == ["--degrees", "--fix", "beta3=-1"]
    # a plain negative number is argparse's own: options of several values keep them apart
    assert join_negative_values(["--beta", "-0.3", "0.2", "-5"]) == ["--beta", "-0.3", "0.2", "-5"]
    assert join_negative_values(["--euler", "-1e-3,2,3"]) == ["--euler=-1e-3,2,3"]


def test_ik_by_rotation_quaternion_and_euler_agree_and_close_every_leg(tmp_path, capsys):
    angles = [0.4, -0.3, 1.1]                                   # intrinsic ZYX, radians
    rot = Rotation.from_euler("ZYX", angles).as_matrix()
    x, y, z, w = Rotation.from_matrix(rot).as_quat()
    outs = []
    for k, opt in enumerate([["--rotation", ",".join(repr(float(v)) for v in rot.ravel())],
                             ["--quaternion", f"{-w},{-x},{-y},{-z}"],             # -q: the same rotation
                             ["--euler", ",".join(map(str, angles)), "--convention", "ZYX"]]):
        path = tmp_path / f"ik{k}.json"
        assert main(["ik", EXAMPLE, *opt, "--json", str(path)]) == 0
        outs.append(json.loads(path.read_text()))
    capsys.readouterr()
    mech = general_3rrr()
    for out in outs:
        np.testing.assert_allclose(out["platform_rotation"], rot, atol=1e-12)
        assert len(out["solutions"]) == len(outs[0]["solutions"]) == 8
        for sol in out["solutions"]:
            res = mech.forward(sol["joint_angles"])          # the pose of every leg is the rotation asked for
            for pose in res.leg_poses:
                np.testing.assert_allclose(pose, rot, atol=1e-9)
    modes = {tuple(s["working_mode"]) for s in outs[0]["solutions"]}
    assert len(modes) == 8


def test_ik_in_degrees_prints_degrees(capsys):
    assert main(["ik", EXAMPLE, "--euler", "-10,20,30", "--degrees", "--convention", "xyz"]) == 0
    out = capsys.readouterr().out
    assert "joint angles in degrees" in out and "8 solution(s)" in out


@pytest.mark.parametrize("args, match", [
    ([], "exactly one of --rotation, --quaternion, --euler"),
    (["--rotation", "1,0,0,0,1,0,0,0,1", "--quaternion", "1,0,0,0"], "exactly one of"),
    (["--rotation", "1,0,0,0,1,0,0,0"], "--rotation: expected 9"),
    (["--rotation", "2,0,0,0,1,0,0,0,1"], "--rotation: expected a rotation matrix"),
    (["--quaternion", "0,0,0,0"], "--quaternion: expected a nonzero"),
    (["--euler", "1,2,3", "--convention", "ZZY"], "convention: expected three axis letters"),
    (["--quaternion", "1,0,0,0", "--convention", "ZYX"], "--convention: only with --euler"),
    (["--quaternion", "1,0,0,0", "--json", "/nonexistent/ik.json"], "the directory /nonexistent does not exist"),
])
def test_ik_bad_poses_are_one_clear_error(capsys, args, match):
    assert main(["ik", EXAMPLE, *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("spherekin: error: ") and match in err


def test_batch_bad_csv_is_refused_before_any_work_and_nothing_is_written(tmp_path, capsys):
    csv = tmp_path / "in.csv"
    csv.write_text("beta1,beta2,beta3\n0,0,0\n0.1,zero,0\n")
    out = tmp_path / "r.csv"
    assert main(["batch", EXAMPLE, "--inputs", str(csv), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{csv} line 3, column beta2: expected a finite number, got 'zero'" in err
    assert not out.exists()


@pytest.mark.parametrize("args, match", [
    (["--grid", "beta1=0:1:3", "--fix", "beta2=0"], "no value for beta3"),
    (["--grid", "beta1=0:1"], "expected name=lo:hi:n"),
    (["--grid", "beta1=0:1:3", "--fix", "beta2=0", "--fix", "beta3=0", "--out", "r.txt"], "expected a .parquet"),
    ([], "expected the inputs"),
])
def test_batch_bad_specs_are_one_clear_error(tmp_path, capsys, monkeypatch, args, match):
    monkeypatch.chdir(tmp_path)
    full = args if "--out" in args else [*args, "--out", "r.csv"]
    assert main(["batch", EXAMPLE, *full]) == 2
    assert match in capsys.readouterr().err
    assert not (tmp_path / "r.csv").exists()


def test_batch_in_process_writes_the_documented_table(tmp_path, capsys):
    out = tmp_path / "r.csv"
    assert main(["batch", EXAMPLE, "--grid", "beta1=-1:1:3", "--fix", "beta2=-0.2", "--fix", "beta3=0.5",
                 "--out", str(out), "--workers", "0"]) == 0
    assert "3 input(s) solved in this process" in capsys.readouterr().out
    frame = pd.read_csv(out)
    assert list(frame["input"].unique()) == [0, 1, 2]
    np.testing.assert_array_equal(frame.groupby("input")["beta1"].first(), [-1.0, 0.0, 1.0])
    assert (frame["beta2"] == -0.2).all()


def test_map_draws_the_figure_and_writes_the_table(tmp_path, capsys):
    png, table = tmp_path / "map.png", tmp_path / "map.csv"
    assert main(["map", EXAMPLE, "--grid", "beta1=-3:3:5", "--grid", "beta2=-3:3:4", "--fix", "beta3=0.5",
                 "--plot", str(png), "--table", str(table), "--singularity", "--workers", "0"]) == 0
    out = capsys.readouterr().out
    assert "grid points" in out and f"wrote {png}" in out
    assert png.stat().st_size > 10_000
    t = pd.read_csv(table)
    assert len(t) == 20 and list(t.columns[:3]) == ["beta1", "beta2", "solutions"]
    assert (t["solutions"] % 2 == 0).all()          # the real assemblies of a 3-RRR come in pairs (degree 8 over R)


@pytest.mark.parametrize("args, match", [
    (["--grid", "beta1=-3:3:5", "--fix", "beta2=0", "--fix", "beta3=0"], "exactly two grid axes"),
    (["--grid", "beta1=-3:3:5", "--grid", "beta2=-3:3:5", "--fix", "beta3=0", "--plot", "m.jpg"], "expected a file name ending"),
    (["--grid", "beta1=-3:3:5", "--grid", "beta2=-3:3:5", "--fix", "beta3=0", "--table", "m.txt"], "expected a .csv"),
])
def test_map_bad_arguments_are_refused_before_any_solve(tmp_path, capsys, monkeypatch, args, match):
    monkeypatch.chdir(tmp_path)
    assert main(["map", EXAMPLE, *args]) == 2
    err = capsys.readouterr().err
    assert match in err
    assert "grid points" not in err


def _write_path(tmp_path, xs):
    p = tmp_path / "path.csv"
    p.write_text("beta1,beta2,beta3\n" + "".join(f"{float(x)!r},0,0.5\n" for x in xs))
    return p


def test_track_writes_the_rows_json_and_checks_against_full_solves(tmp_path, capsys):
    xs = np.linspace(-3.0, -2.8, 9)
    path = _write_path(tmp_path, xs)
    out, js = tmp_path / "t.csv", tmp_path / "t.json"
    assert main(["track", EXAMPLE, "--path", str(path), "--start-solution", "2", "--check", "4",
                 "--out", str(out), "--json", str(js)]) == 0
    text = capsys.readouterr().out
    assert "9 of 9 row(s) tracked" in text and "check: at 3 row(s) the tracked pose is one of the solutions" in text
    from spherekin.batch.rows import columns

    frame = pd.read_csv(out)
    assert list(frame.columns) == list(columns(general_3rrr()))
    assert list(frame["input"]) == list(range(9)) and (frame["status"] == "certified").all()
    data = json.loads(js.read_text())
    assert data["stop"] is None and len(data["poses"]) == 9
    # the same start by rotation gives the same rows
    rot = np.array(data["poses"][0]["platform_rotation"])
    assert main(["track", EXAMPLE, "--path", str(path), "--start-rotation",
                 ",".join(repr(float(v)) for v in rot.ravel()), "--json", str(js)]) == 0
    again = json.loads(js.read_text())
    np.testing.assert_allclose([r["platform_rotation"] for r in again["poses"]],
                               [r["platform_rotation"] for r in data["poses"]], atol=1e-13)


def test_track_reports_the_singularity_where_the_mode_ends(tmp_path, capsys):
    path = _write_path(tmp_path, np.linspace(-3.0, -2.6, 9))
    stops = 0
    for k in range(1, 7):
        assert main(["track", EXAMPLE, "--path", str(path), "--start-solution", str(k)]) == 0
        text = capsys.readouterr().out
        if "stopped between rows" in text:
            stops += 1
            assert "a parallel singularity" in text and "-2.7141013" in text
    assert stops == 2


@pytest.mark.parametrize("args, match", [
    ([], "exactly one of --start-rotation"),
    (["--start-solution", "0"], "solution number >= 1"),
    (["--start-solution", "9"], "--start-solution: expected a solution number 1..8"),
    (["--start-quaternion", "1,0,0,0"], "does not close the legs"),
    (["--start-solution", "1", "--plot", "x.gif"], "expected a file name ending"),
    (["--start-solution", "1", "--json", "nodir/t.json"], "--json nodir/t.json: the directory nodir does not exist"),
])
def test_track_bad_starts_are_one_clear_error(tmp_path, capsys, monkeypatch, args, match):
    monkeypatch.chdir(tmp_path)
    path = _write_path(tmp_path, [0.3, 0.35])
    assert main(["track", EXAMPLE, "--path", str(path), *args]) == 2
    assert match in capsys.readouterr().err
