"""Mechanisms written as graphs (kind "graph"): the loop basis, the mobility, the errors, and the answers
against references written here, not spherekin's solver: four-bars in closed form (a six-bar as two
four-bars in series), a five-bar as two circles on the sphere, a 3-RRR against the 3-RRR kind and the
degree-8 eigenvalue solve of references/peers_closed_form.py."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import spherekin as sk
from references.peers_closed_form import direct_kinematics, geometry_of
from spherekin.mechanism import MechanismFileError, general_3rrr, load_mechanism, mechanism_from_dict
from spherekin.mechanism.graph import Step

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def rot(axis, angle) -> np.ndarray:
    """Rot(axis, angle) by scipy (right-hand rule), independent of spherekin's Rodrigues."""
    a = np.asarray(axis, dtype=float)
    return Rotation.from_rotvec(a / np.linalg.norm(a) * angle).as_matrix()


def signed_angle(axis, x, y) -> float:
    """The angle t with Rot(axis, t) x = y for unit x, y at the same angle to the unit ``axis``."""
    a = np.asarray(axis, dtype=float)
    xp, yp = x - a * (a @ x), y - a * (a @ y)
    return math.atan2(float(a @ np.cross(xp, yp)), float(xp @ yp))


def dyad_angles(d, c0, b, k) -> list[float]:
    """Every t with (Rot(d, t) c0) . b = k (a four-bar's input-output equation, P cos t + Q sin t + S = k)."""
    d, c0, b = (np.asarray(v, dtype=float) for v in (d, c0, b))
    p = c0 @ b - (d @ c0) * (d @ b)
    q = np.cross(d, c0) @ b
    s = (d @ c0) * (d @ b)
    r = math.hypot(p, q)
    ratio = (k - s) / r
    if abs(ratio) > 1.0:
        return []
    base, spread = math.atan2(q, p), math.acos(ratio)
    return [base + spread, base - spread]


def watt_reference(mech, a_in: float) -> list[dict]:
    """Every assembly of examples/watt_six_bar.toml at input A: the four-bar A-B-C-D in closed form
    (the rocker's angle D places C at the coupler's angle from B), then the four-bar E-F-G-B seen from
    the crank (link5's angle E places F at link6's angle from G). Readings in radians."""
    ax = {j.name: np.array(j.axis) for j in mech.joints}
    out = []
    r_crank = rot(ax["A"], a_in)
    b = r_crank @ ax["B"]
    for t_d in dyad_angles(ax["D"], ax["C"], b, ax["B"] @ ax["C"]):
        r_rocker = rot(ax["D"], t_d)
        c = r_rocker @ ax["C"]
        t_b = signed_angle(ax["B"], ax["C"], r_crank.T @ c)          # crank . Rot(B) carries C onto c
        r_coupler = r_crank @ rot(ax["B"], t_b)
        t_c = signed_angle(ax["C"], ax["D"], r_coupler.T @ ax["D"])   # rocker = coupler . Rot(C, t_c)
        g = rot(ax["B"], t_b) @ ax["G"]                               # G's axis seen from the crank
        for t_e in dyad_angles(ax["E"], ax["F"], g, ax["F"] @ ax["G"]):
            r5 = rot(ax["E"], t_e)                                    # link5 seen from the crank
            t_f = signed_angle(ax["F"], ax["G"], r5.T @ g)
            r6 = r5 @ rot(ax["F"], t_f)
            t_g = signed_angle(ax["G"], ax["B"], r6.T @ rot(ax["B"], t_b) @ ax["B"])
            out.append({"A": a_in, "B": t_b, "C": t_c, "D": t_d, "E": t_e, "F": t_f, "G": t_g,
                        "pose": r_coupler})
    return out


def close(a: float, b: float) -> float:
    return abs(math.remainder(a - b, 2 * math.pi))


# ------------------------------------------------------------------ the loop basis, by hand

