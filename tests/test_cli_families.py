"""The ik, batch and map commands (in-process through spherekin.cli.main; the Dask runs are in
test_batch_engine.py)."""

from __future__ import annotations

import json
import math
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
    assert join_negative_values(["--euler", "-pi/2", "--x", "-.5"]) == ["--euler=-pi/2", "--x=-.5"]
    assert join_negative_values(["--degrees", "--fix", "beta3=-1"]) == ["--degrees", "--fix", "beta3=-1"]


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
