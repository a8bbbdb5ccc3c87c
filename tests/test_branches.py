"""Branches and circuits of a one-input mechanism (spherekin.batch.branches, `spherekin map` of a
one-DOF file), against the spherical four-bar's closed-form input-output equation written here.

Closed form (independent of spherekin's solver): ground pivots a (crank, input theta) and d (rocker,
output psi); the crank moves the coupler axis b0 to b = Rot(a, theta) b0, the rocker moves c0 to
c = Rot(d, psi) c0, and the coupler is rigid: b . c = b0 . c0 (the circle-circle intersection on the
unit sphere: c lies on the circle of centre d through c0 and on the circle of centre b at the
coupler's angle). With Rodrigues' formula for c:

    A cos psi + B sin psi + C = 0,  A = b.c0 - (b.d)(d.c0),  B = b.(d x c0),  C = (b.d)(d.c0) - b0.c0,

so psi = atan2(B, A) +- acos(-C / rho), rho = sqrt(A^2 + B^2), real where the discriminant
A^2 + B^2 - C^2 >= 0; its zeros are the branch points (the two assemblies meet, psi = atan2(B, A) or
that + pi). Joint readings are 0 in the reference assembly the axes are written in, so theta and psi
are the readings of joints A and D.
"""

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from spherekin.batch.branches import BRANCHES_SCHEMA, branch_map
from spherekin.cli import main

ROOT = Path(__file__).resolve().parent.parent
FOUR_BAR = ROOT / "examples" / "four_bar.toml"
#: The non-Grashof four-bar of the test (degrees: ground, crank, coupler, rocker) and its reference
#: crank reading (radians): 40 + 60 > 50 + 45, so no link turns fully: the input is limited.
NON_GRASHOF = (50.0, 60.0, 40.0, 45.0)
NON_GRASHOF_THETA0 = 0.3
#: Agreement asked of every sample and branch point with the closed form (the issue's 1e-9).
CLOSED_FORM_TOL = 1e-9
#: Samples within this input distance (radians) of a branch point are compared through the residual
#: of the input-output equation instead of acos: there acos(-C/rho) loses half the digits of
#: -C/rho (its slope 1/sqrt(1 - x^2) is unbounded at the branch point).
NEAR_BRANCH = 1e-5


def rot(axis, t):
    """Rodrigues: the rotation by t (radians, right hand) about the unit vector axis."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(t) * k + (1.0 - math.cos(t)) * k @ k


def read_axes(path):
    """(a, b0, c0, d) of a four-bar file of the examples' layout (legs crank A-B and rocker D-C)."""
    legs = {leg["name"]: leg["joints"] for leg in tomllib.loads(Path(path).read_text())["legs"]}
    axes = {j["name"]: np.array(j["axis"], dtype=float) for joints in legs.values() for j in joints}
    return tuple(axes[n] / np.linalg.norm(axes[n]) for n in "ABCD")


def coefficients(geo, theta):
    a, b0, c0, d = geo
    b = rot(a, theta) @ b0
    return b @ c0 - (b @ d) * (d @ c0), b @ np.cross(d, c0), (b @ d) * (d @ c0) - b0 @ c0


def discriminant(geo, theta):
    A, B, C = coefficients(geo, theta)
    return A * A + B * B - C * C


def outputs(geo, theta):
    """The two readings of D at input theta (nan where the linkage does not assemble)."""
    A, B, C = coefficients(geo, theta)
    rho = math.hypot(A, B)
    if abs(C) > rho:
        return (math.nan, math.nan)
    base, half = math.atan2(B, A), math.acos(-C / rho)
    return (base + half, base - half)


def equation_residual(geo, theta, psi):
    A, B, C = coefficients(geo, theta)
    return A * math.cos(psi) + B * math.sin(psi) + C


def branch_inputs(geo):
    """The zeros of the discriminant on the input circle: a scan, then bisection to 1e-14."""
    ts = np.linspace(-math.pi, math.pi, 3601)
    values = [discriminant(geo, t) for t in ts]
    roots = []
    for lo, hi, f_lo, f_hi in zip(ts, ts[1:], values, values[1:]):
        if f_lo * f_hi < 0:
            while hi - lo > 1e-14:
                mid = 0.5 * (lo + hi)
                if discriminant(geo, mid) * f_lo > 0:
                    lo, f_lo = mid, discriminant(geo, mid)
                else:
                    hi = mid
            roots.append(0.5 * (lo + hi))
    return roots