def test_the_watt_six_bars_loops_are_the_ones_counted_by_hand():
    g = load_mechanism(EXAMPLES / "watt_six_bar.toml").link_graph
    # 7 joints, 6 links: 7 - 6 + 1 = 2 loops. Breadth-first from the ground (joints in file order):
    # ground -A-> crank, ground -D-> rocker; crank -B-> coupler, crank -E-> link5; coupler -G-> link6.
    # Off the tree: C (coupler - rocker) and F (link5 - link6).
    assert [lp.closing for lp in g.loops] == ["C", "F"]
    c, f = g.loops
    assert c.root == "ground"
    assert c.up == (Step("A", 1), Step("B", 1), Step("C", 1)) and c.down == (Step("D", 1),)
    assert f.root == "crank"                    # the paths to link5 and link6 share ground - crank
    assert f.up == (Step("E", 1), Step("F", 1)) and f.down == (Step("B", 1), Step("G", -1))   # G written link6 first
    assert g.mobility == 3 * 5 - 2 * 7 == 1


def test_a_3rrr_as_a_graph_has_the_two_loops_of_legs_against_leg1():
    g = load_mechanism(EXAMPLES / "general_3rrr_graph.toml").link_graph
    # ground -beta_i-> proximal_i -gamma_i-> distal_i; delta1 reaches the platform first: delta2, delta3 close
    assert [lp.closing for lp in g.loops] == ["delta2", "delta3"]
    for i, lp in zip((2, 3), g.loops):
        assert lp.root == "ground"
        assert lp.up == tuple(Step(f"{p}{i}", 1) for p in ("beta", "gamma", "delta"))
        assert lp.down == tuple(Step(f"{p}1", 1) for p in ("beta", "gamma", "delta"))
    assert g.mobility == 3


# ------------------------------------------------------------------ errors, one each

def graph(joints, ground="ground", output=None, name="m"):
    data = {"kind": "graph", "name": name, "ground": ground, "joints": joints}
    if output is not None:
        data["output"] = output
    return data


def joint(name, a, b, axis, actuated=False):
    return {"name": name, "links": [a, b], "axis": list(axis), "actuated": actuated}


FOUR = [joint("A", "ground", "crank", (0, 0, 1), True), joint("B", "crank", "coupler", (0, 0.6, 0.8)),
        joint("C", "coupler", "rocker", (0.6, 0.8, 0)), joint("D", "ground", "rocker", (1, 0, 0))]


@pytest.mark.parametrize("data, message", [
    (graph([dict(j, actuated=False) for j in FOUR]), "expected at least one actuated joint"),
    (graph(FOUR + [joint("E", "rocker", "extra", (0, 1, 0))]), "under-actuated: the mobility is M = "),
    (graph(FOUR + [joint("E", "moon", "sun", (0, 1, 0))]), "not connected to the ground"),
    (graph(FOUR[:3] + [joint("D", "rocker", "rocker", (1, 0, 0))]), "joins link 'rocker' to itself"),
    (graph(FOUR + [joint("A", "crank", "rocker", (0, 1, 0))]), "joint name 'A' is used twice"),
    (graph(FOUR + [joint("E", "crank", "ground", (0, 1, 0))]), "both join links"),
    (graph(FOUR, output="nowhere"), "output: link 'nowhere' is joined by no joint"),
    (graph(FOUR, output="ground"), "output: expected a moving link"),
    (graph(FOUR, ground="base"), "ground: link 'base' is joined by no joint"),
    (graph(FOUR[:1] + [joint("B", "crank", "coupler", (0, 0, 1))] + FOUR[2:]), "coaxial joints in series"),
    (graph(FOUR[:3]), "no closed loop"),
    (graph([dict(FOUR[0], links=["ground"])] + FOUR[1:]), "joints[0].links: expected two link names"),
    (graph([dict(FOUR[0], reach=1)] + FOUR[1:]), "joints[0].reach: unknown key"),
])
def test_each_bad_graph_gets_one_clear_error(data, message):
    with pytest.raises(MechanismFileError) as info:
        mechanism_from_dict(data, source="g.toml")
    assert message in str(info.value) and str(info.value).startswith("g.toml: ")


