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

from spherekin.cli import protect_negative_values, main
from spherekin.mechanism import general_3rrr

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = str(ROOT / "examples" / "general_3rrr.toml")


def test_negative_values_are_read_as_values():
    assert protect_negative_values(["solve", "f", "--inputs", "-0.3,0.2", "--tol", "1e-6"]) == \
        ["solve", "f", "--inputs", " -0.3,0.2", "--tol", "1e-6"]
    assert protect_negative_values(["--euler", "-pi/2", "--x", "-.5"]) == ["--euler", " -pi/2", "--x", "-.5"]
    assert protect_negative_values(["--degrees", "--fix", "beta3=-1"]) == ["--degrees", "--fix", "beta3=-1"]
    # a plain negative number is argparse's own: options of several values keep them apart
    assert protect_negative_values(["--beta", "-0.3", "0.2", "-5"]) == ["--beta", "-0.3", "0.2", "-5"]
    assert protect_negative_values(["--euler", "-1e-3,2,3"]) == ["--euler", " -1e-3,2,3"]


def test_an_option_of_several_values_takes_negative_angles(capsys):
    # --beta takes three values: -pi/2 must stay one of them (independent: the printed actuators)
    assert main(["gosselin", "--beta", "-pi/2", "0", "-pi/4", "--samples", "10"]) == 0
    out = capsys.readouterr().out
    assert f"beta = ({-math.pi / 2:+.4f}, +0.0000, {-math.pi / 4:+.4f}) rad" in out
    assert main(["solve", EXAMPLE, "--inputs", "-pi/2,0.2,-0.5", "--quiet"]) == 0
    assert f"beta1 = {-math.pi / 2:+.6g} rad" in capsys.readouterr().out
    assert main(["solve", EXAMPLE, "--inputs", "-0.3x,0.2,0.5"]) == 2
    assert "got '-0.3x'" in capsys.readouterr().err               # the value as typed


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
    (["--start-solution", "0"], "--start-solution: expected a whole number from 1 to 8"),
    (["--start-solution", "9"], "--start-solution: expected a whole number from 1 to 8"),
    (["--start-quaternion", "1,0,0,0"], "does not close the legs"),
    (["--start-solution", "1", "--plot", "x.gif"], "expected a file name ending"),
    (["--start-solution", "1", "--json", "nodir/t.json"], "--json nodir/t.json: the directory nodir does not exist"),
])
def test_track_bad_starts_are_one_clear_error(tmp_path, capsys, monkeypatch, args, match):
    monkeypatch.chdir(tmp_path)
    path = _write_path(tmp_path, [0.3, 0.35])
    assert main(["track", EXAMPLE, "--path", str(path), *args]) == 2
    assert match in capsys.readouterr().err


def test_ik_prints_no_minus_zero(capsys):
    # rotation by 90 deg about x: delta2 of four working modes is 0 up to rounding (about -1e-15)
    gosselin = str(ROOT / "examples" / "gosselin.toml")
    assert main(["ik", gosselin, "--euler", "0,0,90", "--degrees"]) == 0
    out = capsys.readouterr().out
    assert "-0.000000" not in out
    rows = [line.split() for line in out.splitlines()[3:]]      # after the pose, count and header lines
    assert len(rows) == 8 and sum(r[8] == "+0.000000" for r in rows) == 4   # r[8]: delta2


