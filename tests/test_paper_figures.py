"""Tests for paper_figures/fig{1,2}_*.py and exp_{slice,solutions}.py: each script writes its PNG and PDF, and its numbers agree
with independent derivations.

* fig1: the four-bar panel's link angles against examples/four_bar.toml read here with tomllib; the polygon's sides and exterior angles against the spherical excess (Gauss-Bonnet:
  sum of exterior angles = 2 pi - area, area from the Van Oosterom-Strackee triangle formula) and
  the closure of Eqs. (1) and (2) by plain numpy rotation matrices written here;
* fig2: the displaced configuration's platform axes against R v_i^0 (v_i^0 read from
  examples/gosselin.toml with tomllib) with R built by scipy from the rotation the script asks for, and the model's phi_k against exterior angles measured here from
  tangent vectors;
* exp_slice: the roots of the 2-D slice against a brute-force grid + least-squares search on the leg
  poses built with scipy rotations (no spherekin code);
* exp_solutions: 8 solutions, 4 singular (the paper's count), each closing every leg (angle between the
  elbow axis and R v_i^0 equal to the distal link twist pi/2) by scipy rotations;
* labels: only Figs. 1-2 are called the paper's figures (scripts, README, docs), the exp_* are
  captioned as this project's experiments, and every count paper_figures/README.md quotes is in the
  file its section cites.
"""

from __future__ import annotations

import importlib
import json
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "paper_figures"
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


def sphere_axes_of(fig) -> list:
    return [ax for ax in fig.axes if ax.name == "3d"]


def test_fig1_has_the_four_bar_panel_beside_the_polygon_panels(fig1):
    """The paper's Fig. 1 has three panels: the four-bar's polygon (left), a polygon before and after normalization."""
    module = load("fig1_polygon")
    panels = sphere_axes_of(module.draw(fig1[1]))
    assert len(panels) == 3
    assert "four-bar" in panels[0].get_title()
    assert "Eq. (1)" in panels[1].get_title() and "Eq. (2)" in panels[2].get_title()


def test_fig1_four_bar_is_the_example_file(fig1):
    """Vertices are the file's joint axes (reference configuration), sides its link angles."""
    linkage = fig1[1]["linkage"]
    spec = tomllib.loads((ROOT / "examples" / "four_bar.toml").read_text())
    axes = {j["name"]: np.array(j["axis"], dtype=float) for leg in spec["legs"] for j in leg["joints"]}
    up, down = ([j["name"] for j in leg["joints"]] for leg in spec["legs"])
    names = up + down[::-1]
    assert linkage["names"] == names
    np.testing.assert_allclose(linkage["poly"]["vertices"], [axes[n] for n in names], atol=1e-12)
    for k, side in enumerate(linkage["poly"]["sides"]):
        a, b = axes[names[k]], axes[names[(k + 1) % len(names)]]
        assert side == pytest.approx(math.acos(np.clip(a @ b, -1, 1)), abs=1e-12)
    assert linkage["residual"] < TIGHT
    assert [name for name, _ in linkage["links"]] == [spec["legs"][0]["name"], "coupler", spec["legs"][1]["name"],
                                                      "ground"]


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


def test_fig2_draws_the_mechanism_beside_its_two_loops(fig2):
    """The paper's Fig. 2: the platform (left) and the polygons it defines (right)."""
    _, module, data = fig2
    panels = sphere_axes_of(module.draw(data))
    assert len(panels) == 3
    assert "Gosselin platform" in panels[0].get_title()
    assert [ax.get_title().split(":")[0] for ax in panels[1:]] == ["(b) loop 1", "(c) loop 2"]


def test_fig2_configuration_is_the_requested_rotation_of_the_file(fig2):
    _, module, data = fig2
    assert module.MECHANISM_FILE == ROOT / "examples" / "gosselin.toml"
    spec = tomllib.loads(module.MECHANISM_FILE.read_text())
    mech = data["mechanism"]
    r = rot(module.ROTATION_AXIS, math.radians(module.ROTATION_DEG))
    for i, leg in enumerate(mech.legs):
        base, platform0 = np.array(spec["base_axes"][i]), np.array(spec["platform_axes"][i])
        np.testing.assert_allclose(data["axes"]["displaced"][leg.name][-1], r @ platform0, atol=1e-12)
        np.testing.assert_allclose(data["axes"]["reference"][leg.name][-1], platform0, atol=1e-12)
        np.testing.assert_allclose(data["axes"]["displaced"][leg.name][0], base, atol=1e-12)   # the base stays


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


# ------------------------------------------------------------------------------------------- labels

#: The paper has exactly these figures (two schematic figures, no numeric tables).
PAPER_FIGURES = {"fig1_polygon": "Fig. 1", "fig2_gosselin": "Fig. 2"}
#: A text claiming to be one of the paper's figures: "the paper's Fig. 3", "paper Fig. 3", "paper's Figure 3".
PAPER_CLAIM = re.compile(r"paper(?:'s)?\s+(?:Fig(?:ure|s)?\.?)\s*(\d+)", re.I)


def scripts() -> dict:
    return {p.stem: p for p in sorted(FIGURES.glob("*.py")) if not p.stem.startswith("_")}


