"""Tests for paper_figures/fig{1,2}_*.py and exp_{slice,solutions}.py: each script writes its PNG and PDF, and its numbers agree
with independent derivations.

* fig1: the polygon's sides and exterior angles against the spherical excess (Gauss-Bonnet:
  sum of exterior angles = 2 pi - area, area from the Van Oosterom-Strackee triangle formula) and
  the closure of Eqs. (1) and (2) by plain numpy rotation matrices written here;
* fig2: the displaced configuration's platform axes against R v_i^0 with R built by scipy from the
  rotation the script asks for, and the model's phi_k against exterior angles measured here from
  tangent vectors;
* exp_slice: the roots of the 2-D slice against a brute-force grid + least-squares search on the leg
  poses built with scipy rotations (no spherekin code);
* exp_solutions: 8 solutions, 4 singular (the paper's count), each closing every leg (angle between the
  elbow axis and R v_i^0 equal to the distal link twist pi/2) by scipy rotations.
"""

from __future__ import annotations

import importlib
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Closure and angle agreement: products of at most 16 double-precision rotations are exact to ~1e-15.
TIGHT = 1e-12
#: Roots of the slice: the solver reports cluster centres of boxes of side <= its tolerance 1e-6;
#: the brute-force roots are polished to ~1e-12, so the centres lie within a few tolerances.
ROOT_AGREEMENT = 1e-5


def load(name: str):
    return importlib.import_module(f"paper_figures.{name}")


def assert_written(out: Path, name: str) -> None:
    png, pdf = out / f"{name}.png", out / f"{name}.pdf"
    assert png.read_bytes()[:8] == PNG_SIGNATURE and png.stat().st_size > 10_000
    assert pdf.read_bytes()[:5] == b"%PDF-" and pdf.stat().st_size > 5_000


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot(axis, angle):
    return Rotation.from_rotvec(angle * np.asarray(axis, dtype=float) / np.linalg.norm(axis)).as_matrix()


def signed_turn(p, a, b):
    """Signed angle at p (right-hand rule about p) from the prolongation of the arc a -> p to the arc p -> b."""
    t_in = -(a - (a @ p) * p)                 # tangent at p of the arc arriving from a, pointing forward
    t_out = b - (b @ p) * p
    return math.atan2(float(p @ np.cross(t_in, t_out)), float(t_in @ t_out))


# --------------------------------------------------------------------------------------------- fig1

@pytest.fixture(scope="module")
def fig1(tmp_path_factory):
    out = tmp_path_factory.mktemp("fig1")
    return out, load("fig1_polygon").main(["--out-dir", str(out)])


def test_fig1_writes_png_and_pdf(fig1):
    assert_written(fig1[0], "fig1_polygon")


def test_fig1_angles_match_the_spherical_excess(fig1):
    poly = fig1[1]["poly"]
    p = poly["vertices"]
    m = len(p)
    sides = [math.acos(np.clip(p[k] @ p[(k + 1) % m], -1, 1)) for k in range(m)]
    np.testing.assert_allclose(poly["sides"], sides, atol=1e-12)
    assert len({round(s, 3) for s in sides}) == m                       # unequal sides, as asked
    assert len({round(t, 3) for t in poly["exterior"]}) == m            # unequal angles
    area = 0.0                                                          # fan from p1 (convex polygon)
    for k in range(1, m - 1):
        a, b, c = p[0], p[k], p[k + 1]
        area += 2 * math.atan2(abs(a @ np.cross(b, c)), 1 + a @ b + b @ c + c @ a)
    assert sum(poly["exterior"]) == pytest.approx(2 * math.pi - area, abs=1e-12)
    for k in range(m):
        assert poly["exterior"][k] == pytest.approx(signed_turn(p[k], p[k - 1], p[(k + 1) % m]), abs=1e-12)