def test_batch_in_degrees_says_the_table_holds_radians(tmp_path, capsys):
    out = tmp_path / "r.csv"
    assert main(["batch", EXAMPLE, "--grid", "beta1=-90:90:2", "--fix", "beta2=0", "--fix", "beta3=30",
                 "--degrees", "--out", str(out), "--workers", "0", "--quiet"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "--degrees: inputs read in degrees" in header and "holds radians" in header
    frame = pd.read_csv(out)
    np.testing.assert_allclose(sorted(set(frame["beta1"])), [-np.pi / 2, np.pi / 2], rtol=1e-15)
    np.testing.assert_allclose(frame["beta3"], np.pi / 6, rtol=1e-15)


# ---------------------------------------------------------------- track: ranges, numbers, names (issue 27)

#: The path of tests/test_continuation.py along which gamma1 of one assembly leaves [-0.9 pi, 0.9 pi]
#: between rows 13 and 14.
RANGE_XS = np.linspace(0.07, 0.67, 41)


def _ranged_example(tmp_path) -> Path:
    """examples/general_3rrr.toml with gamma1 = ["-0.9*pi", "0.9*pi"] (docs/mechanism-format.md)."""
    text = Path(EXAMPLE).read_text().replace("# [joint_ranges]", "[joint_ranges]")
    text = text.replace('# beta1 = ["-pi/2", "pi/2"]', 'gamma1 = ["-0.9*pi", "0.9*pi"]')
    assert 'gamma1 = ["-0.9*pi"' in text
    out = tmp_path / "ranged.toml"
    out.write_text(text)
    return out


def test_track_stops_where_a_joint_leaves_its_range_in_stdout_json_and_csv(tmp_path, capsys):
    from spherekin import compile as compile_problem
    from spherekin.mechanism import load_mechanism

    toml = _ranged_example(tmp_path)
    path = tmp_path / "path.csv"
    path.write_text("beta1,beta2,beta3\n" + "".join(f"{float(x)!r},2.83,-2.24\n" for x in RANGE_XS))
    report = compile_problem(load_mechanism(toml)).solve([RANGE_XS[0], 2.83, -2.24])
    number = 1 + next(k for k, s in enumerate(report.solutions) if -2.7 < s.passive_angles["gamma1"] < -2.6)
    out, js = tmp_path / "t.csv", tmp_path / "t.json"
    assert main(["track", str(toml), "--path", str(path), "--start-solution", str(number), "--check", "5",
                 "--out", str(out), "--json", str(js)]) == 0
    text = capsys.readouterr().out
    assert "14 of 41 row(s) tracked" in text
    assert "stopped between rows 13 and 14: gamma1 leaves its joint range" in text
    data = json.loads(js.read_text())
    assert data["complete"] is False and len(data["poses"]) == 14
    stop = data["stop"]
    assert stop["kind"] == "range" and stop["joint"] == "gamma1" and stop["between_rows"] == [13, 14]
    assert stop["joint_range"] == pytest.approx([-0.9 * np.pi, 0.9 * np.pi], abs=1e-15)
    assert 0.2717 < stop["last_proven_inputs"]["beta1"] < stop["exit_inputs"]["beta1"] < 0.2719
    assert all(abs(p["passive_angles"]["gamma1"]) <= 0.9 * np.pi for p in data["poses"])
    assert data["check"] == {"rows": [0, 5, 10, 13], "mismatched_rows": [], "passed": True}
    # one measure: the CSV's parallel_measure (batch's column), the JSON's and the printed one
    frame = pd.read_csv(out)
    assert len(frame) == 14 and list(frame["solution"]) == [1] * 14
    measures = [p["parallel_measure"] for p in data["poses"]]
    np.testing.assert_allclose(frame["parallel_measure"], measures, rtol=1e-12)
    lines = text.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:1] == ["row"])
    assert lines[head].split()[-1] == "parallel_measure"
    printed = [float(line.split()[-1]) for line in lines[head + 1:head + 15]]
    np.testing.assert_allclose(printed, measures, rtol=1e-4)


def test_track_check_mismatch_exits_1_and_the_json_says_so(tmp_path, capsys, monkeypatch):
    import spherekin.cli.track as cli

    monkeypatch.setattr(cli, "CHECK_MATCH", -1.0)          # no full solve can then match a tracked pose
    path = _write_path(tmp_path, np.linspace(-3.0, -2.8, 5))
    js = tmp_path / "t.json"
    assert main(["track", EXAMPLE, "--path", str(path), "--start-solution", "2", "--check", "2",
                 "--json", str(js)]) == 1
    assert "NOT among the solutions of the full solve at row(s) 0, 2, 4" in capsys.readouterr().err
    assert json.loads(js.read_text())["check"] == {"rows": [0, 2, 4], "mismatched_rows": [0, 2, 4], "passed": False}


def test_one_number_for_a_solution_in_the_table_the_json_the_csv_and_start_solution(tmp_path, capsys):
    from spherekin import compile as compile_problem
    from spherekin.mechanism import load_mechanism

    x = [-3.0, 0.0, 0.5]
    js = tmp_path / "s.json"
    assert main(["solve", EXAMPLE, "--inputs", ",".join(map(str, x)), "--json", str(js)]) == 0
    lines = capsys.readouterr().out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.lstrip().startswith("#"))
    printed = {int(line.split()[0]): [float(v) for v in line.split()[1:7]]
               for line in lines[head + 1:] if line.split() and line.split()[0].isdigit()}
    assert sorted(printed) == list(range(1, 7))
    data = json.loads(js.read_text())
    assert [s["number"] for s in data["solutions"]] == list(range(1, 7))
    inputs = tmp_path / "in.csv"
    inputs.write_text("beta1,beta2,beta3\n" + ",".join(map(str, x)) + "\n")
    out = tmp_path / "b.csv"
    assert main(["batch", EXAMPLE, "--inputs", str(inputs), "--out", str(out)]) == 0
    frame = pd.read_csv(out)
    assert list(frame["solution"]) == list(range(1, 7))
    path = _write_path(tmp_path, np.linspace(-3.0, -2.9, 3))
    mech = load_mechanism(EXAMPLE)
    problem = compile_problem(mech)
    report = problem.solve(x)
    names = list(mech.loop_unknowns)
    for number in range(1, 7):
        from_json = next(s for s in data["solutions"] if s["number"] == number)["passive_angles"]
        from_csv = frame[frame["solution"] == number][names].to_numpy(float)[0]
        np.testing.assert_allclose(printed[number], [from_json[n] for n in names], atol=1e-6)
        np.testing.assert_allclose(from_csv, [from_json[n] for n in names], atol=1e-12)
        tj = tmp_path / f"t{number}.json"
        assert main(["track", EXAMPLE, "--path", str(path), "--start-solution", str(number), "--json", str(tj)]) == 0
        first = json.loads(tj.read_text())["poses"][0]["passive_angles"]
        np.testing.assert_allclose([first[n] for n in names], [from_json[n] for n in names], atol=1e-12)
        # Python: report.solutions[number - 1] is solution `number`; start= takes it, or its index
        for start in (report.solutions[number - 1], number - 1):
            tr = problem.track(np.array([x, x]), start=start)
            np.testing.assert_allclose(list(tr.poses[0].passive_angles.values()), [from_json[n] for n in names],
                                       atol=1e-12)
    capsys.readouterr()