def wrapped(x):
    return (x + math.pi) % (2 * math.pi) - math.pi


def write_four_bar(path, dims, theta0, triad=None):
    """A general-kind file of the four-bar with link angles ``dims`` (degrees), the crank at theta0
    from the ground plane in the reference assembly; returns its axes (a, b0, c0, d). ``triad``: the
    axes of joints E, G, H of a third leg from the ground to the coupler (a Stephenson six-bar)."""
    g, cr, co, ro = map(math.radians, dims)
    a, d = np.array([0.0, 0.0, 1.0]), np.array([math.sin(g), 0.0, math.cos(g)])
    b = rot(a, theta0) @ np.array([math.sin(cr), 0.0, math.cos(cr)])
    x, y = np.linalg.solve([[1.0, b @ d], [b @ d, 1.0]], [math.cos(co), math.cos(ro)])   # c.b, c.d given
    n, p = np.cross(b, d), x * b + y * d
    c = p + math.sqrt((1.0 - p @ p) / (n @ n)) * n
    vec = lambda v: "[" + ", ".join(repr(float(t)) for t in v) + "]"
    path.write_text(f'kind = "general"\nname = "non-Grashof four-bar"\nreference_leg = "crank"\n'
                    f'[[legs]]\nname = "crank"\n[[legs.joints]]\nname = "A"\naxis = {vec(a)}\nactuated = true\n'
                    f'[[legs.joints]]\nname = "B"\naxis = {vec(b)}\n'
                    f'[[legs]]\nname = "rocker"\n[[legs.joints]]\nname = "D"\naxis = {vec(d)}\n'
                    f'[[legs.joints]]\nname = "C"\naxis = {vec(c)}\n'
                    + ("" if triad is None else '[[legs]]\nname = "triad"\n' + "".join(
                        f'[[legs.joints]]\nname = "{n}"\naxis = {vec(v)}\n' for n, v in zip("EGH", triad))))
    return a, b, c, d


def check_samples_on_closed_form(bmap, geo, points):
    """Every sample of every branch on the closed form, each branch on one root (+ or -) between
    branch points; returns the signs per branch."""
    col = bmap.joints.index("D")
    signs = []
    for branch in bmap.branches:
        found = set()
        for u, q in zip(branch.inputs, branch.angles):
            psi = q[col]
            if min((abs(u - p) for p in points), default=math.inf) < NEAR_BRANCH:
                assert abs(equation_residual(geo, u, psi)) < CLOSED_FORM_TOL
                continue
            gaps = [abs(wrapped(psi - r)) for r in outputs(geo, u)]
            k = int(np.argmin(gaps))
            assert gaps[k] < CLOSED_FORM_TOL, (u, psi, outputs(geo, u))
            found.add(k)
        assert len(found) == 1                       # a branch stays on one assembly
        signs.append(found.pop())
    return signs


def test_crank_rocker_has_two_crank_circuits_on_the_closed_form():
    geo = read_axes(FOUR_BAR)
    assert min(discriminant(geo, t) for t in np.linspace(-math.pi, math.pi, 721)) > 0   # a crank: always assembles
    bmap = branch_map(FOUR_BAR, "A=-pi:pi:37", joint="D")
    assert bmap.full_turn and bmap.output == "D"
    assert len(bmap.circuits) == 2 and not bmap.branch_points
    assert all(c.crank and not c.branch_points for c in bmap.circuits)
    signs = check_samples_on_closed_form(bmap, geo, [])
    # each circuit is one of the two closed-form assemblies, the other circuit the other one
    per_circuit = [{signs[k] for k in c.branches} for c in bmap.circuits]
    assert sorted(map(sorted, per_circuit)) == [[0], [1]]
    assert "crank: covers the full input turn" in bmap.report()
    # no zero of the discriminant: the certified cover holds no cell, and says so
    assert bmap.cover.complete and bmap.cover.cells == () and bmap.unresolved == ()
    assert "no branch point over the input's range (proven)" in bmap.report()