def test_the_under_actuated_error_names_the_mobility():
    five = [joint("A", "ground", "l1", (0, 0, 1), True), joint("B", "l1", "l2", (0, 0.6, 0.8)),
            joint("C", "l2", "l3", (0.6, 0.8, 0)), joint("D", "l3", "l4", (0, 0.8, 0.6)),
            joint("E", "ground", "l4", (1, 0, 0))]
    with pytest.raises(MechanismFileError, match=r"mobility is M = .* = 3 x 4 - 2 x 5 = 2, but 1 joint\(s\) are actuated"):
        mechanism_from_dict(graph(five))
    mech = mechanism_from_dict(graph([dict(j, actuated=True) if j["name"] == "E" else j for j in five]))
    assert mech.actuated == ("A", "E")


# ------------------------------------------------------------------ answers against references

@pytest.mark.parametrize("a_in", [-2.9, -1.2, 0.0, 0.7, 2.2])
def test_the_watt_six_bar_is_two_four_bars_in_series(a_in):
    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    want = watt_reference(mech, a_in)
    report = sk.solve(mech, (a_in,))
    assert report.count_exact and report.proven_count == len(want) == len(report.solutions)
    for ref in want:
        hits = [s for s in report.solutions
                if max(close(s.joint_angles[n], ref[n]) for n in "BCDEFG") < 1e-9]
        assert len(hits) == 1
        assert np.abs(hits[0].platform_rotation - ref["pose"]).max() < 1e-9      # the output link: coupler


def test_a_watt_six_bars_coupler_pose_gives_back_the_input_that_made_it():
    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    for ref in watt_reference(mech, 0.9)[::2]:
        sols = sk.inverse_kinematics(mech, ref["pose"])
        # the pose fixes A (and B, C, D); the dyad E-F-G has its two branches
        assert len(sols) == 2 and all(s.status == "certified" for s in sols)
        for s in sols:
            assert close(s.inputs[0], 0.9) < 1e-9
            assert max(close(s.joint_angles[n], ref[n]) for n in "BCD") < 1e-9


def test_a_five_bar_as_a_graph_meets_two_circles_on_the_sphere():
    five = sk.mechanism.five_bar()
    legs = {leg.name: leg for leg in five.legs}
    # write it as a graph: each leg's joints in order, links ground -> ... -> coupler
    joints, links = [], []
    for leg in five.legs:
        chain = ["ground", *[f"{leg.name}{k}" for k in range(1, len(leg.joints))], "coupler"]
        for k, j in enumerate(leg.joints):
            joints.append({"name": j.name, "links": [chain[k], chain[k + 1]], "axis": list(j.axis),
                           "actuated": j.actuated})
    mech = mechanism_from_dict(graph(joints, output="coupler"))
    assert mech.actuated == five.actuated
    # the reference: the two inputs place the two distal joints' axes p, q; the last joint's axis x
    # lies at the fixed link angles from both: two circles on the sphere, x = alpha p + beta q +- gamma p x q
    chains = [leg.joints for leg in five.legs]
    long_leg = next(c for c in chains if len(c) == 3)
    short_leg = next(c for c in chains if len(c) == 2)
    for inputs in [(0.3, -0.2), (1.0, 0.4), (-0.7, 0.9)]:
        given = dict(zip(five.actuated, inputs))
        p = rot(short_leg[0].axis, given[short_leg[0].name]) @ np.array(short_leg[1].axis)   # moves with the input
        assert long_leg[0].name in given and not long_leg[1].actuated
        x0 = np.array(long_leg[2].axis)
        # the long leg's middle joint is passive: its axis m = Rot(first, input) m0 is fixed by the input too
        m = rot(long_leg[0].axis, given[long_leg[0].name]) @ np.array(long_leg[1].axis)
        cp, cm = float(np.dot(short_leg[1].axis, x0)), float(np.dot(long_leg[1].axis, x0))
        g = np.array([[p @ p, p @ m], [m @ p, m @ m]])
        alpha, beta = np.linalg.solve(g, [cp, cm])
        base = alpha * p + beta * m
        n = np.cross(p, m)
        gamma2 = (1 - base @ base) / (n @ n)
        want = [] if gamma2 < 0 else [base + s * math.sqrt(gamma2) * n for s in (1, -1)]
        report = sk.solve(mech, inputs)
        got = []
        for s in report.solutions:
            d = [s.joint_angles[j.name] - j.reference_angle for j in long_leg[:2]]
            got.append(rot(long_leg[0].axis, d[0]) @ rot(long_leg[1].axis, d[1]) @ x0)
        assert report.count_exact and len(got) == len(want)
        for w in want:
            assert min(np.abs(g_ - w).max() for g_ in got) < 1e-9
        legs_report = sk.solve(five, inputs)
        assert sorted(np.round([s.joint_angles[n] for n in five.joint_names], 9).tolist()
                      for s in legs_report.solutions) == \
            sorted(np.round([s.joint_angles[n] for n in five.joint_names], 9).tolist() for s in report.solutions)
    assert legs


