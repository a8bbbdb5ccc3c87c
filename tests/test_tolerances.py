"""The mechanism as built (spherekin/trust/tolerances.py, issue 45), against an independent reference.

The reference is written here and shares nothing with the module: each joint axis is tilted by an
angle theta <= delta about a random direction normal to it (Rodrigues, not the module's tangent
disk), each input moved within its interval, and the built mechanism's assembly is found by Newton's
method on the platform's rotation vector (finite-difference Jacobian) from the nominal pose. Every
such assembly must lie within the certified bound; the geometry the report names as its worst case
must give the reported lower bound; counts over the tolerances are checked by the degree-8
eigenvalue solver of references/peers_closed_form.py at sampled geometries.
"""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest

import spherekin
from references.peers_closed_form import quadrics_many, real_roots_many
from spherekin.mechanism import Tolerances, general_3rrr, gosselin
from spherekin.trust.tolerances import analyse

#: The issue's tolerances: axes within 0.1 degree, inputs within 0.01 degree.
AXES_DEG, INPUTS_DEG = 0.1, 0.01
#: general_3rrr inputs ~6e-11 from a parallel singularity (8 and 6 assemblies on either side; test_engine).
TWIN_INPUTS = np.array((0.18613171226800826, -0.15119930525771785, 0.6382686351031328))


def rodrigues(axis, angle, v):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return (v * math.cos(angle) + np.cross(axis, v) * math.sin(angle)
            + axis * float(axis @ v) * (1.0 - math.cos(angle)))


def tilt(a, angle, rng):
    """``a`` turned by ``angle`` about a random unit vector normal to it."""
    n = np.cross(a, rng.normal(size=3))
    return rodrigues(n, angle, a)


def exp_so3(w):
    angle = float(np.linalg.norm(w))
    if angle == 0.0:
        return np.eye(3)
    k = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]) / angle
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


def built_legs(mech, axes, inputs):
    """(e_i, b_i, c_i): leg i closes when e_i . (D b_i) = c_i (D: the displacement from the reference),
    for the built axes ``axes`` (legs, 3, 3) and ``inputs`` (radians); the distal link angle as given."""
    out = []
    for i, leg in enumerate(mech.legs):
        u, w, v = axes[i]
        nominal = [np.asarray(j.axis, dtype=float) for j in leg.joints]
        d = inputs[i] - leg.joints[0].reference_angle
        out.append((rodrigues(u, d, w), v, float(nominal[1] @ nominal[2])))
    return out


def solve_built(legs, d0, steps: int = 30):
    """The displacement D near d0 solving every leg (Newton on D = exp(w) d0, numerical Jacobian)."""
    def residual(w):
        d = exp_so3(w) @ d0
        return np.array([e @ d @ b - c for e, b, c in legs])

    w = np.zeros(3)
    for _ in range(steps):
        f = residual(w)
        jac = np.column_stack([(residual(w + h) - residual(w - h)) / 2e-7 for h in np.eye(3) * 1e-7])
        w = w - np.linalg.solve(jac, f)
        if np.max(np.abs(f)) < 1e-15:
            break
    assert np.max(np.abs(residual(w))) < 1e-12
    return exp_so3(w) @ d0


def rotation_angle(r):
    return math.acos(max(-1.0, min(1.0, (np.trace(r) - 1.0) / 2.0)))


def nominal_axes(mech):
    return [[np.asarray(j.axis, dtype=float) for j in leg.joints] for leg in mech.legs]


@pytest.fixture(scope="module", params=[("general_3rrr", (0.3, -0.2, 0.5)), ("general_3rrr", (0.9, -1.2, 0.4)),
                                        ("gosselin", (0.3, -0.2, 0.5))], ids=lambda p: f"{p[0]}-{p[1]}")
def analysed(request):
    name, inputs = request.param
    mech = {"general_3rrr": general_3rrr, "gosselin": gosselin}[name]()
    built = dataclasses.replace(mech, tolerances=Tolerances(AXES_DEG, INPUTS_DEG))
    report = spherekin.compile(built).solve(inputs)
    return mech, np.array(inputs), report