def test_non_grashof_branch_points_join_the_two_assemblies_into_one_circuit(tmp_path):
    path = tmp_path / "non_grashof.toml"
    geo = write_four_bar(path, NON_GRASHOF, NON_GRASHOF_THETA0)
    expected = branch_inputs(geo)
    assert len(expected) == 2                       # the input is limited to [expected[0], expected[1]]
    bmap = branch_map(path, "A=-pi:pi:41", joint="D")
    assert len(bmap.circuits) == 1
    circuit = bmap.circuits[0]
    assert not circuit.crank and len(circuit.branch_points) == 2 and len(circuit.branches) == 2
    got = sorted(p.input for p in bmap.branch_points)
    assert got == pytest.approx(expected, abs=CLOSED_FORM_TOL)
    col = bmap.joints.index("D")
    for p, u_star in zip(sorted(bmap.branch_points, key=lambda p: p.input), expected):
        assert p.polished and p.tolerance < CLOSED_FORM_TOL
        A, B, C = coefficients(geo, u_star)          # the double root: psi = atan2(B, A) (+ pi when C > 0)
        psi_star = math.atan2(B, A) + (math.pi if C > 0 else 0.0)
        assert abs(wrapped(p.angles[col] - psi_star)) < CLOSED_FORM_TOL
        assert sorted(p.branches) == [0, 1]          # it joins the two branches
    signs = check_samples_on_closed_form(bmap, geo, expected)
    assert sorted(signs) == [0, 1]                   # one branch per assembly, met at both ends
    lo, hi = circuit.intervals[0]
    assert (lo, hi) == pytest.approx(expected, abs=CLOSED_FORM_TOL)
    assert "not a full turn" in bmap.report()


def test_cli_map_of_a_one_input_file_writes_branches_json_and_plot(tmp_path, capsys):
    out, png = tmp_path / "b.json", tmp_path / "b.png"
    assert main(["map", str(FOUR_BAR), "--grid", "A=-pi:pi:25", "--joint", "D", "--json", str(out),
                 "--plot", str(png)]) == 0
    text = capsys.readouterr().out
    assert "2 circuit(s)" in text and "crank" in text
    data = json.loads(out.read_text())
    assert data["schema"] == BRANCHES_SCHEMA
    assert {"inputs", "branches", "branch_points", "circuits", "input", "joints", "output"} <= set(data)
    assert data["input"] == "A" and data["output"] == "D" and len(data["inputs"]) == 25
    assert len(data["circuits"]) == 2 and all(c["crank"] for c in data["circuits"])
    assert data["cover"]["cells"] == [] and data["cover"]["complete"] and data["cover"]["error"] is None
    assert "cross-check: certified singular cover of A at T = 1.0e-06 rad, complete, 0 cell(s)" in text
    assert png.stat().st_size > 0


@pytest.mark.parametrize("args, message", [
    (["--joint", "X"], "--joint: 'X' is not a passive joint of this mechanism; expected one of B, D, C"),
    (["--table", "t.csv"], "--table: only for a map of two inputs"),
    (["--grid", "B=0:1:3"], "--grid/--fix: B is not an actuated joint"),
    (["--grid", "A=-180:180:5"], "--grid point 0 (A = -180): A: -180 is more than a full turn in radians"),
    (["--grid", "A=0:1:3", "--grid", "A=1:2:3"], "--grid: the branches of a one-input mechanism take one grid axis"),
])
def test_cli_one_input_map_refuses_bad_options(args, message, capsys):
    assert main(["map", str(FOUR_BAR), *args]) == 2
    out, err = capsys.readouterr()
    assert err.startswith("spherekin: error: ") and message in err and len(err.strip().splitlines()) == 1
    assert out == ""                                # refused before any work: nothing else printed


def test_cli_branches_need_one_actuated_joint(capsys):
    assert main(["map", str(ROOT / "examples" / "gosselin.toml"), "--joint", "B2"]) == 2
    err = capsys.readouterr().err
    assert "--joint: branches and circuits are drawn for a mechanism with one actuated joint" in err
    assert "got 3" in err
    assert main(["map", str(ROOT / "examples" / "five_bar.toml"), "--grid", "A=0:1:2", "--grid", "E=0:1:2",
                 "--json", "m.json"]) == 2
    assert "--json: only for the branches of a mechanism with one actuated joint" in capsys.readouterr().err