def test_a_3rrr_as_a_graph_uses_the_complete_count_and_gives_the_3rrr_kinds_answers():
    kind, as_graph = general_3rrr(), load_mechanism(EXAMPLES / "general_3rrr_graph.toml")
    assert as_graph.kind == "graph" and [leg.name for leg in as_graph.legs] == ["leg1", "leg2", "leg3"]
    geometry = geometry_of(kind)
    for inputs in [(0.1, 0.2, -0.3), (1.0, -0.5, 0.7), (-2.0, 0.4, 1.1)]:
        a, b = sk.solve(kind, inputs), sk.solve(as_graph, inputs)
        assert b.settings.formulation == "complete"
        assert a.proven_count == b.proven_count and b.count_exact
        ref = direct_kinematics(geometry, inputs)           # the degree-8 eigenvalue solve
        assert len(ref) == b.proven_count
        for r in ref:
            assert min(np.abs(s.platform_rotation - r).max() for s in b.solutions) < 1e-9
        for s in b.solutions:
            twin = min(a.solutions, key=lambda t: np.abs(t.platform_rotation - s.platform_rotation).max())
            assert max(close(s.joint_angles[n], twin.joint_angles[n]) for n in kind.joint_names) < 1e-9


def test_a_four_bar_as_a_graph_gives_the_four_bar_kinds_poses():
    legs, as_graph = sk.mechanism.four_bar(), load_mechanism(EXAMPLES / "four_bar_graph.toml")
    ax = {j.name: np.array(j.axis) for j in as_graph.joints}
    for a_in in (-2.5, 0.4, 1.9):
        want = []
        b = rot(ax["A"], a_in) @ ax["B"]
        for t_d in dyad_angles(ax["D"], ax["C"], b, ax["B"] @ ax["C"]):
            c = rot(ax["D"], t_d) @ ax["C"]
            want.append(rot(ax["A"], a_in) @ rot(ax["B"], signed_angle(ax["B"], ax["C"], rot(ax["A"], a_in).T @ c)))
        r1, r2 = sk.solve(legs, (a_in,)), sk.solve(as_graph, (a_in,))
        assert r1.proven_count == r2.proven_count == len(want)
        for w in want:
            assert min(np.abs(s.platform_rotation - w).max() for s in r2.solutions) < 1e-9
            assert min(np.abs(s.platform_rotation - w).max() for s in r1.solutions) < 1e-9