def test_every_sampled_geometry_is_within_the_certified_bound(analysed):
    """60 geometries per input, half with every axis at the rim of its cone and every input at an end
    of its interval: each assembly's error is below its bound (and the bound is not absurdly wide)."""
    mech, inputs, report = analysed
    rng = np.random.default_rng(45)
    delta, eps = math.radians(AXES_DEG), math.radians(INPUTS_DEG)
    ref = np.asarray(mech.platform_reference_matrix)
    proven = [(sol, a) for sol, a in zip(report.solutions, report.tolerances.assemblies)
              if a.worst_case_rotation_error is not None]
    assert len(proven) >= 4
    worst = {a.solution: 0.0 for _, a in proven}
    for trial in range(60):
        rim = trial % 2 == 0
        axes = [[tilt(a, delta if rim else delta * math.sqrt(rng.uniform()), rng) for a in leg]
                for leg in nominal_axes(mech)]
        moved = inputs + (eps * rng.choice([-1.0, 1.0], 3) if rim else rng.uniform(-eps, eps, 3))
        legs = built_legs(mech, axes, moved)
        for sol, a in proven:
            d0 = np.asarray(sol.platform_rotation) @ ref.T
            d = solve_built(legs, d0)
            err = rotation_angle(d @ d0.T)
            assert err <= a.worst_case_rotation_error, (trial, a.solution, err, a.worst_case_rotation_error)
            worst[a.solution] = max(worst[a.solution], err)
    for _, a in proven:                    # random rims reach a good part of the bound, not all of it
        assert worst[a.solution] > 0.3 * a.worst_case_rotation_error


def test_the_worst_case_geometry_reaches_the_lower_bound_and_lies_in_the_tolerances(analysed):
    """The report's worst-case geometry, built and solved here: its error is the lower bound; every axis
    within its cone, every input within its interval; the certified bound within 1.25x of it."""
    mech, inputs, report = analysed
    ref = np.asarray(mech.platform_reference_matrix)
    nominal = nominal_axes(mech)
    for sol, a in zip(report.solutions, report.tolerances.assemblies):
        if a.worst_case_rotation_error is None:
            continue
        geo = a.worst_case_geometry
        axes = [[np.array(geo["axes"][j.name]) for j in leg.joints] for leg in mech.legs]
        for leg_axes, leg_nominal in zip(axes, nominal):
            for built, nom in zip(leg_axes, leg_nominal):
                assert math.acos(min(1.0, float(built @ nom) / np.linalg.norm(built))) <= math.radians(AXES_DEG) * (1 + 1e-9)
        moved = np.array([geo["inputs"][name] for name in mech.actuated])
        assert np.all(np.abs(moved - inputs) <= math.radians(INPUTS_DEG) * (1 + 1e-9))
        d0 = np.asarray(sol.platform_rotation) @ ref.T
        err = rotation_angle(solve_built(built_legs(mech, axes, moved), d0) @ d0.T)
        assert err == pytest.approx(a.worst_case_rotation_error_lower_bound, rel=1e-6)
        assert a.worst_case_rotation_error_lower_bound <= a.worst_case_rotation_error <= 1.25 * err


def test_a_count_proven_constant_is_the_count_of_every_sampled_geometry(analysed):
    """Where the report proves the count constant, the degree-8 eigenvalue solver finds that many real
    roots at 40 sampled geometries (rims included)."""
    mech, inputs, report = analysed
    tr = report.tolerances
    assert tr.count_constant_over_tolerances is True, tr.count_reason
    rng = np.random.default_rng(7)
    delta, eps = math.radians(AXES_DEG), math.radians(INPUTS_DEG)
    for trial in range(40):
        axes = [[tilt(a, delta * (1.0 if trial % 2 else rng.uniform()), rng) for a in leg] for leg in nominal_axes(mech)]
        moved = inputs + rng.uniform(-eps, eps, 3)
        legs = built_legs(mech, axes, moved)
        w = np.array([[e for e, _, _ in legs]])
        v = np.array([[b for _, b, _ in legs]])
        cos = np.array([[c for _, _, c in legs]])
        _, real, ok = real_roots_many(quadrics_many(w, v, cos))
        assert ok[0] and int(real[0].sum()) == report.proven_count