def test_a_grid_short_of_a_turn_gives_open_circuits_over_it_and_the_connect_step_is_pluggable():
    from spherekin.batch.branches import NearestConnector
    from spherekin.mechanism import four_bar

    mech, calls = four_bar(), []
    nearest = NearestConnector(mech, "A", mech.loop_unknowns)

    def connect(u0, q0, u1, q1):                    # a stand-in for another connect step (tracking)
        calls.append((u0, u1))
        return nearest(u0, q0, u1, q1)

    bmap = branch_map(mech, "A=-1:1:11", joint="D", connect=connect)
    assert not bmap.full_turn and len(bmap.circuits) == 2 and not bmap.branch_points
    assert all(not c.crank and c.intervals == ((-1.0, 1.0),) for c in bmap.circuits)
    assert len(calls) >= 10 and min(u for u, _ in calls) == -1.0 and max(u for _, u in calls) == 1.0
    geo = read_axes(FOUR_BAR)
    check_samples_on_closed_form(bmap, geo, [])


#: A third leg E-G-H from the ground to the coupler of the non-Grashof four-bar (axes in the
#: reference assembly): a Stephenson six-bar whose triad assembles twice over the whole input range
#: of its four-bar loop (4 assemblies there, none outside).
TRIAD = ([-0.3630410335686741, -0.09731575234507522, 0.9266773183211623],
         [0.3726504516670979, -0.9279671262592992, -0.0029416754351465676],
         [-0.3601330879178536, 0.08585443853692043, -0.9289419650173318])


def test_stephenson_six_bar_has_two_branch_points_at_each_end_of_its_four_bar_loop(tmp_path):
    """Where the four-bar loop turns back, both triad assemblies ride along: two pairs of assemblies
    meet at one input (the count changes by 4), each pair at its own branch point."""
    path = tmp_path / "stephenson.toml"
    geo = write_four_bar(path, NON_GRASHOF, NON_GRASHOF_THETA0, TRIAD)
    expected = branch_inputs(geo)                   # the four-bar loop's limits: the six-bar's too
    bmap = branch_map(path, "A=-pi:pi:13", joint="D")
    assert set(bmap.counts) == {0, 4}
    inputs = sorted(p.input for p in bmap.branch_points)
    assert inputs == pytest.approx([expected[0]] * 2 + [expected[1]] * 2, abs=CLOSED_FORM_TOL)
    col, triad = bmap.joints.index("D"), [bmap.joints.index(n) for n in "EGH"]
    for u_star in expected:
        here = [p for p in bmap.branch_points if abs(p.input - u_star) < CLOSED_FORM_TOL]
        A, B, C = coefficients(geo, u_star)
        for p in here:                              # the four-bar's double root, each
            assert p.polished and abs(wrapped(p.angles[col] - math.atan2(B, A) - (math.pi if C > 0 else 0.0))) \
                < CLOSED_FORM_TOL
        assert max(abs(wrapped(here[0].angles[k] - here[1].angles[k])) for k in triad) > 0.1   # two triad assemblies
    assert len(bmap.branches) == 4 and all(b.start is not None and b.end is not None for b in bmap.branches)
    assert sorted(k for c in bmap.circuits for k in c.branches) == [0, 1, 2, 3]
    assert not any(c.crank for c in bmap.circuits) and not bmap.unresolved
    signs = check_samples_on_closed_form(bmap, geo, expected)     # D: the four-bar's input-output equation
    assert sorted(signs) == [0, 0, 1, 1]


# ---------------------------------------------------------------- issue 40 item 6: a branch point is never lost

#: The issue's change-point four-bar (kind "general", joint -> axis as written in the file; A driven).
#: Its discriminant's minimum near A = 2.5307274 is -6.6e-18 (50 digits): two branch points 6.5e-9 apart
#: with no assembly between them, which no sampling of the input can see.
CHANGE_POINT = {"A": [0.0, 0.0, 1.0], "B": [0.7697511313200571, 0.5389855446957562, 0.3420201433256688],
                "D": [0.8660254037844386, 0.0, 0.5000000000000001],
                "C": [0.40946274814203376, 0.8374715317066401, -0.36191392825492]}