def test_only_figs_1_and_2_are_the_papers_figures():
    names = scripts()
    assert set(PAPER_FIGURES) <= set(names)
    assert all(n in PAPER_FIGURES or n.startswith("exp_") for n in names), sorted(names)
    for name, path in names.items():
        text = path.read_text()
        head = load(name).__doc__.split("\n")[0]
        if name in PAPER_FIGURES:
            assert head.startswith(f"The paper's {PAPER_FIGURES[name]} redrawn"), head
        else:
            assert head.startswith("This project's experiment (not a figure of the paper)"), head
            assert not re.search(r"\bFig(?:ure|\.)\s*\d", text), name      # no figure number at all
            assert not PAPER_CLAIM.search(text), name


def readme_sections(text: str) -> list[tuple[str, str]]:
    """(heading, body) of each "## " section of a README (the part before the first is heading "")."""
    parts = re.split(r"^## (.*)$", text, flags=re.M)
    return [("", parts[0])] + list(zip(parts[1::2], parts[2::2]))


def test_readme_and_docs_call_only_figs_1_and_2_the_papers():
    pages = [FIGURES / "README.md", ROOT / "experiments" / "README.md", ROOT / "README.md"]
    pages += [p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts]
    for page in pages:
        for match in PAPER_CLAIM.finditer(page.read_text()):
            assert match.group(1) in ("1", "2"), f"{page.relative_to(ROOT)}: {match.group(0)!r}"
    for heading, body in readme_sections((FIGURES / "README.md").read_text())[1:]:
        script = re.search(r"`(\w+)\.py`", heading).group(1)
        if script in PAPER_FIGURES:
            assert f"the paper's {PAPER_FIGURES[script]} redrawn" in heading, heading
        else:
            assert heading.startswith("This project's experiment"), heading
            assert "paper's Fig" not in body, heading


#: Words a count is quoted with in paper_figures/README.md -> the key of the numbers file that holds it.
COUNT_WORDS = {"boxes": "boxes", "split": "split", "splits": "split", "reduced again": "reduced_again",
               "accepted": "accepted", "discarded": "discarded", "isolated": "isolated",
               "solutions": "solutions", "singular": "singular", "certified": "certified"}
QUOTED_COUNT = re.compile(r"\b(\d[\d,]*)\s+(" + "|".join(sorted(map(re.escape, COUNT_WORDS), key=len, reverse=True))
                          + r")\b")
QUOTED_RANGE = re.compile(r"\|det\| = (\d+\.\d+)-(\d+\.\d+)")


def file_pairs(value, key=None) -> set:
    """(key, value) of every number in a JSON document (nested dicts and lists flattened)."""
    if isinstance(value, dict):
        return set().union(*(file_pairs(v, k) for k, v in value.items())) if value else set()
    if isinstance(value, list):
        return set().union(*(file_pairs(v, key) for v in value)) if value else set()
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return {(key, value)}
    return set()


def stale_quotes(text: str) -> tuple[list[str], int]:
    """(problems, quotes checked) of a paper_figures/README.md text: every count it quotes must be the
    value of that count's key in a numbers file its section cites ("Numbers: [`x.json`](x.json)")."""
    problems, checked = [], 0
    for heading, body in readme_sections(text):
        quotes = [(COUNT_WORDS[w], int(n.replace(",", ""))) for n, w in QUOTED_COUNT.findall(body)]
        quotes += [(k, float(v)) for lo, hi in QUOTED_RANGE.findall(body)
                   for k, v in (("det_certified_min", lo), ("det_certified_max", hi))]
        if not quotes:
            continue
        cited = re.findall(r"\[`([\w.]+\.json)`\]\(([\w./]+\.json)\)", body)
        if not cited:
            problems.append(f"{heading!r} quotes {quotes} but cites no numbers file")
            continue
        pairs = set().union(*(file_pairs(json.loads((FIGURES / path).read_text())) for _, path in cited))
        for quote in quotes:
            checked += 1
            if quote not in pairs:
                problems.append(f"{heading!r}: {quote[1]} {quote[0]} is not in {[p for _, p in cited]}")
    return problems, checked


def test_every_count_quoted_in_the_readme_is_in_the_file_it_cites():
    problems, checked = stale_quotes((FIGURES / "README.md").read_text())
    assert not problems, "\n".join(problems)
    assert checked >= 10                      # the slice's counts, the solutions' counts and |det| range


def test_a_stale_count_in_the_readme_is_caught():
    """The check is real: the counts the README gave before the slice was re-run fail it."""
    text = (FIGURES / "README.md").read_text()
    data = json.loads((FIGURES / "exp_slice.json").read_text())["runs"]["paper"]
    quoted = f"{data['boxes']} boxes ({data['split']} split"
    assert quoted in text
    problems, _ = stale_quotes(text.replace(quoted, "131 boxes (40 split"))
    assert len(problems) == 2 and "131 boxes" in problems[0]
    problems, _ = stale_quotes(text.replace("Numbers: [`exp_slice.json`](exp_slice.json).", ""))
    assert any("cites no numbers file" in p for p in problems)


def test_committed_numbers_files_are_what_the_scripts_write(exp_slice, exp_solutions):
    """The committed <name>.json are regenerated byte for byte (make figures leaves them unchanged)."""
    for fixture, name in ((exp_slice, "exp_slice"), (exp_solutions, "exp_solutions")):
        assert (fixture[0] / f"{name}.json").read_text() == (FIGURES / f"{name}.json").read_text(), name
