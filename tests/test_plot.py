"""Tests for spherekin.plot: arcs on the sphere, current joint axes, and the written figure.

Geometry is checked against independent derivations: scipy's rotation vectors for the Rodrigues
rotations of the elbow axes, the pose R for the platform axes (v_i = R v_i^0), the link twists of
the reference configuration for every link, and plain trigonometry for the arcs. The figure is
checked by reading the written file back (PNG header and pixels, SVG text).
"""

import dataclasses
import io
import math
import struct
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherekin.mechanism import presets
from spherekin.plot import _split_by_side, current_joint_axes, great_circle_arc, plot_solutions
from spherekin.problem import solve

INPUTS = {"gosselin": (0.3, -0.2, 0.5), "general_3rrr": (0.6, 0.5, 0.4), "four_bar": (0.5,), "five_bar": (0.1, -0.1)}
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Colours (hex) of the three legs and the platform (matplotlib's "tab10") and of the base.
COLOURS = {"leg1": "#1f77b4", "leg2": "#ff7f0e", "leg3": "#2ca02c", "platform": "#d62728", "base": "#262626"}


def angle(a, b):
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


@pytest.fixture(scope="module")
def solved():
    """name -> (mechanism, inputs, report) for every preset."""
    out = {}
    for name, inputs in INPUTS.items():
        mech = presets.preset(name)
        out[name] = (mech, inputs, solve(mech, inputs))
    return out


def svg_text(tmp_path, *args, **kwargs):
    """The figure written as SVG with text kept as text, for reading titles back."""
    import matplotlib

    path = tmp_path / "figure.svg"
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        plot_solutions(*args, path, **kwargs)
    import html
    return html.unescape(path.read_text())          # "&lt; 1e-12" in the file reads "< 1e-12"


# ------------------------------------------------------------------------------- arcs


@pytest.mark.parametrize("seed", range(6))
def test_arc_is_the_shorter_great_circle_arc_equally_spaced(seed):
    rng = np.random.default_rng(seed)
    p, q = random_unit(rng), random_unit(rng)
    pts = great_circle_arc(p, q, 17)
    assert pts.shape == (17, 3)
    np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(pts[0], p, atol=1e-14)
    np.testing.assert_allclose(pts[-1], q, atol=1e-13)
    # in the plane of p and q, between them, equally spaced in angle
    np.testing.assert_allclose(pts @ np.cross(p, q), 0.0, atol=1e-14)
    theta = angle(p, q)
    for k, x in enumerate(pts):
        assert angle(p, x) == pytest.approx(k * theta / 16, abs=1e-13)
        assert angle(p, x) + angle(x, q) == pytest.approx(theta, abs=1e-13)


def test_arc_between_antipodal_and_coincident_points():
    p = np.array([0.0, 0.6, 0.8])
    half = great_circle_arc(p, -p, 9)
    np.testing.assert_allclose(np.linalg.norm(half, axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(half[[0, -1]], [p, -p], atol=1e-14)
    np.testing.assert_allclose([angle(p, x) for x in half], np.linspace(0.0, math.pi, 9), atol=1e-13)
    assert abs(half[4] @ p) < 1e-14                  # the middle point is a quarter turn from both ends
    np.testing.assert_allclose(great_circle_arc(p, p, 5), np.tile(p, (5, 1)), atol=1e-15)
    # nearly antipodal (by 1e-7 rad, far above the parallel tolerance): still the arc between the two
    q = Rotation.from_rotvec(1e-7 * np.array([1.0, 0.0, 0.0])).apply(-p)
    pts = great_circle_arc(p, q, 5)
    np.testing.assert_allclose(pts[-1], q, atol=1e-9)
    assert angle(p, pts[2]) == pytest.approx(angle(p, q) / 2, abs=1e-9)


@pytest.mark.parametrize(
    "args, key",
    [(([1.0, 1.0, 0.0], [0.0, 0.0, 1.0]), "p"), (([1.0, 0.0, 0.0], "z"), "q"),
     (([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1), "n_points"), (([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 2.5), "n_points")],
)
def test_arc_bad_input(args, key):
    with pytest.raises(ValueError, match=f"^{key}: expected"):
        great_circle_arc(*args)


def test_split_by_side_cuts_at_the_outline():
    view = np.array([0.0, 0.0, 1.0])
    circle = great_circle_arc([1.0, 0.0, 0.0], [0.0, 0.6, 0.8], 5)
    circle = np.concatenate([circle, great_circle_arc([0.0, 0.6, 0.8], [-1.0, 0.0, 0.0], 5)[1:],
                             great_circle_arc([-1.0, 0.0, 0.0], [0.0, -0.6, -0.8], 5)[1:]])
    front, back = _split_by_side(circle, view)
    assert len(front) == 1 and len(back) == 1
    assert np.all(front[0] @ view >= -1e-15) and np.all(back[0] @ view <= 1e-15)
    cut = back[0][0]                                  # the crossing starts the far piece and ends the near one
    np.testing.assert_allclose(front[0][-1], cut, atol=1e-15)
    assert abs(cut @ view) < 1e-15 and abs(np.linalg.norm(cut) - 1.0) < 1e-15


# ------------------------------------------------------------------------------- current axes


@pytest.mark.parametrize("name, seed", [("gosselin", 0), ("gosselin", 1), ("general_3rrr", 2), ("general_3rrr", 3)])
def test_current_axes_of_a_3rrr_agree_with_the_geometry(name, seed):
    """u_i fixed, w_i = Rot(u_i, beta_i) w_i^0, v_i = R v_i^0, and every link keeps its twist, in all 8 working modes."""
    mech = presets.preset(name)
    g = mech.geometry
    pose = Rotation.from_rotvec(0.4 * Rotation.random(random_state=seed).as_rotvec() / math.pi).as_matrix()
    sols = mech.inverse_kinematics(pose)
    assert len(sols) == 8
    v0 = [np.array(v) for v in g.platform_axes]
    for sol in sols:
        axes = current_joint_axes(mech, sol.inputs, sol.passive(mech.passive))
        assert set(axes) == {"leg1", "leg2", "leg3"}
        for i in range(3):
            u, w0 = np.array(g.base_axes[i]), np.array(g.elbow_axes_at_zero[i])
            beta = sol.joint_angles[f"beta{i + 1}"]
            rows = axes[f"leg{i + 1}"]
            assert rows.shape == (3, 3)
            np.testing.assert_allclose(rows[0], u, atol=1e-15)
            np.testing.assert_allclose(rows[1], Rotation.from_rotvec(beta * u).apply(w0), atol=1e-13)
            np.testing.assert_allclose(rows[2], pose @ v0[i], atol=1e-12)
            assert angle(rows[0], rows[1]) == pytest.approx(angle(u, w0), abs=1e-12)
            assert angle(rows[1], rows[2]) == pytest.approx(g.distal_link_angles[i], abs=1e-12)
            j = (i + 1) % 3
            assert angle(rows[2], axes[f"leg{j + 1}"][2]) == pytest.approx(angle(v0[i], v0[j]), abs=1e-12)


@pytest.mark.parametrize("name", ["four_bar", "five_bar", "gosselin"])
def test_current_axes_at_solved_configurations_keep_every_twist(name, solved):
    """At each solution of a solve: base axes fixed, actuated links turned by the inputs, every link
    (legs, platform, base) with the twist of the reference configuration, within the closure residual."""
    mech, inputs, report = solved[name]
    assert report.solutions
    ref = {leg.name: np.array([j.axis for j in leg.joints]) for leg in mech.legs}
    values = dict(zip(mech.actuated, inputs))
    for sol in report.solutions:
        tol = 1e-10 + 10 * sol.residual
        axes = current_joint_axes(mech, inputs, dict(zip(report.unknowns, sol.angles)))
        for leg in mech.legs:
            rows, rows0 = axes[leg.name], ref[leg.name]
            np.testing.assert_allclose(rows[0], rows0[0], atol=1e-15)        # base joints do not move
            for k in range(len(leg.joints) - 1):
                assert angle(rows[k], rows[k + 1]) == pytest.approx(angle(rows0[k], rows0[k + 1]), abs=1e-12)
            first = leg.joints[0]
            if first.actuated:   # the link after an actuated base joint turns about it by the input
                turn = Rotation.from_rotvec((values[first.name] - first.reference_angle) * rows0[0])
                np.testing.assert_allclose(rows[1], turn.apply(rows0[1]), atol=1e-13)
        for k, leg in enumerate(mech.legs):       # the platform closes: its sides keep their twists
            other = mech.legs[(k + 1) % len(mech.legs)].name
            assert angle(axes[leg.name][-1], axes[other][-1]) == \
                pytest.approx(angle(ref[leg.name][-1], ref[other][-1]), abs=tol)
        if mech.kind == "3-RRR":                  # and sits where the reported pose puts it
            for i, v in enumerate(mech.geometry.platform_axes):
                np.testing.assert_allclose(axes[f"leg{i + 1}"][-1], sol.platform_rotation @ np.array(v), atol=tol)


def test_current_axes_bad_input():
    mech = presets.gosselin()
    passive = {n: 0.1 for n in mech.passive}
    with pytest.raises(ValueError, match="^passive_angles: missing"):
        current_joint_axes(mech, (0.0, 0.0, 0.0), {"gamma1": 0.1})
    with pytest.raises(ValueError, match="^passive_angles: .*actuated"):
        current_joint_axes(mech, (0.0, 0.0, 0.0), {**passive, "beta1": 0.2})
    with pytest.raises(ValueError, match="^passive_angles: unknown joint"):
        current_joint_axes(mech, (0.0, 0.0, 0.0), {**passive, "zeta": 0.2})
    with pytest.raises(ValueError, match="^inputs"):
        current_joint_axes(mech, (0.0, 0.0), passive)
    with pytest.raises(ValueError, match="^mechanism"):
        current_joint_axes("gosselin", (0.0, 0.0, 0.0), passive)


# ------------------------------------------------------------------------------- the figure


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == PNG_SIGNATURE and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def colour_pixels(rgb: np.ndarray, hex_colour: str) -> int:
    target = np.array([int(hex_colour[i:i + 2], 16) for i in (1, 3, 5)]) / 255.0
    return int(np.sum(np.all(np.abs(rgb - target) < 0.03, axis=-1)))


@pytest.mark.parametrize("name", list(INPUTS))
def test_png_written_for_every_preset(name, solved, tmp_path):
    from matplotlib.image import imread

    mech, inputs, report = solved[name]
    out = tmp_path / f"{name}.png"
    fig = plot_solutions(mech, inputs, report, out)
    assert len(fig.axes) == len(report.solutions)          # the Figure, one panel per solution, is returned
    data = out.read_bytes()
    width, height = png_size(data)
    n = len(report.solutions)
    assert 700 <= width <= 2000 and 400 <= height <= 1600, (width, height)
    if n > 4:                          # several rows of square panels: taller than one row
        assert height > width / 2
    assert 20_000 < len(data) < 3_000_000
    rgb = imread(io.BytesIO(data))[..., :3]
    # every part is drawn, in its own colour (legs beyond the third use other colours)
    parts = ["base", "platform"] + [f"leg{i + 1}" for i in range(min(3, len(mech.legs)))]
    for part in parts:
        assert colour_pixels(rgb, COLOURS[part]) > 150, part


def test_titles_name_every_solution_and_its_singularity(solved, tmp_path):
    mech, inputs, report = solved["gosselin"]
    text = svg_text(tmp_path, mech, inputs, report)
    assert mech.name in text and "8 solution(s)" in text and "beta1 = +0.3, beta2 = -0.2, beta3 = +0.5 rad" in text and " rad" in text
    kinds = [s.singularity for s in report.solutions]
    assert "serial" in kinds and "regular" in kinds          # the example has both (tests/test_cli.py)
    for k, sol in enumerate(report.solutions, start=1):
        assert f"solution {k}" in text
        shown = "< 1e-12" if sol.residual < 1e-12 else f"{sol.residual:.1e}"   # rounding noise as a bound
        assert f"singularity {sol.singularity}, residual {shown}" in text
    assert "solution 9" not in text


def test_degrees_show_the_inputs_in_degrees(solved, tmp_path):
    mech, inputs, report = solved["four_bar"]
    text = svg_text(tmp_path, mech, inputs, report, degrees=True)
    assert f"A = +{math.degrees(0.5):.4g} deg" in text


def test_report_without_solutions_says_so(solved, tmp_path):
    mech, inputs, report = solved["gosselin"]
    empty = dataclasses.replace(report, solutions=())
    plot_solutions(mech, inputs, empty, tmp_path / "none.png")
    width, height = png_size((tmp_path / "none.png").read_bytes())
    assert width >= 600 and height >= 300
    text = svg_text(tmp_path, mech, inputs, empty)
    assert "no solution in range" in text and "0 solution(s)" in text


def test_one_solution_still_fits_title_and_legend(solved, tmp_path):
    mech, inputs, report = solved["general_3rrr"]
    one = dataclasses.replace(report, solutions=report.solutions[:1])
    plot_solutions(mech, inputs, one, tmp_path / "one.png")
    width, height = png_size((tmp_path / "one.png").read_bytes())
    assert width >= 700 and height < width


def test_bad_input_raises_clear_errors_and_writes_nothing(solved, tmp_path):
    mech, inputs, report = solved["gosselin"]
    four, four_inputs, four_report = solved["four_bar"]
    target = tmp_path / "out.png"
    bad_angles = dataclasses.replace(report, solutions=(dataclasses.replace(report.solutions[0],
                                                                            angles=np.zeros(2)),))
    cases = [
        ((mech, inputs, report, tmp_path / "missing" / "out.png"), {}, "^path: the directory .* does not exist"),
        ((mech, inputs, report, tmp_path), {}, "^path: expected a file name"),
        ((mech, inputs, report, tmp_path / "out.jpg"), {}, r"^path: expected a file name ending in one of \.png"),
        ((mech, inputs, report, 3), {}, "^path"),
        ((mech, (0.31, -0.2, 0.5), report, target), {}, "^inputs: expected the inputs the report was solved at"),
        ((mech, (0.3, -0.2), report, target), {}, "^inputs"),
        ((mech, inputs, four_report, target), {}, "^report: expected a solve of this mechanism"),
        ((four, four_inputs, report, target), {}, "^report: expected a solve of this mechanism"),
        ((presets.general_3rrr(), inputs, dataclasses.replace(report, settings=dataclasses.replace(
            report.settings, mechanism=mech.name)), target),
         {}, "^report: expected a solve of this mechanism, 'general 3-RRR"),
        ((mech, inputs, report.as_dict(), target), {}, "^report: expected a SolveReport"),
        (("gosselin", inputs, report, target), {}, "^mechanism"),
        ((mech, inputs, report, target), {"degrees": "yes"}, "^degrees"),
        ((mech, inputs, bad_angles, target), {}, r"^report\.solutions\[0\]\.angles"),
    ]
    for args, kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            plot_solutions(*args, **kwargs)
    assert not target.exists() and not (tmp_path / "out.jpg").exists()
    assert list(Path(tmp_path).iterdir()) == []


def test_plot_report_draws_a_report_from_what_it_holds(solved, tmp_path):
    import matplotlib

    from spherekin.plot import plot_report

    mech, inputs, report = solved["gosselin"]
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        fig = plot_report(report, tmp_path / "r.svg")
    assert len(fig.axes) == len(report.solutions) == 8
    text = (tmp_path / "r.svg").read_text()
    # the title the explicit call gives: the mechanism's name and the report's inputs
    assert mech.name in text and "beta1 = +0.3, beta2 = -0.2, beta3 = +0.5 rad" in text
    with pytest.raises(ValueError, match="report: expected a SolveReport of spherekin.solve .holding its mechanism"):
        plot_report(dataclasses.replace(report, mechanism=None))
    with pytest.raises(ValueError, match="got int"):
        plot_report(3)


# ------------------------------------------------------------------------------- layout: nothing overlaps

def _boxes_overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def _joint_labels(ax):
    """The joint-name labels of a 3-D panel: its 2-D texts (the x/y/z letters are 3-D texts)."""
    from mpl_toolkits.mplot3d.art3d import Text3D
    return [t for t in ax.texts if not isinstance(t, Text3D)]


@pytest.mark.parametrize("inputs", [(0.3, -0.2, 0.5), (0.0, 0.0, 0.0)])
def test_joint_labels_do_not_collide_and_coincident_joints_share_one(inputs):
    """Gosselin at its reference inputs puts up to three joints on one axis (R = I: every axis is a
    coordinate axis); each near-side joint is named exactly once, joints on one point in one label,
    and no two labels, no label and the panel title, overlap (boxes from the Agg renderer)."""
    mech = presets.gosselin()
    report = solve(mech, inputs)
    fig = plot_solutions(mech, inputs, report)
    renderer = fig.canvas.get_renderer()
    for ax, angles in zip(fig.axes, (s.angles for s in report.solutions)):
        labels = _joint_labels(ax)
        boxes = [t.get_window_extent(renderer) for t in labels]
        for i in range(len(boxes)):
            assert not _boxes_overlap(boxes[i], ax.title.get_window_extent(renderer)), labels[i].get_text()
            assert ax.bbox.contains(boxes[i].x0, boxes[i].y0) and ax.bbox.contains(boxes[i].x1, boxes[i].y1)
            for j in range(i):
                assert not _boxes_overlap(boxes[i], boxes[j]), (labels[i].get_text(), labels[j].get_text())
        # which joints share a point: from the joint axes themselves (independent of the drawing)
        axes = current_joint_axes(mech, inputs, dict(zip(report.unknowns, angles)))
        points = [(j.name, p) for leg in mech.legs for j, p in zip(leg.joints, axes[leg.name])]
        names = [n for t in labels for n in t.get_text().split(", ")]
        assert len(names) == len(set(names))                         # nobody named twice
        for t in labels:
            group = t.get_text().split(", ")
            ps = [p for n, p in points if n in group]
            assert len(ps) == len(group)
            assert all(angle(ps[0], p) < 1e-6 for p in ps), group      # a shared label: one point
    if inputs == (0.0, 0.0, 0.0):
        assert any(len(t.get_text().split(", ")) == 3 for ax in fig.axes for t in _joint_labels(ax))


def test_track_plot_labels_clear_their_ticks_and_panels():
    from spherekin.plot import plot_track
    from spherekin.trust.continuation import track

    mech = presets.preset("general_3rrr")
    path = np.loadtxt(Path(__file__).resolve().parent.parent / "examples" / "path_general_3rrr.csv",
                      delimiter=",", skiprows=1)[:6]
    start = solve(mech, path[0]).solutions[4].platform_rotation
    fig = plot_track(track(mech, path, start))
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    for ax in fig.axes:
        label = ax.yaxis.label.get_window_extent(renderer)
        assert ax.get_ylabel()
        for tick in ax.get_yticklabels():
            if tick.get_text():
                assert not _boxes_overlap(label, tick.get_window_extent(renderer)), (ax.get_ylabel(), tick.get_text())
        # the label stays beside its own panel: within its height, inside the page
        assert ax.bbox.y0 - 1 <= label.y0 and label.y1 <= ax.bbox.y1 + 1, ax.get_ylabel()
        assert page.x0 <= label.x0
    top, bottom = (ax.yaxis.label.get_window_extent(renderer) for ax in fig.axes)
    assert not _boxes_overlap(top, bottom)


def test_map_explains_its_blank_no_assembly_cells():
    from spherekin import batch
    from spherekin.plot import NO_ASSEMBLY_LABEL, plot_assembly_map

    mech = presets.preset("general_3rrr")
    amap = batch.assembly_map(mech, "beta1=-pi:pi:6", "beta2=-pi:pi:6", {"beta3": 0.5}, workers=0)
    empty = amap.solutions == 0
    assert empty.any() and np.isnan(amap.measure[empty]).all()      # the blank cells of the measure panel
    fig = plot_assembly_map(amap, measure=True)
    legends = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    assert NO_ASSEMBLY_LABEL in legends and "no assembly" in NO_ASSEMBLY_LABEL
    measure_ax = [ax for ax in fig.axes if ax.get_title() == "distance to a parallel singularity"][0]
    assert measure_ax.get_legend() is not None
    full = dataclasses.replace(amap, solutions=np.maximum(amap.solutions, 1), measure=np.nan_to_num(amap.measure, nan=0.5))
    fig = plot_assembly_map(full, measure=True)
    assert all(NO_ASSEMBLY_LABEL not in [t.get_text() for t in ax.get_legend().get_texts()]
               for ax in fig.axes if ax.get_legend())


def test_residual_text_bounds_rounding_noise():
    from spherekin.plot import RESIDUAL_NOISE, residual_text
    assert RESIDUAL_NOISE == 1e-12
    assert residual_text(4.2e-16) == residual_text(5.1e-16) == "< 1e-12"    # two machines, one figure
    assert residual_text(2.4e-8) == "2.4e-08" and residual_text(None) == "-"


def test_plot_singular_draws_one_patch_per_cell_coloured_by_status(tmp_path):
    """plot_singular: one rectangle per cell at its place, singular cells in SINGULAR_COLOURS["singular"],
    unresolved ones hatched; a line (y None) is drawn as a strip; the file is written."""
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Rectangle

    from spherekin.plot import SINGULAR_COLOURS, plot_singular
    from spherekin.results import SingularBox, SingularSet, SingularStats

    stats = SingularStats(10, 2, 0, 0.1, 0.1, 0.2)
    boxes = (SingularBox((0.0, 0.1), (0.2, 0.3), "singular"), SingularBox((0.1, 0.2), (0.2, 0.3), "unresolved"))
    sset = SingularSet(("beta1", -1.0, 1.0), ("beta2", -1.0, 1.0), {"beta3": 0.5}, 0.1, boxes, True, stats,
                       "platform")
    fig = plot_singular(sset, tmp_path / "s.png")
    rects = [p for p in fig.axes[0].patches if isinstance(p, Rectangle)]
    np.testing.assert_allclose([(r.get_x(), r.get_y(), r.get_width()) for r in rects], [(0.0, 0.2, 0.1), (0.1, 0.2, 0.1)])
    assert rects[0].get_facecolor() == to_rgba(SINGULAR_COLOURS["singular"]) and not rects[0].get_hatch()
    assert rects[1].get_hatch() == "///"
    assert (tmp_path / "s.png").stat().st_size > 5_000
    line = SingularSet(("A", -3.0, 3.0), None, {}, 0.1, (SingularBox((0.3, 0.4), None, "singular"),), True, stats,
                       "loops")
    assert len([p for p in plot_singular(line, degrees=True).axes[0].patches if isinstance(p, Rectangle)]) == 1


def test_plot_track_takes_the_track_first_like_the_other_plots(tmp_path):
    """One calling convention (issue 42 item 3): ``plot_track(track, path)`` as ``plot_report(report, path)``;
    the former ``(mechanism, track, path)`` still draws the same figure, with a DeprecationWarning."""
    from spherekin.plot import plot_track
    from spherekin.trust.continuation import track

    mech = presets.preset("general_3rrr")
    path = np.loadtxt(Path(__file__).resolve().parent.parent / "examples" / "path_general_3rrr.csv",
                      delimiter=",", skiprows=1)[:3]
    tr = track(mech, path, solve(mech, path[0]).solutions[4].platform_rotation)
    fig = plot_track(tr, tmp_path / "x.png")
    assert (tmp_path / "x.png").stat().st_size > 0 and fig._suptitle.get_text().startswith(mech.name)
    with pytest.warns(DeprecationWarning, match="plot_track\\(track, path\\)"):
        plot_track(mech, tr, tmp_path / "old.png")
    assert (tmp_path / "old.png").stat().st_size > 0
    with pytest.raises(ValueError, match="track: expected a Track"):
        plot_track(mech)


def _legend_clear_of_the_data(fig, ax) -> None:
    """The legend's box lies outside the axes' data area and inside the figure."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legend = ax.get_legend().get_window_extent(renderer)
    assert not legend.overlaps(ax.bbox), (legend, ax.bbox)
    assert fig.bbox.contains(legend.x0, legend.y0) and fig.bbox.contains(legend.x1, legend.y1)


def test_plane_plots_keep_legends_off_the_data_and_cusps_on_top():
    """Issue 42 item 15: the legends of the singular and map plots sat in the upper right corner over cells
    (and a cusp), and the map's --singular overlay filled its cells black over the count colours."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Rectangle

    from spherekin import batch
    from spherekin.plot import plot_assembly_map, plot_singular
    from spherekin.results import Cusp, SingularBox, SingularSet, SingularStats

    stats = SingularStats(10, 2, 0, 0.1, 0.1, 0.2)
    # cells and a cusp in the upper right corner, where the legend used to be
    boxes = tuple(SingularBox((x, x + 0.1), (0.8, 0.9), "singular") for x in (0.5, 0.6, 0.7, 0.8))
    cusp = Cusp(0.85, 0.85, (0.84, 0.86), (0.84, 0.86), "cusp")
    sset = SingularSet(("beta1", -1.0, 1.0), ("beta2", -1.0, 1.0), {"beta3": 0.5}, 0.1, boxes, True, stats,
                       "platform", cusps=(cusp,))
    fig = plot_singular(sset)
    FigureCanvasAgg(fig)
    ax = fig.axes[0]
    _legend_clear_of_the_data(fig, ax)
    star = [c for c in ax.collections if c.get_label().startswith("cusp")][0]
    assert star.get_zorder() > max(p.get_zorder() for p in ax.patches)

    mech = presets.preset("general_3rrr")
    amap = batch.assembly_map(mech, "beta1=-1:1:5", "beta2=-1:1:5", {"beta3": 0.5}, workers=0)
    fig = plot_assembly_map(dataclasses.replace(amap, singular_set=sset))
    FigureCanvasAgg(fig)
    ax = fig.axes[0]
    _legend_clear_of_the_data(fig, ax)
    cells = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_gid() == "singular-cell:singular"]
    assert len(cells) == 4 and all(p.get_facecolor()[3] <= 0.5 for p in cells)     # the count's colour shows through
    assert all(p.get_edgecolor() == to_rgba("black") for p in cells)
    star = [c for c in ax.collections if c.get_label().startswith("cusp")][0]
    assert star.get_zorder() > max(p.get_zorder() for p in ax.patches)