#: Working precision (decimal digits) of the discriminant reference: the file's floats are exact
#: there, and a near-double root (the pair 6.5e-9 apart) keeps ~25 of them.
REFERENCE_DIGITS = 50
#: A root of the reference's quartic is real when its imaginary part is below this. Reason: a
#: near-double root is known to ~sqrt(1e-50) = 1e-25; the complex pair of a dip that stays above 0
#: (1.2e-17 for the +1 ulp variant) has imaginary parts ~sqrt(1.2e-17 / 0.6) ~ 4e-9.
REAL_ROOT_IMAG = 1e-20
#: Widest unresolved interval accepted around a lost pair (radians). Reason: the cover's run of
#: unresolved cells around the change point is ~1e-5 wide at T = 1e-6 (interval arithmetic cannot
#: tell the discriminant's sign closer to its -6.6e-18 minimum); a flag 10 times wider is still local.
UNRESOLVED_WIDTH = 1e-4
#: A coarse full-turn grid (20 deg steps): the count changes are bisected and the cover adds its
#: runs' edges, so the grid only has to keep the test short.
COARSE_TURN = "A=-pi:pi:19"
#: The input interval of the last-bit variants (radians): around the change point at 2.5307 only (the
#: two branch points far from it are the full-turn test's); a solve next to the change point takes
#: ~0.5 s (the solver's clusters), one at a well-conditioned input ~10 ms.
AROUND_CHANGE_POINT = (2.4, 2.7)


def branch_inputs_mp(axes):
    """The branch inputs (radians, floats, sorted) of the four-bar with these file axes, from the
    50-digit discriminant: each axis normalized in mpmath, the rocker's closure at input u
    g(psi) = P + Q cos psi + S sin psi with B(u) = Rot(A, u) B = k0 + kc cos u + ks sin u (Rodrigues),
    P = (D.C)(D.B(u)) - B.C, Q = C.B(u) - (D.C)(D.B(u)), S = (D x C).B(u) (tests/singular_refs.py's
    four_bar_closure_coefficients); real rocker angles exist where Q^2 + S^2 - P^2 >= 0, so the branch
    points are its zeros. With t = tan(u / 2) each of P, Q, S times (1 + t^2) is a quadratic in t and
    the discriminant times (1 + t^2)^2 a quartic: its real roots, u = 2 atan(t)."""
    import mpmath
    from mpmath import mp, mpf

    with mp.workdps(REFERENCE_DIGITS):
        def unit(v):
            v = [mpf(x) for x in v]
            n = mpmath.sqrt(sum(x * x for x in v))
            return [x / n for x in v]

        def dot(a, b):
            return sum(x * y for x, y in zip(a, b))

        A, B, C, D = (unit(axes[n]) for n in "ABCD")
        ab = dot(A, B)
        k0, kc = [a * ab for a in A], [b - a * ab for a, b in zip(A, B)]
        ks = [A[1] * B[2] - A[2] * B[1], A[2] * B[0] - A[0] * B[2], A[0] * B[1] - A[1] * B[0]]
        dxc = [D[1] * C[2] - D[2] * C[1], D[2] * C[0] - D[0] * C[2], D[0] * C[1] - D[1] * C[0]]
        dc, bc = dot(D, C), dot(B, C)

        def trig(f, const=0):
            """(constant, cos u, sin u) coefficients of f(B(u)) + const, f linear -> quadratic in t."""
            c0, cc, cs = f(k0) + const, f(kc), f(ks)
            return [c0 - cc, 2 * cs, c0 + cc]          # t^2, t, 1 of (c0 + cc cos u + cs sin u)(1 + t^2)

        def mul(p, q):
            out = [mpf(0)] * (len(p) + len(q) - 1)
            for i, a in enumerate(p):
                for j, b in enumerate(q):
                    out[i + j] += a * b
            return out

        p = trig(lambda v: dc * dot(D, v), -bc)
        q = trig(lambda v: dot(C, v) - dc * dot(D, v))
        s = trig(lambda v: dot(dxc, v))
        quartic = [x + y - z for x, y, z in zip(mul(q, q), mul(s, s), mul(p, p))]
        assert abs(quartic[0]) > mpf(10) ** -10           # no branch point at u = pi (t infinite)
        roots = mpmath.polyroots(quartic, maxsteps=200, extraprec=4 * REFERENCE_DIGITS)
        return sorted(float(2 * mpmath.atan(r.real)) for r in roots if abs(r.imag) < REAL_ROOT_IMAG)