def test_fig1_both_forms_close_by_plain_numpy_products(fig1):
    data = fig1[1]
    poly = data["poly"]
    z = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    eq1 = np.eye(3)
    for theta, alpha in zip(poly["exterior"], poly["sides"]):
        eq1 = eq1 @ rx(theta) @ rz(alpha)
    eq2 = np.eye(3)
    for phi in data["phis"]:
        eq2 = eq2 @ rx(phi) @ z
    assert np.abs(eq1 - np.eye(3)).max() < TIGHT
    assert np.abs(eq2 - np.eye(3)).max() < TIGHT
    # the corrected index rule: phi_{2k-1} = theta_k + pi, phi_{2k} = alpha_k + pi
    np.testing.assert_allclose(data["phis"][0::2], np.asarray(poly["exterior"]) + math.pi, atol=0)
    np.testing.assert_allclose(data["phis"][1::2], np.asarray(poly["sides"]) + math.pi, atol=0)
    q = data["normalized"]                                             # the drawn normalized polygon
    assert np.linalg.norm(q[-1] - q[0]) < TIGHT                        # the walk closes
    np.testing.assert_allclose(np.einsum("ij,ij->i", q[:-1], q[1:]), 0.0, atol=TIGHT)   # every side pi/2


# --------------------------------------------------------------------------------------------- fig2

@pytest.fixture(scope="module")
def fig2(tmp_path_factory):
    out = tmp_path_factory.mktemp("fig2")
    module = load("fig2_gosselin")
    return out, module, module.main(["--out-dir", str(out)])


def test_fig2_writes_png_and_pdf(fig2):
    assert_written(fig2[0], "fig2_gosselin")


def test_fig2_configuration_is_the_requested_rotation(fig2):
    _, module, data = fig2
    mech = data["mechanism"]
    r = rot(module.ROTATION_AXIS, math.radians(module.ROTATION_DEG))
    platform0 = {"leg1": [0, 0, 1], "leg2": [1, 0, 0], "leg3": [0, 1, 0]}   # v^0 = (z, x, y), preset docstring
    for leg in mech.legs:
        np.testing.assert_allclose(data["axes"]["displaced"][leg.name][-1], r @ platform0[leg.name], atol=1e-12)
        np.testing.assert_allclose(data["axes"]["reference"][leg.name][-1], platform0[leg.name], atol=1e-12)