def test_next_to_a_fold_the_count_is_not_proven_constant_and_a_singularity_is_proven():
    """1e-5 rad from a fold of general_3rrr, inputs within 0.01 degree (1.7e-4 rad) cover it: not
    constant; both sides' counts (8 and 6) are found and the fold proven inside."""
    mech = general_3rrr()
    for step in (1e-5, -1e-5):
        x = TWIN_INPUTS + np.array([step, 0.0, 0.0])
        report = spherekin.compile(mech).solve(x)
        tr = analyse(mech, Tolerances(0.0, INPUTS_DEG), x, report)
        assert tr.count_constant_over_tolerances is False, tr.count_reason
        assert "8" in tr.count_reason and "6" in tr.count_reason


@pytest.mark.parametrize("step", [-3e-4, -1e-3, -3e-3])
def test_near_a_fold_the_proof_of_a_change_is_two_built_mechanisms_the_reference_counts_differently(step):
    """On the 6-assembly side of general_3rrr's fold, 3e-4 .. 3e-3 rad away (the input interval alone does not
    reach it: 0.1 degree axis errors do): not proven constant; where a change is proven, the two witness
    geometries, built and counted by the degree-8 reference, have different counts."""
    mech = general_3rrr()
    x = TWIN_INPUTS + np.array([step, 0.0, 0.0])
    report = spherekin.compile(dataclasses.replace(mech, tolerances=Tolerances(AXES_DEG, INPUTS_DEG))).solve(x)
    tr = report.tolerances
    assert tr.count_constant_over_tolerances is not True, tr.count_reason
    if tr.count_constant_over_tolerances is False:
        counts = []
        for geo in tr.count_witnesses:
            axes = [[np.array(geo["axes"][j.name]) for j in leg.joints] for leg in mech.legs]
            legs = built_legs(mech, axes, np.array([geo["inputs"][n] for n in mech.actuated]))
            _, real, ok = real_roots_many(quadrics_many(np.array([[e for e, _, _ in legs]]),
                                                        np.array([[b for _, b, _ in legs]]),
                                                        np.array([[c for _, _, c in legs]])))
            assert ok[0]
            counts.append(int(real[0].sum()))
        assert len(counts) == 2 and counts[0] != counts[1], counts


@pytest.mark.parametrize("step", [-3e-3, -1e-2, -3e-2])
def test_a_count_proven_constant_under_one_degree_holds_at_sampled_rims(step):
    """Axes within 1 degree, inputs 3e-3 .. 3e-2 rad on the 6-assembly side of general_3rrr's fold (a complex
    pair near the real space): wherever the count is proven constant, 30 built mechanisms at the rims of the
    cones (the degree-8 reference) have the nominal count."""
    mech = general_3rrr()
    x = TWIN_INPUTS + np.array([step, 0.0, 0.0])
    report = spherekin.compile(dataclasses.replace(mech, tolerances=Tolerances(1.0, INPUTS_DEG))).solve(x)
    if report.tolerances.count_constant_over_tolerances is not True:
        return
    rng = np.random.default_rng(21)
    for _ in range(30):
        axes = [[tilt(a, math.radians(1.0), rng) for a in leg] for leg in nominal_axes(mech)]
        legs = built_legs(mech, axes, x + rng.choice([-1.0, 1.0], 3) * math.radians(INPUTS_DEG))
        _, real, ok = real_roots_many(quadrics_many(np.array([[e for e, _, _ in legs]]), np.array([[b for _, b, _ in legs]]),
                                                    np.array([[c for _, _, c in legs]])))
        assert ok[0] and int(real[0].sum()) == report.proven_count


def test_zero_tolerances_give_the_nominal_answer():
    mech = general_3rrr()
    x = (0.3, -0.2, 0.5)
    plain = spherekin.compile(mech).solve(x)
    zero = spherekin.compile(dataclasses.replace(mech, tolerances=Tolerances())).solve(x)
    assert zero.proven_count == plain.proven_count
    assert all(np.array_equal(a.angles, b.angles) for a, b in zip(zero.solutions, plain.solutions))
    tr = zero.tolerances
    assert tr.count_constant_over_tolerances is True
    assert [a.worst_case_rotation_error for a in tr.assemblies] == [0.0] * plain.proven_count