def change_point_file(path, nudge=None):
    """The change-point four-bar written to ``path``, with ``nudge`` = (joint, index, +-1): that axis
    float moved by one ulp up or down; returns the axes written."""
    from singular_refs import FourBar, four_bar_toml

    axes = {n: list(v) for n, v in CHANGE_POINT.items()}
    if nudge is not None:
        name, k, sign = nudge
        axes[name][k] = math.nextafter(axes[name][k], sign * math.inf)
    path.write_text(four_bar_toml(FourBar(*(np.array(axes[n]) for n in "ABCD")), "change-point four-bar"))
    return axes


def check_every_branch_point_found_or_held(points, unresolved, cover, expected):
    """``points``: (input, tolerance, polished) located; ``unresolved``: (lo, hi); ``cover``: the
    cross-check's JSON object; ``expected``: the reference's branch inputs."""
    assert cover["error"] is None and cover["complete"] and cover["disagreements"] == []
    for u, tol, polished in points:                    # every located point is a reference root, within its claim
        assert polished and min(abs(u - r) for r in expected) <= tol
    for r in expected:                                 # every reference root: located, or inside a flag
        assert any(abs(u - r) <= tol for u, tol, _ in points) or any(lo <= r <= hi for lo, hi in unresolved), r
    assert all(hi - lo < UNRESOLVED_WIDTH for lo, hi in unresolved)