def test_track_json_is_track_as_dict_and_python_gives_the_same_steps(tmp_path, capsys):
    from spherekin import compile as compile_problem
    from spherekin.batch import read_inputs_csv
    from spherekin.mechanism import load_mechanism

    path = str(ROOT / "examples" / "path_general_3rrr.csv")
    js = tmp_path / "t.json"
    assert main(["track", EXAMPLE, "--path", path, "--start-solution", "5", "--json", str(js)]) == 0
    capsys.readouterr()
    cli_json = json.loads(js.read_text())
    assert cli_json["stop"]["kind"] == "singular"               # the README's example: it meets the fold
    mech = load_mechanism(EXAMPLE)
    problem = compile_problem(mech)
    rows = read_inputs_csv(mech, path).values
    report = problem.solve(rows[0])
    tr = problem.track(rows, start=report.solutions[4])          # solution 5, as --start-solution 5
    assert json.loads(json.dumps(tr.as_dict())) == cli_json          # every number, step totals included


def test_ik_json_numbers_its_solutions_as_printed(tmp_path, capsys):
    js = tmp_path / "ik.json"
    assert main(["ik", EXAMPLE, "--euler", "0.4,-0.3,1.1", "--json", str(js)]) == 0
    lines = capsys.readouterr().out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["#", "mode"])
    names = lines[head].split()[2:-2]
    printed = {int(line.split()[0]): [float(v) for v in line.split()[2:2 + len(names)]]
               for line in lines[head + 1:] if line.split() and line.split()[0].isdigit()}
    data = json.loads(js.read_text())
    assert [s["number"] for s in data["solutions"]] == sorted(printed) == list(range(1, 9))
    for s in data["solutions"]:
        np.testing.assert_allclose(printed[s["number"]], [s["joint_angles"][n] for n in names], atol=1e-6)


def test_an_interrupt_while_the_json_is_written_leaves_the_earlier_file_and_no_temporary(tmp_path, capsys,
                                                                                         monkeypatch):
    """Ctrl-C arriving while `--json` is written (half the text in the file): exit 130, the earlier output
    untouched (not a cut JSON), no temporary left beside it."""
    import pathlib

    js = tmp_path / "ik.json"
    js.write_text('{"earlier": true}')
    real = pathlib.Path.write_text

    def cut(self, text, *a, **k):
        real(self, text[:len(text) // 2], *a, **k)
        raise KeyboardInterrupt

    monkeypatch.setattr(pathlib.Path, "write_text", cut)
    assert main(["ik", EXAMPLE, "--euler", "0.4,-0.3,1.1", "--json", str(js)]) == 130
    monkeypatch.undo()
    assert json.loads(js.read_text()) == {"earlier": True}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ik.json"]


def _ik_rows(lines: list[str]) -> dict:
    """number -> (joint angles, in range) of the printed ik table."""
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["#", "mode"])
    n = len(lines[head].split()) - 4
    return {int(w[0]): ([float(v) for v in w[2:2 + n]], w[2 + n] == "yes")
            for w in (line.split() for line in lines[head + 1:]) if w and w[0].isdigit()}


def test_ik_in_range_keeps_each_solutions_number(tmp_path, capsys):
    """`ik --in-range` shows the solutions inside every range under the numbers they have without it
    (issue 42 item 7: #1 with it was #5 without it). The range on gamma1 is tested here, not by the code."""
    text = (ROOT / "examples" / "general_3rrr.toml").read_text()
    path = tmp_path / "ranged.toml"
    path.write_text(text.replace('# [joint_ranges]\n# beta1 = ["-pi/2", "pi/2"]', '[joint_ranges]\ngamma1 = [0.0, 3.0]'))
    args = ["ik", str(path), "--euler", "0.4,-0.3,1.1"]
    assert main(args) == 0
    every = _ik_rows(capsys.readouterr().out.splitlines())
    js = tmp_path / "ik.json"
    assert main([*args, "--in-range", "--json", str(js)]) == 0
    kept = _ik_rows(capsys.readouterr().out.splitlines())
    inside = {k for k, (angles, _) in every.items() if 0.0 <= angles[3] % (2 * math.pi) <= 3.0}   # gamma1's column
    assert 0 < len(inside) < len(every) and set(kept) == inside
    for k, (angles, flag) in kept.items():
        assert flag and angles == every[k][0]
    assert [s["number"] for s in json.loads(js.read_text())["solutions"]] == sorted(inside)
