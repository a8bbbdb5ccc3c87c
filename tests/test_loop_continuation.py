"""Certified tracking on the loop equations (spherekin.trust.loop_continuation), for mechanisms the
platform tracker does not apply to, against references written here: the spherical four-bar's
closed form (the coupler as a circle-circle intersection on the unit sphere) and the five-bar as two
circles on the sphere. Nothing here uses spherekin's solver for the expected numbers."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from spherekin.cli import main
from spherekin.mechanism import five_bar, four_bar, load_mechanism
from spherekin.problem import compile as compile_problem
from spherekin.trust.continuation import RangeStop, SingularStop, Track, TrackedPose

# The axes of examples/four_bar.toml (its reference assembly: every reading 0).
AXES = {"A": (0.0, 0.0, 1.0), "B": (0.0, 0.5, 0.8660254037844387),
        "D": (0.9848077530122081, 0.0, 0.17364817766693044),
        "C": (0.5242414154116771, 0.8463950507266184, -0.09373556674308138)}


def four_bar_file(tmp_path, actuated: str, ranges: dict | None = None):
    """examples/four_bar.toml's linkage with the joints ``actuated`` (e.g. "D", "AD") driven and
    optional joint ranges (radians)."""
    ranges = ranges or {}
    text = 'kind = "general"\nname = "four-bar"\nreference_leg = "crank"\n'
    for leg, joints in (("crank", "AB"), ("rocker", "DC")):
        text += f'\n[[legs]]\nname = "{leg}"\n'
        for j in joints:
            text += f'\n[[legs.joints]]\nname = "{j}"\naxis = {list(AXES[j])}\n'
            text += "actuated = true\n" if j in actuated else ""
            text += f"range = [{ranges[j][0]!r}, {ranges[j][1]!r}]\n" if j in ranges else ""
    path = tmp_path / f"four_bar_{actuated}.toml"
    path.write_text(text)
    return path


def rot(axis, t):
    """Rot(axis, t) (Rodrigues), radians."""
    a = np.asarray(axis, dtype=float)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(t) * k + (1.0 - math.cos(t)) * k @ k


def circles(p, q, cos_p, cos_q):
    """X = a p + b q + c (p x q) on the unit sphere with X.p = cos_p, X.q = cos_q: (a, b, the
    discriminant c^2 |p x q|^2; two points when > 0, the branch point when 0)."""
    g = float(p @ q)
    a = (cos_p - g * cos_q) / (1.0 - g * g)
    b = (cos_q - g * cos_p) / (1.0 - g * g)
    return a, b, 1.0 - (a * a + b * b + 2.0 * a * b * g)


def meet(p, q, cos_p, cos_q, sign):
    """The intersection point of the two circles on the side ``sign`` of p x q."""
    a, b, disc = circles(p, q, cos_p, cos_q)
    n = np.cross(p, q)
    return a * p + b * q + sign * math.sqrt(max(disc, 0.0) / float(n @ n)) * n


def reading(axis, x0, x):
    """The angle t with x = Rot(axis, t) x0 (x0, x at the same angle from the axis), radians."""
    axis = np.asarray(axis, dtype=float)
    return math.atan2(float(x @ np.cross(axis, x0)), float(x @ (x0 - (x0 @ axis) * axis)))


A, B, C, D = (np.array(AXES[n]) for n in "ABCD")


def rocker_of_crank(theta, sign):
    """Closed form of the four-bar driven at A: the reading of D for the crank reading theta."""
    c = meet(rot(A, theta) @ B, D, float(B @ C), float(C @ D), sign)
    return reading(D, C, c)


def crank_of_rocker(phi, sign):
    """Closed form of the four-bar driven at D: the reading of A for the rocker reading phi."""
    b = meet(A, rot(D, phi) @ C, float(A @ B), float(B @ C), sign)
    return reading(A, B, b)


def rocker_disc(phi):
    return circles(A, rot(D, phi) @ C, float(A @ B), float(B @ C))[2]


def branch_point(lo, hi):
    """The rocker input where the two assemblies meet (the discriminant's sign change in [lo, hi])."""
    assert rocker_disc(lo) > 0 > rocker_disc(hi)
    while hi - lo > 1e-15:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if rocker_disc(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def angle_gap(a, b):
    return abs(math.remainder(a - b, 2 * math.pi))


def branch_of(value, closed_form, x):
    """The sign (+1/-1) of the closed form's branch that ``value`` is at input x."""
    gaps = {s: angle_gap(value, closed_form(x, s)) for s in (1, -1)}
    sign = min(gaps, key=gaps.get)
    assert gaps[sign] < 1e-9 and gaps[-sign] > 1e-3
    return sign


def test_a_crank_turn_reproduces_the_closed_form_and_never_switches_assembly():
    problem = compile_problem(four_bar())
    path = np.linspace(-math.pi, math.pi, 200)[:, None]
    signs = set()
    for k in range(2):
        tr = problem.track(path, start=k)
        assert tr.complete and len(tr.poses) == 200 and tr.passive_joints == ("B", "D", "C")
        sign = branch_of(tr.poses[0].passive_angles["D"], rocker_of_crank, path[0, 0])
        signs.add(sign)
        for p in tr.poses:
            assert angle_gap(p.passive_angles["D"], rocker_of_crank(p.inputs["A"], sign)) < 1e-9
            assert angle_gap(p.passive_angles["D"], rocker_of_crank(p.inputs["A"], -sign)) > 1e-3
    assert signs == {1, -1}                       # both assemblies tracked, each on its own branch


def test_a_rocker_input_stops_at_the_branch_point_located_to_1e_9(tmp_path):
    mech = load_mechanism(four_bar_file(tmp_path, "D"))
    target = branch_point(1.0, 1.3)
    path = np.linspace(0.0, 1.3, 27)[:, None]
    problem = compile_problem(mech)
    n_before = int(np.sum(path[:, 0] < target))
    tr = problem.track(path, start=0)             # (both assemblies end there; one suffices, each stop costs seconds)
    st = tr.stop
    assert isinstance(st, SingularStop) and st.between_rows == (n_before - 1, n_before)
    assert abs(st.singular_inputs["D"] - target) < 1e-9
    assert st.last_proven_inputs["D"] <= target and st.distance < 1e-6       # proofs to ~5e-9 of it
    assert len(tr.poses) == n_before and all(p.inputs["D"] < target for p in tr.poses)
    sign = branch_of(tr.poses[0].passive_angles["A"], crank_of_rocker, 0.0)
    for p in tr.poses:
        assert angle_gap(p.passive_angles["A"], crank_of_rocker(p.inputs["D"], sign)) < 1e-9


def test_the_tracker_stays_on_its_branch_where_the_two_come_close_but_do_not_meet(tmp_path):
    mech = load_mechanism(four_bar_file(tmp_path, "D"))
    near = branch_point(1.0, 1.3) - 1e-5          # the two assemblies ~0.014 rad apart, not met
    gap = angle_gap(crank_of_rocker(near, 1), crank_of_rocker(near, -1))
    assert 1e-3 < gap < 0.02
    path = np.concatenate((np.linspace(0.0, near, 8), [near - 0.1]))[:, None]     # there and back
    problem = compile_problem(mech)
    for k in range(2):
        tr = problem.track(path, start=k)
        assert tr.complete and len(tr.poses) == len(path)
        sign = branch_of(tr.poses[0].passive_angles["A"], crank_of_rocker, 0.0)
        for p in tr.poses:
            assert angle_gap(p.passive_angles["A"], crank_of_rocker(p.inputs["D"], sign)) < 1e-9


def test_a_passive_joint_leaving_its_range_ends_the_track_where_the_closed_form_crosses(tmp_path):
    theta0, crossing = 0.2, 0.2 + 0.37
    sign = 1
    phi0, phi_c = rocker_of_crank(theta0, sign), rocker_of_crank(crossing, sign)
    rising = rocker_of_crank(crossing + 1e-6, sign) > phi_c
    rng = (phi0 - 1.0, phi_c) if rising else (phi_c, phi0 + 1.0)
    mech = load_mechanism(four_bar_file(tmp_path, "A", {"D": rng}))
    path = np.linspace(theta0, theta0 + 1.0, 21)[:, None]
    problem = compile_problem(mech)
    report = problem.solve(path[0])
    start = next(s for s in report.solutions
                 if angle_gap(s.passive_angles["D"], rocker_of_crank(theta0, sign)) < 1e-9)
    tr = problem.track(path, start=start)
    st = tr.stop
    assert isinstance(st, RangeStop) and st.joint == "D" and st.joint_range == rng
    assert abs(st.last_proven_inputs["A"] - crossing) < 1e-9 and st.bracket <= 1e-11
    assert abs(st.joint_angle - phi_c) < 1e-9
    assert all(p.inputs["A"] <= crossing for p in tr.poses) and len(tr.poses) == int(np.sum(path[:, 0] < crossing))
    for p in tr.poses:
        assert angle_gap(p.passive_angles["D"], rocker_of_crank(p.inputs["A"], sign)) < 1e-9


def test_a_five_bar_tracked_along_a_path_follows_the_two_circles():
    mech = five_bar()
    j = {jt.name: np.asarray(jt.axis, dtype=float) for jt in mech.joints}
    a, b, c, d, e = (j[n] for n in "ABCDE")

    def coupler_point(inputs, sign):
        """The joint C where the circle about B(theta_A) meets the circle about D(theta_E)."""
        return meet(rot(a, inputs[0]) @ b, rot(e, inputs[1]) @ d, float(b @ c), float(d @ c), sign)

    path = np.column_stack((np.linspace(0.0, 0.5, 30), np.linspace(0.0, -0.4, 30)))
    problem = compile_problem(mech)
    for k in range(2):
        tr = problem.track(path, start=k)
        assert tr.complete and set(tr.passive_joints) == {"B", "C", "D"}
        signs = set()
        for p in tr.poses:
            x = (p.inputs["A"], p.inputs["E"])
            got_left = rot(a, x[0]) @ rot(b, p.passive_angles["B"]) @ c        # C along the leg A-B
            got_right = rot(e, x[1]) @ rot(d, p.passive_angles["D"]) @ c       # C along the leg E-D
            gaps = {s: np.abs(coupler_point(x, s) - got_left).max() for s in (1, -1)}
            sign = min(gaps, key=gaps.get)
            assert gaps[sign] < 1e-9 and gaps[-sign] > 1e-3
            assert np.abs(got_right - got_left).max() < 1e-9
            signs.add(sign)
        assert len(signs) == 1                    # one branch all along


def test_redundant_actuation_and_a_rotation_start_are_refused_clearly(tmp_path):
    from spherekin.trust.loop_continuation import track_loops

    mech = four_bar()
    with pytest.raises(ValueError, match="start: the start angles do not close the loops"):
        track_loops(mech, [[0.1]], {"B": 0.0, "C": 0.0, "D": 0.0})
    with pytest.raises(ValueError, match=r"start: missing the angle\(s\) of \['C'\]"):
        track_loops(mech, [[0.1]], {"B": 0.0, "D": 0.0})
    with pytest.raises(ValueError, match="start: a start rotation needs the platform tracker"):
        compile_problem(mech).track([[0.1]], start=np.eye(3))
    both = load_mechanism(four_bar_file(tmp_path, "AD"))
    with pytest.raises(ValueError, match=r"track: .* 3 equations \(1 loop\(s\)\) in 2 passive joint\(s\): "
                                         "redundant actuation is not tracked"):
        track_loops(both, [[0.0, 0.0]], {"B": 0.0, "C": 0.0})


def test_a_pose_without_an_output_link_writes_json_csv_and_a_plot(tmp_path):
    from spherekin.batch.rows import track_rows
    from spherekin.plot import plot_track

    mech = four_bar()
    pose = TrackedPose(0, {"A": 0.0}, None, {"B": 0.0, "D": 0.0, "C": 0.0}, 0.0, 0.5, 0)
    tr = Track(mech.name, ("A",), ("B", "D", "C"), 1, (pose,), None, 0, 0)
    data = json.loads(json.dumps(tr.as_dict(), allow_nan=False))
    assert data["poses"][0]["platform_rotation"] is None
    frame = tr.frame()
    assert np.isnan(frame["qw"]).all() and frame["D"].tolist() == [0.0]
    assert len(track_rows(mech, tr)) == 1
    plot_track(tr, tmp_path / "t.png")
    assert (tmp_path / "t.png").stat().st_size > 0


def test_cli_tracks_a_four_bar_and_reports_the_range_stop_in_json(tmp_path, capsys):
    theta0, crossing = 0.2, 0.2 + 0.37
    phi_c = rocker_of_crank(crossing, 1)
    rng = (rocker_of_crank(theta0, 1) - 1.0, phi_c)
    assert rocker_of_crank(crossing + 1e-6, 1) > phi_c                   # D rises through its range's end
    toml = four_bar_file(tmp_path, "A", {"D": rng})
    rows = np.linspace(theta0, theta0 + 1.0, 11)
    path = tmp_path / "path.csv"
    path.write_text("A\n" + "".join(f"{float(v)!r}\n" for v in rows))
    js, out = tmp_path / "t.json", tmp_path / "t.csv"
    for number in (1, 2):
        assert main(["track", str(toml), "--path", str(path), "--start-solution", str(number), "--check", "2",
                     "--json", str(js), "--out", str(out), "--plot", str(tmp_path / "t.png")]) == 0
        data = json.loads(js.read_text())
        if data["stop"] is not None:
            break
    text = capsys.readouterr().out
    n = int(np.sum(rows < crossing))
    assert f"{n} of 11 row(s) tracked" in text and "D leaves its joint range" in text
    assert "the tracked pose is one of the solutions of the full solve" in text
    assert data["schema"] == "spherekin.track/3" and data["passive_joints"] == ["B", "D", "C"]
    assert len(data["poses"]) == n and data["stop"]["kind"] == "range" and data["stop"]["joint"] == "D"
    assert abs(data["stop"]["last_proven_inputs"]["A"] - crossing) < 1e-9
    for p in data["poses"]:
        assert angle_gap(p["passive_angles"]["D"], rocker_of_crank(p["inputs"]["A"], 1)) < 1e-9
    assert out.read_text().count("\n") == n + 1


def test_an_elbow_actuated_3rrr_two_loops_closes_every_row_and_returns_to_its_assembly(tmp_path):
    from spherekin.mechanism import general_3rrr

    base = general_3rrr()
    text = 'kind = "general"\nname = "elbow-actuated 3-RRR"\nreference_leg = "leg1"\n'
    for i in (1, 2, 3):
        text += f'\n[[legs]]\nname = "leg{i}"\n'
        for j in (f"beta{i}", f"gamma{i}", f"delta{i}"):
            text += f'\n[[legs.joints]]\nname = "{j}"\naxis = {[float(v) for v in base.joint(j).axis]}\n'
            text += "actuated = true\n" if j.startswith("gamma") else ""
    (tmp_path / "elbow.toml").write_text(text)
    mech = load_mechanism(tmp_path / "elbow.toml")
    axes = {j.name: np.asarray(j.axis, dtype=float) for j in mech.joints}
    t = np.linspace(0.0, 2 * math.pi, 41)
    path = 0.15 * np.column_stack((np.sin(t), np.sin(2 * t), 1.0 - np.cos(t)))     # a closed loop from 0
    problem = compile_problem(mech)
    report = problem.solve(path[0])
    start = next(s for s in report.solutions if max(abs(v) for v in s.passive_angles.values()) < 1e-9)
    tr = problem.track(path, start=start)       # the reference assembly: every reading 0
    assert tr.complete and len(tr.poses) == 41
    for p in tr.poses:
        q = {**p.inputs, **p.passive_angles}
        legs = [rot(axes[f"beta{i}"], q[f"beta{i}"]) @ rot(axes[f"gamma{i}"], q[f"gamma{i}"])
                @ rot(axes[f"delta{i}"], q[f"delta{i}"]) for i in (1, 2, 3)]
        assert max(np.abs(legs[0] - r).max() for r in legs[1:]) < 1e-9      # the loops close
    assert max(abs(v) for v in tr.poses[-1].passive_angles.values()) < 1e-9   # back in the start assembly


def test_an_input_leaving_its_range_between_two_rows_in_range_ends_the_track_at_the_range_end(tmp_path):
    mech = load_mechanism(four_bar_file(tmp_path, "A", {"A": (2.5, 3.9)}))
    path = np.array([[3.2], [3.0], [-2.6]])         # -2.6 is 3.68 modulo 2 pi, in range; the segment to it is not
    tr = compile_problem(mech).track(path, start=0)
    st = tr.stop
    assert isinstance(st, RangeStop) and st.joint == "A" and st.between_rows == (1, 2) and len(tr.poses) == 2
    assert abs(st.last_proven_inputs["A"] - (2.5 - 1e-10)) < 1e-9                # RANGE_TOL widens the end


def test_on_a_3rrr_the_loop_tracker_gives_the_platform_trackers_poses():
    """Two formulations (the legs' Eq. (1) in the platform's orientation, the loops' Eq. (2) in the
    passive joints) and two enclosures: the same assembly at every row."""
    from spherekin.mechanism import general_3rrr
    from spherekin.trust.loop_continuation import track_loops

    mech = general_3rrr()
    problem = compile_problem(mech)
    path = np.column_stack((np.linspace(-3.0, -2.8, 9), np.zeros(9), np.full(9, 0.5)))
    report = problem.solve(path[0])
    for k in (0, 3):
        platform = problem.track(path, start=k)
        loops = track_loops(mech, path, report.solutions[k].passive_angles)
        assert platform.complete and loops.complete
        for a, b in zip(platform.poses, loops.poses):
            assert np.abs(a.platform_rotation - b.platform_rotation).max() < 1e-12
            assert max(angle_gap(a.passive_angles[n], b.passive_angles[n]) for n in mech.loop_unknowns) < 1e-12


def closed_form_readings(theta, sign) -> np.ndarray:
    """The passive readings (B, D, C: four_bar()'s loop_unknowns order) of the assembly ``sign`` at crank
    reading theta, from the closed form: the coupler turns C onto its place c, B stays at Rot(A, theta) B."""
    t_d = rocker_of_crank(theta, sign)
    c = rot(D, t_d) @ C
    b = rot(A, theta) @ B
    t_b = reading(B, C, rot(A, theta).T @ c)
    t_c = reading(C, B, rot(D, t_d).T @ b)
    return np.array([t_b, t_d, t_c])


def test_a_step_box_that_holds_the_root_only_at_the_end_of_its_segment_is_not_proven():
    """The parametric test proves a root in the box for EVERY input of the step: a box around the end
    root only (the root at the start lies outside it) is refused over the segment, proven at its end."""
    from spherekin.trust.loop_continuation import LoopEquations

    mech = four_bar()
    assert mech.loop_unknowns == ("B", "D", "C")
    x0, x1 = 0.5, 0.51
    th0, th1 = closed_form_readings(x0, 1), closed_form_readings(x1, 1)
    eqs = LoopEquations(mech, (x0,))
    move = np.abs(th1 - th0).max()
    assert move > 2e-3
    lo, hi = np.minimum(th0, th1) - 0.3 * move, np.maximum(th0, th1) + 0.3 * move
    assert eqs.krawczyk(lo[None], hi[None], [[x0]], [[x1]]).all()              # the step box: proven
    r = 0.25 * move                                                              # holds th1, not th0
    assert np.abs(th0 - th1).max() > r
    assert eqs.krawczyk((th1 - r)[None], (th1 + r)[None], [[x1]], [[x1]]).all()   # at x1 alone: proven
    assert not eqs.krawczyk((th1 - r)[None], (th1 + r)[None], [[x0]], [[x1]]).any()


def test_a_passive_joint_that_leaves_its_range_and_comes_back_between_two_rows_ends_the_track(tmp_path):
    """The rocker D peaks between two rows; its range ends just below the peak, both rows are inside:
    the track must end where D leaves the range (the closed form's crossing), not pass the peak."""
    sign = 1
    grid = np.linspace(-math.pi, math.pi, 2001)
    values = np.array([rocker_of_crank(t, sign) for t in grid])
    k = int(np.argmax(values))
    peak_at = grid[k]
    rows = np.array([[peak_at - 0.01], [peak_at + 0.01]])      # one step apart: proven in one step
    ends = [rocker_of_crank(x, sign) for x in rows[:, 0]]
    hi = values[k] - 0.2 * (values[k] - max(ends))
    assert max(ends) < hi < values[k]
    mech = load_mechanism(four_bar_file(tmp_path, "A", {"D": (float(values[k]) - 3.0, float(hi))}))
    problem = compile_problem(mech)
    start = next(s for s in problem.solve(rows[0]).solutions
                 if angle_gap(s.passive_angles["D"], rocker_of_crank(rows[0, 0], sign)) < 1e-9)
    tr = problem.track(rows, start=start)
    assert isinstance(tr.stop, RangeStop) and tr.stop.joint == "D" and len(tr.poses) == 1
    from spherekin.core.angles import RANGE_TOL

    # the crossing, by bisection on the closed form: ranges are closed with a solve's tolerance RANGE_TOL
    lo_t, hi_t = rows[0, 0], peak_at
    while hi_t - lo_t > 1e-14:
        mid = 0.5 * (lo_t + hi_t)
        lo_t, hi_t = (mid, hi_t) if rocker_of_crank(mid, sign) <= hi + RANGE_TOL else (lo_t, mid)
    assert abs(tr.stop.last_proven_inputs["A"] - lo_t) < 1e-9


def test_a_crank_turn_at_0_01_rad_rows_is_proven_one_step_a_row_in_batches_on_the_closed_form(monkeypatch):
    # issue 30: the steps of up to BATCH rows are proven in one Krawczyk call (before: one call per step)
    from spherekin.trust.continuation import BATCH
    from spherekin.trust.loop_continuation import LoopEquations

    calls = []
    krawczyk = LoopEquations.krawczyk
    monkeypatch.setattr(LoopEquations, "krawczyk", lambda self, *a, **kw: calls.append(1) or krawczyk(self, *a, **kw))
    problem = compile_problem(four_bar())
    path = np.arange(-math.pi, math.pi, 0.01)[:, None]
    for k in range(2):
        calls.clear()
        tr = problem.track(path, start=k)
        assert len(calls) == 1 + math.ceil((len(path) - 1) / BATCH)       # the start's proof, then one per batch
        assert tr.complete and len(tr.poses) == len(path)
        sign = branch_of(tr.poses[0].passive_angles["D"], rocker_of_crank, path[0, 0])
        for p in tr.poses:
            np.testing.assert_allclose(np.array([p.passive_angles[n] for n in ("B", "D", "C")]),
                                       closed_form_readings(p.inputs["A"], sign), atol=1e-9)
        assert tr.rejected_steps == 0 and tr.proven_steps == len(path) - 1
        assert [p.proven_steps for p in tr.poses] == [0] + [1] * (len(path) - 1)


def test_jumps_of_the_crank_are_split_together_proven_and_stay_on_their_branch():
    from spherekin.trust.loop_continuation import LoopEquations

    mech = four_bar()
    problem = compile_problem(mech)
    # two jumps in one batch, both walked (together): rows 4 -> 5 (+2 rad) and 9 -> 10 (-1.5 rad)
    xs = np.concatenate([np.arange(5) * 0.01, 2.04 + np.arange(5) * 0.01, 0.58 + np.arange(3) * 0.01])
    path = xs[:, None]
    eqs = LoopEquations(mech, path[0])
    other = 0
    for k in range(2):
        tr = problem.track(path, start=k)
        assert tr.complete and len(tr.poses) == len(path)
        sign = branch_of(tr.poses[0].passive_angles["D"], rocker_of_crank, path[0, 0])
        for p in tr.poses:                         # every row on the start's branch of the closed form
            np.testing.assert_allclose(np.array([p.passive_angles[n] for n in ("B", "D", "C")]),
                                       closed_form_readings(p.inputs["A"], sign), atol=1e-9)
        steps = [p.proven_steps for p in tr.poses]
        assert steps[5] > 1 and steps[10] > 1                 # the jumps were split, the rows between not
        assert steps[:5] == [0, 1, 1, 1, 1] and steps[6:10] == [1] * 4 and steps[11:] == [1] * 2
        assert tr.rejected_steps >= 2
        # the float prediction alone (tangent + Newton over the jump, no proof)
        theta = eqs.predict(np.array([tr.poses[4].passive_angles[n] for n in tr.passive_joints]), path[4], path[5])
        other += theta is None or angle_gap(theta[tr.passive_joints.index("D")], rocker_of_crank(path[5, 0], sign)) > 1e-6
    assert other >= 1                             # accepting it unproven would lose or swap an assembly