def test_the_change_point_four_bars_close_branch_points_are_flagged_not_lost(tmp_path, capsys):
    """The issue's command (`map FILE --joint D`, on a coarser grid): its two branch points 6.5e-9 apart
    at A = 2.53072741... were lost (1 circuit, 2 branch points, nothing unresolved); now each lies in an
    unresolved interval of the map, which the text and the JSON show with the cross-check."""
    path, out = tmp_path / "change_point.toml", tmp_path / "b.json"
    expected = branch_inputs_mp(change_point_file(path))
    close = [r for r in expected if abs(r - 2.5307274) < 1e-7]
    assert len(expected) == 4 and len(close) == 2 and 6e-9 < close[1] - close[0] < 7e-9    # the numbers
    assert main(["map", str(path), "--grid", COARSE_TURN, "--joint", "D", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    data = json.loads(out.read_text())
    points = [(p["input"], p["tolerance"], p["polished"]) for p in data["branch_points"]]
    check_every_branch_point_found_or_held(points, data["unresolved"], data["cover"], expected)
    assert any(lo <= close[0] and close[1] <= hi for lo, hi in data["cover"]["unresolved"])
    assert data["cover"]["tol"] == 1e-6 and data["cover"]["cells"]
    assert "cross-check: certified singular cover of A" in text and "turned unresolved" in text
    assert "the certified cover holds a singular input there" in text


@pytest.mark.parametrize("sign, roots", [(+1, 0), (-1, 2)])
def test_the_change_points_last_bit_variants_lose_no_branch_point(tmp_path, sign, roots):
    """One ulp of C's y component up: the dip stays above 0 (no branch point there, 50 digits); down: it
    crosses (two, 1.3e-8 apart). Either way every branch point of the reference over the interval is
    located (within its tolerance) or inside an unresolved interval, and none lies outside the cover."""
    path = tmp_path / "variant.toml"
    lo, hi = AROUND_CHANGE_POINT
    expected = [r for r in branch_inputs_mp(change_point_file(path, ("C", 1, sign))) if lo <= r <= hi]
    assert len(expected) == roots and all(abs(r - 2.5307274) < 1e-7 for r in expected)
    bmap = branch_map(path, f"A={lo}:{hi}:4", joint="D")
    check_every_branch_point_found_or_held([(p.input, p.tolerance, p.polished) for p in bmap.branch_points],
                                           bmap.unresolved, bmap.cover.as_dict(), expected)


def test_a_circuit_between_two_grid_inputs_is_found_at_the_covers_cells(tmp_path):
    """The non-Grashof four-bar assembles over [e0, e1] only; a grid of two inputs around that range sees
    no assembly. The cover's cells there (its runs' edges solved) give the circuit and its two branch
    points, at the closed form's inputs."""
    path = tmp_path / "non_grashof.toml"
    geo = write_four_bar(path, NON_GRASHOF, NON_GRASHOF_THETA0)
    e0, e1 = branch_inputs(geo)
    bmap = branch_map(path, f"A={float(e0) - 0.3!r}:{float(e1) + 0.3!r}:2", joint="D")
    assert bmap.counts == (0, 0) and not bmap.unresolved
    assert sorted(p.input for p in bmap.branch_points) == pytest.approx([e0, e1], abs=CLOSED_FORM_TOL)
    assert len(bmap.circuits) == 1 and len(bmap.circuits[0].branch_points) == 2
    assert bmap.cover.samples == 4 and bmap.cover.unresolved == () and bmap.cover.disagreements == ()


def test_a_located_branch_point_outside_the_cover_is_reported_never_silent(monkeypatch, tmp_path):
    """A cover that holds no cell (standing in for a wrong one): the located branch point of the
    non-Grashof four-bar at the lower end of its range is a disagreement, kept in the map and named in
    the report; a cover that cannot be computed says so in one line."""
    import types

    import spherekin.singularities.cover

    path = tmp_path / "non_grashof.toml"
    e0, _ = branch_inputs(write_four_bar(path, NON_GRASHOF, NON_GRASHOF_THETA0))
    grid = f"A={float(e0) - 1.3e-4!r}:{float(e0) + 2.9e-4!r}:2"     # no cell: the grid must see the count change
    monkeypatch.setattr(spherekin.singularities.cover, "singular",
                        lambda *args, **kwargs: types.SimpleNamespace(boxes=(), complete=True))
    bmap = branch_map(path, grid, joint="D")
    assert bmap.counts == (0, 2) and len(bmap.branch_points) == 1 and bmap.cover.disagreements == (0,)
    assert bmap.branch_points[0].input == pytest.approx(e0, abs=CLOSED_FORM_TOL)
    assert "DISAGREES: 1 located branch point(s) outside the cover (branch point(s) 1)" in bmap.report()
    assert bmap.as_dict()["cover"]["disagreements"] == [0]

    def refuse(*args, **kwargs):
        raise ValueError("det K_p: too many terms")

    monkeypatch.setattr(spherekin.singularities.cover, "singular", refuse)
    bmap = branch_map(path, grid, joint="D")
    assert bmap.cover.error == "det K_p: too many terms" and len(bmap.branch_points) == 1
    assert "cross-check: not done (the certified singular cover failed: det K_p: too many terms)" in bmap.report()


def test_cross_check_accounts_for_cells_near_a_located_point_only():
    """cross_check on numbers worked by hand (T = 1e-6, COVER_EXPLAINS = 2): a point at 0.5e-6 accounts
    for [-1.5e-6, 2.5e-6], so the run [0, 2e-6] and half of [2e-6, 3e-6]; a point at 10 meets no cell;
    on a full turn a point just below -pi accounts for the cell just below pi."""
    from spherekin.batch.branches import cross_check

    cells = [(1e-6, 2e-6), (0.0, 1e-6), (2e-6, 3e-6), (5e-6, 6e-6)]
    left, outside = cross_check(cells, [(0.5e-6, 1e-14), (10.0, 1e-14)], 1e-6)
    assert outside == (1,)
    assert len(left) == 2 and left[1] == (5e-6, 6e-6)
    assert left[0] == pytest.approx((2.5e-6 + 1e-14, 3e-6), abs=1e-20)
    top = (math.pi - 1e-6, math.pi)
    assert cross_check([top], [(-math.pi - 1e-9, 1e-14)], 1e-6, 2 * math.pi) == ((), ())
    assert cross_check([top], [(-math.pi - 1e-9, 1e-14)], 1e-6) == (((math.pi - 1e-6, math.pi),), (0,))


@pytest.mark.parametrize("value, words", [(0, "expected 0 < T <= 0.5 (radians)"), (-1e-6, "expected 0 < T"),
                                          (0.6, "expected 0 < T"), (True, "expected 0 < T"), ("1e-6", "expected 0 < T"),
                                          (1e-9, "is below 1.28e-07")])
def test_a_bad_cover_tol_is_refused_in_one_line_before_any_solve(value, words):
    with pytest.raises(ValueError, match="^cover_tol: ") as err:
        branch_map(FOUR_BAR, "A=-1:1:3", cover_tol=value)
    assert words in str(err.value)
    assert "\n" not in str(err.value)