def test_fig2_loops_angles_are_the_measured_exterior_angles(fig2):
    _, _, data = fig2
    readings = data["configs"]["displaced"]
    for loop in data["loops"]:
        v = loop["vertices"]
        m = len(v)
        for k in range(m):
            assert math.acos(np.clip(v[k] @ v[(k + 1) % m], -1, 1)) == pytest.approx(math.pi / 2, abs=1e-12)
            offset, name, sign = loop["specs"][k]
            phi = offset + sign * readings[name]
            turn = signed_turn(v[k], v[k - 1], v[(k + 1) % m])
            assert math.remainder(phi - turn, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


# ---------------------------------------------------------------------------------------- exp_slice

@pytest.fixture(scope="module")
def exp_slice(tmp_path_factory):
    out = tmp_path_factory.mktemp("exp_slice")
    return out, load("exp_slice").main(["--out-dir", str(out)])


def brute_force_roots(mech, inputs, fixed):
    """Roots (B, C) of the slice by a 3-deg grid + least squares on the two legs' poses (scipy rotations)."""
    axes = {j.name: np.array(j.axis) for j in mech.joints}
    a = rot(axes["A"], inputs[0])
    d = rot(axes["D"], fixed)

    def gap(x):
        return (a @ rot(axes["B"], x[0]) - d @ rot(axes["C"], x[1])).ravel()

    grid = np.radians(np.arange(-180.0, 180.0, 3.0))
    vals = np.array([[np.linalg.norm(gap((b, c))) for c in grid] for b in grid])
    roots = []
    for i, j in zip(*np.nonzero(vals < 0.3)):
        sol = least_squares(gap, (grid[i], grid[j]), xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if np.linalg.norm(gap(sol.x)) < 1e-10:
            x = np.array([math.remainder(v, 2 * math.pi) for v in sol.x])
            if not any(np.abs(x - r).max() < 1e-7 for r in roots):
                roots.append(x)
    return roots


def test_exp_slice_writes_png_and_pdf(exp_slice):
    assert_written(exp_slice[0], "exp_slice")


def test_exp_slice_roots_equal_brute_force_roots(exp_slice):
    data = exp_slice[1]
    expected = brute_force_roots(data["mechanism"], (data["input"],), data["root"]["D"])
    assert len(expected) == 1                          # a consistent slice of a four-bar: one assembly
    for kind, run in data["runs"].items():
        found = [np.array([math.remainder(v, 2 * math.pi) for v in s["angles"]]) for s in run["solutions"]
                 if s["is_root"]]
        assert len(found) == 1, kind
        np.testing.assert_allclose(found[0], expected[0], atol=ROOT_AGREEMENT)
        for s in run["solutions"]:                     # what the figure flags as false is no root
            if not s["is_root"]:
                assert min(np.abs(np.array([math.remainder(v, 2 * math.pi) for v in s["angles"]]) - r).max()
                           for r in expected) > 0.1


# --------------------------------------------------------------------------------------------- exp_solutions

@pytest.fixture(scope="module")
def exp_solutions(tmp_path_factory):
    out = tmp_path_factory.mktemp("exp_solutions")
    return out, load("exp_solutions").main(["--out-dir", str(out)])


def test_exp_solutions_writes_png_and_pdf(exp_solutions):
    assert_written(exp_solutions[0], "exp_solutions")


def test_exp_solutions_eight_solutions_four_singular_each_closing(exp_solutions):
    data = exp_solutions[1]
    sols = data["report"].solutions
    assert len(sols) == 8
    assert sorted(s.status for s in sols) == ["certified"] * 4 + ["singular"] * 4
    base = {"leg1": [1, 0, 0], "leg2": [0, 1, 0], "leg3": [0, 0, -1]}      # preset docstring
    elbow0 = {"leg1": [0, 1, 0], "leg2": [0, 0, -1], "leg3": [1, 0, 0]}
    platform0 = {"leg1": [0, 0, 1], "leg2": [1, 0, 0], "leg3": [0, 1, 0]}
    for s in sols:
        r = np.asarray(s.platform_rotation)
        assert np.abs(r @ r.T - np.eye(3)).max() < TIGHT and np.linalg.det(r) == pytest.approx(1.0)
        for leg, beta in zip(("leg1", "leg2", "leg3"), data["inputs"]):
            w = rot(base[leg], beta) @ np.array(elbow0[leg], dtype=float)
            assert float(w @ (r @ np.array(platform0[leg], dtype=float))) == pytest.approx(0.0, abs=1e-9)


def test_a_quick_run_never_replaces_a_committed_figure(capsys, monkeypatch, tmp_path):
    from matplotlib.figure import Figure

    from paper_figures import _figure_tools as ft

    committed = tmp_path / "paper_figures"          # stands for paper_figures/: nothing is left in the checkout
    committed.mkdir()
    monkeypatch.setattr(ft, "HERE", committed)
    name = "zz_quick_probe"
    paths = ft.save(Figure(figsize=(1, 1)), committed, name, quick=True)
    assert all(p.parent == committed / "quick" and p.exists() for p in paths)
    assert not (committed / f"{name}.png").exists()
    assert "drawn from a quick run" in capsys.readouterr().out
    full = ft.save(Figure(figsize=(1, 1)), committed / "quick", name, quick=False)
    assert full[0].parent == committed / "quick"


def test_exp_convergence_without_results_runs_the_quick_experiment_of_the_experiments_package(monkeypatch, tmp_path):
    """From a fresh clone no results exist: the quick run is imported as experiments.convergence
    (the scripts run as python -m paper_figures.<name>, not from inside experiments/)."""
    import json

    from experiments import _common, convergence
    from paper_figures import _figure_tools as ft

    monkeypatch.setattr(_common, "RESULTS", tmp_path)
    calls = []

    def quick_main(argv):                         # stands for the real quick run (minutes): writes its JSON
        calls.append(argv)
        (tmp_path / "quick").mkdir(exist_ok=True)
        (tmp_path / "quick" / "convergence.json").write_text(json.dumps({"probe": 1}))

    monkeypatch.setattr(convergence, "main", quick_main)
    assert ft.experiment_data("convergence") == ({"probe": 1}, True)
    assert calls == [["--quick"]]


def test_exp_convergence_runs_as_a_module():
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    done = subprocess.run([sys.executable, "-m", "paper_figures.exp_convergence", "--help"], cwd=root,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "--results" in done.stdout


def test_figures_are_byte_deterministic(fig1, tmp_path):
    """A second run writes the same bytes (PNG and PDF): no version or date in the files, no randomness."""
    out, _ = fig1
    load("fig1_polygon").main(["--out-dir", str(tmp_path)])
    for suffix in ("png", "pdf"):
        first, second = (d / f"fig1_polygon.{suffix}" for d in (out, tmp_path))
        assert first.read_bytes() == second.read_bytes(), suffix
    png = (tmp_path / "fig1_polygon.png").read_bytes()
    assert b"Software" not in png and b"Matplotlib" not in png
    assert b"CreationDate" not in (tmp_path / "fig1_polygon.pdf").read_bytes()