def test_the_input_tolerance_alone_moves_the_assembly_within_its_bound():
    """Axes exact, inputs +-0.01 degree: the bound is positive and holds the inputs' extremes."""
    mech = general_3rrr()
    x = np.array((0.3, -0.2, 0.5))
    report = spherekin.compile(dataclasses.replace(mech, tolerances=Tolerances(0.0, INPUTS_DEG))).solve(x)
    eps = math.radians(INPUTS_DEG)
    ref = np.asarray(mech.platform_reference_matrix)
    for sol, a in zip(report.solutions, report.tolerances.assemblies):
        assert 0.0 < a.worst_case_rotation_error
        d0 = np.asarray(sol.platform_rotation) @ ref.T
        for signs in np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).T.reshape(-1, 3):
            d = solve_built(built_legs(mech, nominal_axes(mech), x + eps * signs), d0)
            assert rotation_angle(d @ d0.T) <= a.worst_case_rotation_error


def test_an_ill_conditioned_pair_is_left_unproven_not_guessed():
    """general_3rrr at (-1.1, 0.7, 2.0): two assemblies 0.31 rad apart that 0.1 degree moves by ~0.07 rad
    each (a 40x amplification): no single box proves them over the whole tolerances, so their bound
    and the count are reported unproven (None), never a number; the other four are bounded. (Random
    rim geometries all have 6 real roots: the truth may be constant; the proof does not say so.)"""
    mech = general_3rrr()
    x = (-1.1, 0.7, 2.0)
    report = spherekin.compile(dataclasses.replace(mech, tolerances=Tolerances(AXES_DEG, INPUTS_DEG))).solve(x)
    tr = report.tolerances
    assert tr.count_constant_over_tolerances is None and "not proven" in tr.count_reason
    bounds = [a.worst_case_rotation_error for a in tr.assemblies]
    assert bounds.count(None) == 2 and all(b > 0 for b in bounds if b is not None)
    assert tr.worst_case_rotation_error is None


def test_a_mechanism_the_platform_analysis_does_not_cover_goes_to_the_loop_equations():
    """The platform analysis says it does not cover a four-bar; a solve sends it to the loop equations'
    (per-joint bounds and the one-loop count: tests/test_loop_tolerances.py)."""
    mech = dataclasses.replace(spherekin.mechanism.four_bar(), tolerances=Tolerances(0.1, 0.01))
    report = spherekin.compile(mech).solve((0.4,))
    direct = analyse(mech, mech.tolerances, (0.4,), report)
    assert direct.count_constant_over_tolerances is None and "3-RRRs driven at their base" in direct.count_reason
    assert all(a.worst_case_rotation_error is None for a in direct.assemblies)
    tr = report.tolerances
    assert tr.count_constant_over_tolerances is True and "A^2 + B^2 - C^2" in tr.count_reason
    assert all(set(a.worst_case_joint_error) == set(mech.passive) for a in tr.assemblies)