def test_solve_json_gives_every_joint_by_name_and_the_output_links_rotation(tmp_path, capsys):
    from spherekin.cli import main

    out = tmp_path / "w.json"
    assert main(["solve", str(EXAMPLES / "watt_six_bar.toml"), "--inputs", "0.7", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    want = watt_reference(mech, 0.7)
    assert len(data["solutions"]) == len(want)
    for sol in data["solutions"]:
        assert list(sol["joint_angles"]) == list("ABCDEFG")         # every joint of the file, in its order
        ref = min(want, key=lambda r: max(close(sol["joint_angles"][n], r[n]) for n in "BCDEFG"))
        assert max(close(sol["joint_angles"][n], ref[n]) for n in "ABCDEFG") < 1e-9
        assert np.abs(np.array(sol["platform_rotation"]) - ref["pose"]).max() < 1e-9


def test_graph_files_round_trip(tmp_path):
    for name in ("watt_six_bar", "stephenson_six_bar", "general_3rrr_graph", "four_bar_graph"):
        mech = load_mechanism(EXAMPLES / f"{name}.toml")
        path = tmp_path / f"{name}.toml"
        path.write_text(sk.mechanism.dumps_mechanism(mech))
        again = load_mechanism(path)
        assert again.name == mech.name and again.output == mech.output and again.link_graph.links == mech.link_graph.links
        for j, k in zip(again.joints, mech.joints):          # axes normalized once more: to the last bit
            assert (j.name, j.actuated, j.range, j.reference_angle) == (k.name, k.actuated, k.range, k.reference_angle)
            assert np.abs(np.subtract(j.axis, k.axis)).max() < 1e-15


def test_the_sphere_figure_draws_every_link_of_a_graph():
    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    report = sk.solve(mech, (0.5,))
    fig = sk.plot.plot_report(report)
    labels = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
    assert labels[:6] == ["ground (ground)", "crank", "rocker", "link5", "link6", "coupler (output)"]
    # every joint's dot sits on the sphere at its current axis: joint [a, b] turns with link a
    axes = sk.plot.current_joint_axes(mech, (0.5,), report.solutions[0].passive_angles)["joints"]
    ref = watt_reference(mech, 0.5)
    s = report.solutions[0]
    r = min(ref, key=lambda x: max(close(s.joint_angles[n], x[n]) for n in "BCDEFG"))
    coupler = r["pose"]
    assert np.abs(axes[mech.joint_names.index("C")] - coupler @ np.array(mech.joint("C").axis)).max() < 1e-9
    assert np.abs(axes[mech.joint_names.index("D")] - np.array(mech.joint("D").axis)).max() < 1e-12


def test_a_graph_mechanism_travels_to_a_worker_by_pickle():
    import pickle

    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    again = pickle.loads(pickle.dumps(mech))
    assert again == mech and again.link_graph.loops == mech.link_graph.loops
    want = watt_reference(mech, 0.7)
    report = sk.solve(again, (0.7,))
    assert report.proven_count == len(want) == 4


def test_ik_of_a_graph_without_an_output_link_is_one_clear_error(tmp_path, capsys):
    from spherekin.cli import main

    text = (EXAMPLES / "watt_six_bar.toml").read_text().replace('output = "coupler"\n', "")
    path = tmp_path / "no_output.toml"
    path.write_text(text)
    assert main(["ik", str(path), "--euler", "0,0,0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "output: this mechanism names no output link" in err


def _one_loop(n: int) -> dict:
    """A graph of one loop of ``n`` joints (every joint but three actuated): the shape whose tree
    is deepest, so that a per-link scan or per-link path shows as the square of ``n``."""
    h = math.hypot(1.0, 0.3)
    joints = [joint(f"J{k}", f"L{k}", f"L{(k + 1) % n}",
                    (math.cos(2 * math.pi * k / n) / h, math.sin(2 * math.pi * k / n) / h, 0.3 / h), k < n - 3)
              for k in range(n)]
    return graph(joints, ground="L0")


def _lines_run(data: dict) -> int:
    """Lines of spherekin.mechanism executed while ``data`` is loaded (a deterministic measure of work,
    unlike a time: the same on a loaded machine)."""
    import sys

    count = [0]
    package = str(Path(sk.__file__).parent / "mechanism")

    def tracer(frame, event, arg):
        if not frame.f_code.co_filename.startswith(package):
            return None
        def lines(frame, event, arg):
            count[0] += event == "line"
            return lines
        return lines(frame, event, arg)

    sys.settrace(tracer)
    try:
        mechanism_from_dict(data)
    finally:
        sys.settrace(None)
    return count[0]


def test_loading_a_graph_grows_linearly_with_its_joints():
    """Issue 42 item 12: loading scanned every joint for each link and walked each link's path from
    the ground (an 8,000-joint file took 18 s, 100,000 did not finish in an hour). Doubling the joints
    must about double the work, not quadruple it."""
    small, large = _lines_run(_one_loop(400)), _lines_run(_one_loop(800))
    assert large / small < 2.5, (small, large)
    mech = mechanism_from_dict(_one_loop(800))
    # the lazily built paths are the tree's own (a chain from the ground, one step per link)
    assert [st.joint for st in mech.link_paths["L5"]] == ["J0", "J1", "J2", "J3", "J4"]
    assert [st.sign for st in mech.link_paths["L799"]] == [-1]      # reached through J799 = [L799, L0]