def test_the_json_carries_the_tolerances_under_their_python_names(tmp_path):
    path = tmp_path / "out.json"
    proc = subprocess.run([sys.executable, "-m", "spherekin", "solve", "examples/general_3rrr.toml", "--inputs",
                           "0.3,-0.2,0.5", "--tolerances", "axes_deg=0.1,inputs_deg=0.01,beta1=0.05", "--json",
                           str(path), "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "worst-case rotation error <=" in proc.stdout and "count constant (proven)" in proc.stdout
    data = json.loads(path.read_text())
    assert data["schema"] == "spherekin.solve/3"
    tr = data["tolerances"]
    assert tr["tolerances"] == {"axes_deg": 0.1, "inputs_deg": 0.01, "joints": {"beta1": 0.05}}
    assert tr["count_constant_over_tolerances"] is True
    first = tr["assemblies"][0]
    assert set(first) >= {"solution", "worst_case_rotation_error", "worst_case_rotation_error_lower_bound",
                          "worst_case_geometry", "tightness"}
    assert "[tolerances]" in data["mechanism_toml"] and '"beta1" = 0.05' in data["mechanism_toml"]


@pytest.mark.parametrize("option, message", [
    ("axes_deg=-0.1", "axes_deg: expected a number of degrees in [0, 10], got -0.1"),
    ("inputs_deg=nan", "inputs_deg: expected a number of degrees in [0, 10], got nan"),
    ("axes_deg=12", "axes_deg: 12 degrees is over the 10 accepted"),
    ("leg1_base=0.1", "no joint of that name"),
    ("axes_deg", "expected key=degrees pairs"),
])
def test_bad_tolerances_on_the_command_line_are_one_line(option, message):
    proc = subprocess.run([sys.executable, "-m", "spherekin", "solve", "examples/general_3rrr.toml", "--inputs",
                           "0.3,-0.2,0.5", "--tolerances", option], capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("spherekin: error: --tolerances") and message in lines[0]


# ---------------------------------------------------------------- families: batch and map

def test_a_batch_table_carries_each_entry_s_bound_and_each_input_s_count_verdict():
    """The batch's columns under tolerances are each report's own numbers, row by row (an input
    without assembly: one row, empty)."""
    from spherekin.batch import solve_many as batch_solve

    mech = dataclasses.replace(general_3rrr(), tolerances=Tolerances(AXES_DEG, INPUTS_DEG))
    rows = np.array([(0.3, -0.2, 0.5), tuple(TWIN_INPUTS + [1e-5, 0.0, 0.0]), (0.9, -1.2, 0.4)])
    frame = batch_solve(mech, rows, workers=0)
    assert list(frame.columns[-3:]) == ["worst_case_rotation_error", "worst_case_rotation_error_lower_bound",
                                        "count_constant_over_tolerances"]
    problem = spherekin.compile(mech)
    for k, row in enumerate(rows):
        tr = problem.solve(row).tolerances
        part = frame[frame["input"] == k]
        # (the batch's chunk and a single solve may differ in the poses' last bits: rtol 1e-12)
        np.testing.assert_allclose(part["worst_case_rotation_error"].to_numpy(dtype=float),
                                   [np.nan if a.worst_case_rotation_error is None else a.worst_case_rotation_error
                                    for a in tr.assemblies], rtol=1e-12)
        want = {True: "true", False: "false"}[tr.count_constant_over_tolerances]
        assert set(part["count_constant_over_tolerances"]) == {want}


def test_a_map_under_tolerances_draws_the_largest_bound_and_where_the_count_may_change(tmp_path):
    from spherekin.batch import assembly_map
    from spherekin.plot import plot_assembly_map

    mech = dataclasses.replace(general_3rrr(), tolerances=Tolerances(AXES_DEG, INPUTS_DEG))
    amap = assembly_map(mech, "beta1=0.1:0.3:2", "beta2=-0.3:-0.1:2", ["beta3=0.5"], workers=0)
    problem = spherekin.compile(mech)
    for i, b1 in enumerate(amap.x.values):
        for j, b2 in enumerate(amap.y.values):
            tr = problem.solve((b1, b2, 0.5)).tolerances
            want = tr.worst_case_rotation_error
            assert amap.worst_error[i, j] == pytest.approx(want, rel=1e-12) if want is not None else \
                np.isnan(amap.worst_error[i, j])
            assert amap.count_constant[i, j] == {True: 1.0, False: 0.0}[tr.count_constant_over_tolerances]
    assert "under tolerances: worst-case rotation error up to" in amap.table()
    fig = plot_assembly_map(amap, tmp_path / "map.png")
    assert len(fig.axes) == 4 and (tmp_path / "map.png").stat().st_size > 0     # two panels, two colour bars
    assert "as built" in fig.axes[2].get_title()


def test_a_tracked_path_under_tolerances_bounds_every_pose():
    """track with tolerances: at every pose a bound, and 20 sampled geometries at three rows of the path
    (the reference's own solve from the tracked pose) stay within it."""
    mech = dataclasses.replace(general_3rrr(), tolerances=Tolerances(AXES_DEG, INPUTS_DEG))
    path = np.column_stack([np.linspace(-0.3, 0.3, 7), np.full(7, -0.2), np.full(7, 0.5)])
    problem = spherekin.compile(mech)
    track = problem.track(path, start=0)
    assert len(track.poses) == 7 and all(p.tolerances is not None for p in track.poses)
    rng = np.random.default_rng(3)
    ref = np.asarray(mech.platform_reference_matrix)
    for pose in track.poses[::3]:
        bound = pose.tolerances.assemblies[0].worst_case_rotation_error
        assert bound is not None and bound > 0
        d0 = np.asarray(pose.platform_rotation) @ ref.T
        x = path[pose.row]
        for _ in range(20):
            axes = [[tilt(a, math.radians(AXES_DEG), rng) for a in leg] for leg in nominal_axes(mech)]
            d = solve_built(built_legs(mech, axes, x + rng.uniform(-1, 1, 3) * math.radians(INPUTS_DEG)), d0)
            assert rotation_angle(d @ d0.T) <= bound
    assert "tolerances" in track.as_dict()["poses"][0]
