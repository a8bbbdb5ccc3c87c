"""Tests for spherekin.search.lp_backends against an independent dense implementation of Eq. (12).

The reference is written here from the paper: for one box, with the control points v_I =
(i_1/m_1, ..., i_n/m_n, w_I) of every equation (an axis of degree 0 is first elevated to degree 1,
which repeats the constant and gives every v_I all n abscissae), minimize and maximize each x_k
subject to (x, 0) = sum_I c_I v_I, c_I >= 0, sum_I c_I = 1 for every equation at once, with the
plane w = 0 replaced by the slab |w| <= tol as documented. It is solved by
scipy.optimize.linprog(method="highs") on dense matrices, with all n abscissae per equation
(the backends use only the variables an equation depends on, with integer abscissa rows).

The backends' bounds come from dual certificates verified by spherekin (Neumaier & Shcherbina
2004). The adversarial tests replace a backend's ``_solve`` (and ``_farkas``) with one that
returns wrong points, garbage duals, the answer to the opposite objective, or a spurious
"infeasible": the bounds must still contain the reference box, and a box may be discarded only
when the reference agrees it is empty.
"""

import functools
import re

from fractions import Fraction

import numpy as np
import pytest
from scipy.optimize import linprog

from spherekin.core import bernstein
from tests.formulate_cases import formulate
from spherekin.search.lp_backends import (INFEASIBLE, LP_BACKENDS, LP_OPTIONS, OPTIMAL, OTHER, REJECTED_BACKEND_CLASSES,
                                          REJECTED_LP_BACKENDS,
                                          ClarabelBackend, HighsCvxpyBackend, HighspyBackend, LPBackend, LPStructure,
                                          backend_class, make_backend)
from spherekin.search.pruners import check_pruner, make_pruner
from spherekin.mechanism import gosselin
from spherekin.search.boxloop import ROUNDING_SAFETY

#: No certified bound may lie inside the reference bound by more than this (the reference is HiGHS
#: simplex at its 1e-7 default tolerances on O(1) data; measured: never more than 5e-16 inside).
REF_TOL = 1e-8
#: On honest solves a certified bound may lie outside the reference optimum by at most this
#: (measured on the random and Gosselin boxes below: highspy and highs <= 1.1e-10, median 3e-13 --
#: the rounding margin; clarabel <= 1.1e-8, median 2e-11).
CERT_LOOSENESS = 1e-7
EPS = np.finfo(float).eps


# ---------------------------------------------------------------- dense reference of Eq. (12)

def elevated(w):
    """Degree-0 axes elevated to degree 1 (the constant repeated): same polynomial, all n abscissae."""
    for k in range(w.ndim):
        if w.shape[k] == 1:
            w = np.repeat(w, 2, axis=k)
    return w


def reference_bounds(cps, tols, relax=1.0):
    """min / max of each x_k over Eq. (12) for all equations of all blocks; None when infeasible.

    cps: per block (E, d_1..d_n) control points on the box; tols: per block (E,) slab half-widths.
    Variables: x (n), then c_e (all control points of equation e, elevated).
    """
    n = cps[0].ndim - 1
    eqs = [(elevated(c[e]), float(t[e]) * relax) for c, t in zip(cps, tols) for e in range(c.shape[0])]
    nvar = n + sum(w.size for w, _ in eqs)
    a_eq, b_eq, a_ub, b_ub = [], [], [], []
    off = n
    for w, tol in eqs:
        size = w.size
        absc = np.indices(w.shape).reshape(n, -1) / (np.array(w.shape)[:, None] - 1)   # i_k / m_k
        row = np.zeros(nvar)
        row[off:off + size] = 1.0                       # sum c = 1
        a_eq.append(row)
        b_eq.append(1.0)
        for k in range(n):                              # sum c_I i_k/m_k = x_k
            row = np.zeros(nvar)
            row[off:off + size] = absc[k]
            row[k] = -1.0
            a_eq.append(row)
            b_eq.append(0.0)
        s = np.abs(w).max()                             # a row divided by a positive number: same set
        if s > 0:                                       # (w = 0 satisfies the slab everywhere)
            row = np.zeros(nvar)
            row[off:off + size] = w.ravel() / s
            a_ub += [row, -row]                         # |sum c_I w_I| <= tol
            b_ub += [tol / s, tol / s]
        off += size
    lo, hi = np.zeros(n), np.ones(n)
    for k in range(n):
        for sign in (1.0, -1.0):
            cost = np.zeros(nvar)
            cost[k] = sign
            res = linprog(cost, A_ub=np.array(a_ub).reshape(-1, nvar), b_ub=b_ub, A_eq=np.array(a_eq), b_eq=b_eq,
                          bounds=(0, None), method="highs")
            if res.status == 2:
                return None
            assert res.status == 0, res.message
            if sign > 0:
                lo[k] = res.x[k]
            else:
                hi[k] = res.x[k]
    return lo, hi


def assert_valid(res, ref):
    """The certified box contains the reference box (no point of Eq. 12 cut off)."""
    assert not res.empty
    assert np.all(res.lo <= ref[0] + REF_TOL) and np.all(res.hi >= ref[1] - REF_TOL), (res, ref)


def assert_matches_reference(res, ref):
    """Valid, and no looser than the reference optimum by more than CERT_LOOSENESS."""
    assert_valid(res, ref)
    assert np.all(res.lo >= ref[0] - CERT_LOOSENESS) and np.all(res.hi <= ref[1] + CERT_LOOSENESS), (res, ref)


def looseness(res, ref):
    return max(np.max(ref[0] - res.lo), np.max(res.hi - ref[1]))


# ---------------------------------------------------------------- test systems

SMALL_SHAPES = {
    2: [(2, 3, 3), (1, 3, 1)],                  # two equations in (x0, x1), one in x0 only
    3: [(3, 3, 3, 3), (1, 1, 3, 3)],            # three in (x0, x1, x2), one without x0
}


def random_boxes(seed, n, count):
    """Random control points for SMALL_SHAPES[n] whose slab usually meets the hull (and not always)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        cps = [rng.normal(size=s) + rng.uniform(-0.8, 0.8, size=(s[0],) + (1,) * n) for s in SMALL_SHAPES[n]]
        tols = [rng.choice([1e-12, 1e-5, 1e-3], size=s[0]) for s in SMALL_SHAPES[n]]
        out.append((cps, tols))
    return out


def gosselin_blocks(formulation):
    """The brief's Gosselin system at inputs (0.3, -0.2, 0.5), passive ranges (-1.5, 1.5)."""
    mech = gosselin()
    system = mech.loop_system((0.3, -0.2, 0.5), {n: (-1.5, 1.5) for n in mech.passive})
    blocks = formulate(formulation, system.loops, system.unknowns)
    return [b.coeffs for b in blocks], [ROUNDING_SAFETY * EPS * b.scale for b in blocks]


@functools.lru_cache(maxsize=None)
def narrow_gosselin_boxes(count=60):
    """Narrow boxes (widths 1e-3..0.3) of the transversal Gosselin system, with their reference
    bounds: nearly infeasible LPs, on which HiGHS's primal simplex sometimes answers kUnknown."""
    coeffs, tols = gosselin_blocks("transversal")
    rng = np.random.default_rng(5)
    out = []
    for _ in range(count):
        w = 10 ** rng.uniform(-3, -0.5)
        lo = rng.uniform(0.2, 0.8 - w, 6)
        cps = [bernstein.restrict(c, np.c_[lo, lo + w], nvars=6) for c in coeffs]
        out.append((cps, tols, reference_bounds(cps, tols)))
    return out


# ---------------------------------------------------------------- backends vs the reference

@pytest.mark.parametrize("name", LP_BACKENDS)
class TestBackendAgainstDenseEq12:

    @pytest.mark.parametrize("n", [2, 3])
    def test_random_boxes(self, name, n):
        backend = make_backend(name, SMALL_SHAPES[n])     # one instance: no state leaks between boxes
        kinds = {"empty": 0, "cut": 0}
        for cps, tols in random_boxes(10 + n, n, 16):
            ref = reference_bounds(cps, tols)
            res = backend.box_bounds(cps, tols)
            assert res.doubts == 0
            if ref is None:                                 # infeasible: proven by a Farkas certificate
                assert res.empty
                kinds["empty"] += 1
            else:
                assert_matches_reference(res, ref)
                kinds["cut"] += bool(np.any(ref[0] > 1e-3) or np.any(ref[1] < 1 - 1e-3))
        assert kinds["empty"] >= 1 and kinds["cut"] >= 3

    @pytest.mark.parametrize("formulation", ["transversal", "paper"])
    def test_gosselin_boxes(self, name, formulation):
        coeffs, tols = gosselin_blocks(formulation)
        backend = make_backend(name, [c.shape for c in coeffs])
        for box, nonempty in (([0.25, 0.75], True), ([0.0, 0.5], False), ([0.3, 0.8], None)):
            cps = [bernstein.restrict(c, np.array([box] * 6), nvars=6) for c in coeffs]
            ref = reference_bounds(cps, tols)
            if nonempty is not None:
                assert (ref is not None) == nonempty            # the test data are what they claim
            res = backend.box_bounds(cps, tols)
            assert res.doubts == 0
            if ref is None:
                assert res.empty
            else:
                assert_matches_reference(res, ref)

    def test_narrow_gosselin_boxes_are_decided_without_doubt(self, name):
        """Measured before the certificates: highspy left 9 of these 60 boxes undecided (46 doubts,
        from kUnknown verdicts); now a Farkas certificate decides every empty one."""
        cases = narrow_gosselin_boxes()
        backend = make_backend(name, [c.shape for c in cases[0][0]])
        for cps, tols, ref in cases:
            res = backend.box_bounds(cps, tols)
            assert res.doubts == 0
            if ref is None:
                assert res.empty
            else:
                assert_matches_reference(res, ref)
        assert sum(ref is None for *_, ref in cases) >= 50

    def test_equation_above_the_slab_gives_an_empty_box(self, name):
        rng = np.random.default_rng(3)
        cps = [rng.normal(size=(2, 3, 3)), 0.5 + rng.uniform(0.0, 1.0, size=(1, 3, 1))]   # w > tol everywhere
        tols = [np.full(2, 1e-3), np.full(1, 1e-3)]
        assert reference_bounds(cps, tols) is None
        res = make_backend(name, SMALL_SHAPES[2]).box_bounds(cps, tols)
        assert res.empty and np.all(res.lo > res.hi) and res.doubts == 0

    def test_disjoint_hulls_give_an_empty_box(self, name):
        """Each block alone has roots (x0 = 0.2, x0 = 0.9); only the intersection of hulls is empty."""
        first = np.broadcast_to(np.array([-0.2, 0.3, 0.8])[:, None], (3, 3))    # x0 - 0.2, degree 2
        cps = [np.stack([first, 2 * first]), np.array([[[-0.9], [-0.4], [0.1]]])]  # x0 - 0.9
        tols = [np.full(2, 1e-9), np.full(1, 1e-9)]
        assert reference_bounds(cps[:1], tols[:1]) is not None
        assert reference_bounds(cps[1:], tols[1:]) is not None
        assert reference_bounds(cps, tols) is None
        assert make_backend(name, SMALL_SHAPES[2]).box_bounds(cps, tols).empty

    def test_slightly_infeasible_box_is_proven_empty(self, name):
        """Hull just above the slab (2..3 tol): infeasible by a margin far above rounding, so the
        Farkas certificate proves it (the old protocol kept such boxes as too close to call)."""
        rng = np.random.default_rng(4)
        tol = 1e-3
        cps = [tol * rng.uniform(2.0, 3.0, size=(2, 3, 3)), np.zeros((1, 3, 1))]
        tols = [np.full(2, tol), np.full(1, tol)]
        assert reference_bounds(cps, tols) is None and reference_bounds(cps, tols, relax=3.0) is not None
        res = make_backend(name, SMALL_SHAPES[2]).box_bounds(cps, tols)
        assert res.empty and res.doubts == 0

    def test_equations_inside_the_slab_solve_nothing(self, name):
        cps = [np.full((2, 3, 3), 1e-4), np.full((1, 3, 1), -1e-4)]
        tols = [np.full(2, 1e-3), np.full(1, 1e-3)]
        res = make_backend(name, SMALL_SHAPES[2]).box_bounds(cps, tols)
        assert (res.empty, res.lp_count, res.doubts) == (False, 0, 0)
        np.testing.assert_array_equal(np.r_[res.lo, res.hi], [0, 0, 1, 1])

    # ------------------------------------------------------------ adversarial solvers

    def test_honest_answers_are_used(self, name, monkeypatch):
        """Control for the tests below: the spy passing answers through gives the reference box."""
        backend, cps, tols, ref = protocol_case(name)
        log = spy(backend, monkeypatch, lambda real, d, i: real(d))
        res = backend.box_bounds(cps, tols)
        assert res.doubts == 0 and log["loads"] == 1 and log["solves"] == 4
        assert_matches_reference(res, ref)

    def test_feasible_but_suboptimal_point_is_not_taken_as_a_bound(self, name, monkeypatch):
        backend, cps, tols, ref = protocol_case(name)
        # answer every objective with the answer (point and duals) to the OPPOSITE one: the point
        # is feasible but not optimal, the duals are not a certificate for this objective
        log = spy(backend, monkeypatch, lambda real, d, i: real(-d))
        res = backend.box_bounds(cps, tols)
        assert log["solves"] == 4
        assert_valid(res, ref)
        assert res.doubts >= 1                           # the point lies far beyond the certified bound

    @pytest.mark.parametrize("kind", ["nan", "outside", "shifted_x", "lambda_sum", "slab", "missing"])
    def test_bad_points_with_honest_duals_give_the_certified_bounds(self, name, kind, monkeypatch):
        """The primal point is only a diagnostic: the bound comes from the (honest) duals."""
        backend, cps, tols, ref = protocol_case(name)
        spy(backend, monkeypatch, corrupt_point(backend, kind))
        res = backend.box_bounds(cps, tols)
        assert_matches_reference(res, ref)
        assert res.doubts == 4 and res.lp_count == 4

    @pytest.mark.parametrize("kind", ["zeros", "random", "huge", "flipped", "scaled", "perturbed", "one_row"])
    def test_garbage_duals_give_valid_bounds(self, name, kind, monkeypatch):
        backend, cps, tols, ref = protocol_case(name)
        spy(backend, monkeypatch, corrupt_duals(kind))
        res = backend.box_bounds(cps, tols)
        assert_valid(res, ref)
        assert res.doubts >= 1                           # honest point, loose certificate: flagged

    @pytest.mark.parametrize("kind", ["none", "nan", "inf", "wrong_length"])
    def test_unusable_duals_leave_bounds_at_the_faces(self, name, kind, monkeypatch):
        backend, cps, tols, ref = protocol_case(name)
        spy(backend, monkeypatch, corrupt_duals(kind))
        res = backend.box_bounds(cps, tols)
        assert not res.empty and res.doubts == 4 and res.lp_count == 4
        np.testing.assert_array_equal(res.lo, 0.0)
        np.testing.assert_array_equal(res.hi, 1.0)

    def test_failed_solve_without_duals_leaves_the_faces(self, name, monkeypatch):
        backend, cps, tols, ref = protocol_case(name)
        log = spy(backend, monkeypatch, corrupt_duals("other"))
        res = backend.box_bounds(cps, tols)       # each failure asks _farkas, which proves nothing
        assert log["solves"] == 4 and res.lp_count >= 4
        assert not res.empty and res.doubts == 4
        np.testing.assert_array_equal(res.lo, 0.0)
        np.testing.assert_array_equal(res.hi, 1.0)

    def test_failed_solve_with_duals_still_gives_certified_bounds(self, name, monkeypatch):
        """The status does not matter for soundness: the duals of a 'failed' solve are checked."""
        backend, cps, tols, ref = protocol_case(name)

        def answer(real, d, i):
            status, z, y = real(d)
            return OTHER, z, y

        spy(backend, monkeypatch, answer)
        res = backend.box_bounds(cps, tols)
        assert_matches_reference(res, ref)
        assert res.doubts == 4

    def test_failed_solve_on_an_infeasible_box_is_proven_empty(self, name, monkeypatch):
        """A failed verdict (HiGHS reports kUnknown on some nearly infeasible boxes) still asks
        for a Farkas certificate; here the real solve left one in the solver's state."""
        rng = np.random.default_rng(3)
        cps = [rng.normal(size=(2, 3, 3)), 0.5 + rng.uniform(0.0, 1.0, size=(1, 3, 1))]   # w > tol everywhere
        tols = [np.full(2, 1e-3), np.full(1, 1e-3)]
        assert reference_bounds(cps, tols) is None
        backend = make_backend(name, SMALL_SHAPES[2])

        def answer(real, d, i):
            assert real(d)[0] == INFEASIBLE
            return OTHER, None, None

        spy(backend, monkeypatch, answer)
        res = backend.box_bounds(cps, tols)
        assert res.empty and res.doubts == 0

    def test_spurious_infeasible_is_not_trusted(self, name, monkeypatch):
        backend, cps, tols, ref = protocol_case(name)
        log = spy(backend, monkeypatch, lambda real, d, i: (INFEASIBLE, None, None) if i == 0 else real(d))
        res = backend.box_bounds(cps, tols)       # the backend's own _farkas finds no certificate
        assert log["solves"] == 1
        assert not res.empty and res.doubts == 1
        np.testing.assert_array_equal(res.lo, 0.0)
        np.testing.assert_array_equal(res.hi, 1.0)

    @pytest.mark.parametrize("kind", ["none", "zeros", "random", "huge", "nan", "optimal_duals"])
    def test_garbage_farkas_certificates_are_rejected(self, name, kind, monkeypatch):
        backend, cps, tols, ref = protocol_case(name)
        honest = backend.structure
        rng = np.random.default_rng(5)

        def farkas():
            if kind == "optimal_duals":         # a real dual solution: a bound, not a Farkas proof
                return backend._solve(np.array([1.0, 0.0]))[2], 1
            y = {"none": None, "zeros": np.zeros(honest.nrow), "random": rng.normal(size=honest.nrow),
                 "huge": 1e300 * rng.normal(size=honest.nrow), "nan": np.full(honest.nrow, np.nan)}[kind]
            return y, 0

        spy(backend, monkeypatch, lambda real, d, i: (INFEASIBLE, None, None), farkas=farkas)
        res = backend.box_bounds(cps, tols)
        assert not res.empty and res.doubts == 1
        np.testing.assert_array_equal(res.lo, 0.0)
        np.testing.assert_array_equal(res.hi, 1.0)

    def test_bounds_certified_before_an_unproven_infeasible_verdict_are_kept(self, name, monkeypatch):
        backend, cps, tols, ref = protocol_case(name)
        spy(backend, monkeypatch, lambda real, d, i: (INFEASIBLE, None, None) if i == 2 else real(d))
        res = backend.box_bounds(cps, tols)
        assert not res.empty and res.doubts == 1
        assert_valid(res, ref)
        assert abs(res.lo[0] - ref[0][0]) <= CERT_LOOSENESS and abs(res.hi[0] - ref[1][0]) <= CERT_LOOSENESS
        np.testing.assert_array_equal([res.lo[1], res.hi[1]], [0.0, 1.0])


# ---------------------------------------------------------------- the doubt protocol: helpers

def protocol_case(name):
    """A box whose Eq. (12) region is a proper sub-box, and a backend ``name`` for it."""
    cps, tols = random_boxes(21, 2, 1)[0]
    cps[1] = np.array([[[-0.5], [0.1], [0.9]]])          # x0 confined to where this one can vanish
    cps[0][0, 1, 1] = 1.0                                # the centre point is far off the slab
    cps[0][0, ::2, ::2] = 0.0                            # corners on w = 0: lambda can move among them
    ref = reference_bounds(cps, tols)
    assert ref is not None and np.any(ref[0] > 0.05)
    return make_backend(name, SMALL_SHAPES[2]), cps, tols, ref


def spy(backend, monkeypatch, answer, farkas=None):
    """Replace backend._solve by answer(real_solve, direction, call_index) (and _farkas by farkas)."""
    real_solve, real_load = backend._solve, backend._load
    log = {"loads": 0, "solves": 0}

    def load():
        log["loads"] += 1
        real_load()

    def solve(direction):
        log["solves"] += 1
        return answer(real_solve, direction, log["solves"] - 1)

    monkeypatch.setattr(backend, "_load", load)
    monkeypatch.setattr(backend, "_solve", solve)
    if farkas is not None:
        monkeypatch.setattr(backend, "_farkas", farkas)
    return log


def corrupt_point(backend, kind):
    """An answer that keeps the real duals and turns the real optimal point z into a bad one."""
    n = backend.structure.n
    first = backend.structure.equations[0].cols          # lambda of equation 0: a 3 x 3 grid

    def answer(real, direction, i):
        status, z, y = real(direction)
        assert status == OPTIMAL
        z = z.copy()
        if kind == "missing":
            return OPTIMAL, None, y
        if kind == "nan":
            z[0] = np.nan
        elif kind == "outside":
            z[:n] = 1.5
        elif kind == "shifted_x":            # claims a bound 0.1 inside the true one
            z[:n] -= 0.1 * direction
        elif kind == "lambda_sum":           # mass added at abscissa (0, 0), where w = 0: only the sum moves
            z[first.start] += 0.01
        elif kind == "slab":                 # the centre control point of every equation: x = (0.5, 0.5),
            z[:n] = 0.5                      # sum = 1, abscissae = x; only the slab rows fail
            for eq in backend.structure.equations:
                z[eq.cols] = 0.0
                z[eq.cols.start + (eq.cols.stop - eq.cols.start) // 2] = 1.0
        return OPTIMAL, z, y
    return answer


def corrupt_duals(kind):
    """An answer that keeps the real optimal point and replaces the real duals y by bad ones."""
    rng = np.random.default_rng(7)

    def answer(real, direction, i):
        status, z, y = real(direction)
        assert status == OPTIMAL
        if kind == "other":
            return OTHER, None, None
        bad = {
            "none": lambda: None,
            "zeros": lambda: np.zeros_like(y),
            "random": lambda: rng.normal(size=y.shape),
            "huge": lambda: 1e12 * rng.normal(size=y.shape),
            "flipped": lambda: -y,
            "scaled": lambda: 1.5 * y,
            "perturbed": lambda: y + 1e-3 * rng.normal(size=y.shape),
            "one_row": lambda: np.where(np.arange(len(y)) == np.argmax(np.abs(y)), 0.0, y),
            "nan": lambda: np.where(np.arange(len(y)) == 1, np.nan, y),
            "inf": lambda: np.where(np.arange(len(y)) == 1, np.inf, y),
            "wrong_length": lambda: y[:-1],
        }[kind]()
        return OPTIMAL, z, bad
    return answer


# ---------------------------------------------------------------- the certificates themselves

def test_weak_duality_bound_never_exceeds_the_true_minimum():
    """certified_min for arbitrary multipliers y on the protocol box vs the reference optimum."""
    backend, cps, tols, ref = protocol_case("highspy")
    st = backend.structure
    assert st.load(cps, tols)
    backend._load()
    rng = np.random.default_rng(11)
    tightest = {}
    for k in range(st.n):
        for sign in (1.0, -1.0):
            c = st.objective(k, sign)
            true_min = ref[0][k] if sign > 0 else -ref[1][k]
            status, _, y = backend._solve(c[:st.n].copy())
            assert status == OPTIMAL
            candidates = [y] + [y + s * rng.normal(size=y.shape) for s in (1e-12, 1e-9, 1e-6, 1e-3, 1.0)
                                for _ in range(20)] + [s * rng.normal(size=y.shape) for s in (1e-3, 1.0, 1e3)]
            bounds = np.array([st.certified_min(c, cand) for cand in candidates])
            assert np.all(bounds <= true_min + REF_TOL), (k, sign, bounds.max() - true_min)
            tightest[(k, sign)] = true_min - bounds[0]
    assert max(tightest.values()) < CERT_LOOSENESS, tightest          # honest duals: tight


def test_hand_made_farkas_certificate():
    """One equation of the first block lies above the slab: w_I >= a > tol at every control point.
    y = a on its sum row and -1 on its slab row gives reduced costs w_I - a >= 0 on its lambda and
    0 elsewhere, so the bound with c = 0 is a - tol' > 0 (derived by hand, not by the code)."""
    cps = [np.zeros((2, 3, 3)), np.zeros((1, 3, 1))]
    cps[0][0] = 0.25 + np.arange(9).reshape(3, 3) / 8       # w in [0.25, 1.25]: scaled by 1.25
    tol = 1e-3
    tols = [np.full(2, tol), np.full(1, tol)]
    st = LPStructure(SMALL_SHAPES[2])
    cps[1][0] = np.array([[-1.0], [0.0], [1.0]])            # active, but not involved
    assert st.load(cps, tols)
    eq = st.equations[0]
    y = np.zeros(st.nrow)
    y[eq.slab_row] = -1.0
    y[eq.sum_row] = 0.25 / 1.25                              # a = min scaled w
    assert st.certifies_empty(y) and st.certifies_empty(-y)  # either sign convention is accepted
    cps[0][0] -= 0.25 - 0.5 * tol                           # now min w = tol / 2 < tol: feasible
    assert st.load(cps, tols)
    y[eq.sum_row] = (0.5 * tol) / (1.0 + 0.5 * tol)
    assert not st.certifies_empty(y) and not st.certifies_empty(-y)
    assert not st.certifies_empty(np.zeros(st.nrow)) and not st.certifies_empty(None)


def test_highspy_proves_infeasibility_with_the_dual_simplex_when_no_ray_is_known(monkeypatch):
    """Fallback of HighspyBackend._farkas: no ray in HiGHS's state (here: the verdict is claimed
    without a solve of this box) -> one warm-started dual-simplex re-run, whose ray is verified."""
    rng = np.random.default_rng(3)
    cps = [rng.normal(size=(2, 3, 3)), 0.5 + rng.uniform(0.0, 1.0, size=(1, 3, 1))]   # infeasible
    tols = [np.full(2, 1e-3), np.full(1, 1e-3)]
    assert reference_bounds(cps, tols) is None
    backend = make_backend("highspy", SMALL_SHAPES[2])
    assert not backend.h.getDualRay()[1]
    spy(backend, monkeypatch, lambda real, d, i: (INFEASIBLE, None, None))
    res = backend.box_bounds(cps, tols)
    assert res.empty and res.doubts == 0 and res.lp_count == 2
    # the strategy is restored for the next box
    assert backend.h.getOptionValue("simplex_strategy")[1] == LP_OPTIONS["simplex_strategy"]


# ---------------------------------------------------------------- names, shapes, input

def test_backend_names():
    with pytest.raises(ValueError) as err:
        make_backend("glpk", SMALL_SHAPES[2])
    assert "glpk" in str(err.value) and all(name in str(err.value) for name in LP_BACKENDS)


def test_the_registry_lists_exactly_the_backends():
    assert list(LP_BACKENDS) == ["clarabel", "highs", "highspy"]
    assert [LP_BACKENDS[n] for n in LP_BACKENDS] == [ClarabelBackend, HighsCvxpyBackend, HighspyBackend]
    assert all(issubclass(cls, LPBackend) for cls in LP_BACKENDS.values())
    assert not set(REJECTED_LP_BACKENDS) & set(LP_BACKENDS)


@pytest.mark.parametrize("name", ["glpk", "osqp"])
@pytest.mark.parametrize("call", [backend_class, lambda name: make_backend(name, SMALL_SHAPES[2])],
                         ids=["backend_class", "make_backend"])
def test_an_unknown_backend_is_the_registry_error(call, name):
    with pytest.raises(ValueError, match=re.escape(f"lp_backend: expected one of {list(LP_BACKENDS)}, got {name!r}")):
        call(name)


def test_a_registered_backend_is_accepted_by_the_lookup(registered):
    class HighspyAgain(HighspyBackend):
        name = "highspy-again"

    registered(LP_BACKENDS, HighspyAgain)
    check_pruner("lp", "highspy-again")
    pruner = make_pruner("lp", SMALL_SHAPES[2], "highspy-again")
    assert isinstance(pruner.backend, HighspyAgain)
    cps, tols = random_boxes(1, 2, 1)[0]
    got, want = pruner.backend.box_bounds(cps, tols), make_backend("highspy", SMALL_SHAPES[2]).box_bounds(cps, tols)
    assert got.empty == want.empty and np.array_equal(got.lo, want.lo) and np.array_equal(got.hi, want.hi)


def test_structure_rejects_bad_shapes():
    with pytest.raises(ValueError, match="shapes"):
        LPStructure([])
    with pytest.raises(ValueError, match="shapes"):
        LPStructure([(2, 3, 3), (1, 3)])
    with pytest.raises(ValueError, match="shapes"):
        LPStructure([(0, 3, 3)])


def test_box_bounds_rejects_bad_input():
    backend = make_backend("highspy", SMALL_SHAPES[2])
    cps, tols = random_boxes(1, 2, 1)[0]
    with pytest.raises(ValueError, match="blocks"):
        backend.box_bounds(cps[:1], tols[:1])
    with pytest.raises(ValueError, match=r"cps\[1\].*shape"):
        backend.box_bounds([cps[0], cps[0]], tols)
    with pytest.raises(ValueError, match=r"tols\[0\].*shape"):
        backend.box_bounds(cps, [tols[0][:1], tols[1]])
    bad = [cps[0].copy(), cps[1]]
    bad[0][0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        backend.box_bounds(bad, tols)
    with pytest.raises(ValueError, match="tolerances >= 0"):
        backend.box_bounds(cps, [-tols[0], tols[1]])


@pytest.mark.parametrize("name", ["osqp", "scs"])
def test_rejected_backends_explain_why(name):
    with pytest.raises(ValueError, match=f"{name}.*not supported.*valid certified bounds.*slower"):
        make_backend(name, SMALL_SHAPES[2])


@pytest.mark.parametrize("name", sorted(REJECTED_BACKEND_CLASSES))
def test_refused_first_order_backends_still_give_valid_certified_bounds(name):
    """The refusal is for speed, not soundness (issue 18): OSQP's and SCS's approximate duals,
    through certified_min, never cut into the reference box of the exact LP (HiGHS via linprog),
    and a box is empty only when the reference says so. Small boxes only (~10-30 ms per LP)."""
    cls = REJECTED_BACKEND_CLASSES[name]
    assert cls.name == name and name not in LP_BACKENDS
    backend = cls(SMALL_SHAPES[2])
    kinds = {"empty": 0, "cut": 0}
    for cps, tols in random_boxes(12, 2, 6):
        ref = reference_bounds(cps, tols)
        res = backend.box_bounds(cps, tols)
        if res.empty:
            assert ref is None
            kinds["empty"] += 1
        elif ref is not None:
            assert_valid(res, ref)
            kinds["cut"] += bool(np.any(res.lo > 1e-3) or np.any(res.hi < 1 - 1e-3))   # and useful
    assert kinds["empty"] >= 1 and kinds["cut"] >= 2


def test_cvxpy_invalid_solution_is_a_doubt_not_a_crash(monkeypatch):
    """cvxpy raises ValueError('Cannot unpack invalid solution ...') when HiGHS ends in kUnknown
    (seen on the Gosselin transversal system): the box must be kept, with a doubt, not crash the run."""
    backend, cps, tols, ref = protocol_case("highs")

    def fails(*args, **kwargs):
        raise ValueError("Cannot unpack invalid solution: Solution(status=UNKNOWN, ...)")

    monkeypatch.setattr(backend.problem, "solve", fails)
    res = backend.box_bounds(cps, tols)
    assert not res.empty and res.doubts == 4
    np.testing.assert_array_equal(res.lo, 0.0)
    np.testing.assert_array_equal(res.hi, 1.0)


def test_other_value_errors_of_cvxpy_are_not_swallowed(monkeypatch):
    backend, cps, tols, ref = protocol_case("highs")

    def fails(*args, **kwargs):
        raise ValueError("some programming error")

    monkeypatch.setattr(backend.problem, "solve", fails)
    with pytest.raises(ValueError, match="programming error"):
        backend.box_bounds(cps, tols)


def test_highs_backends_print_nothing_on_stdout():
    """HiGHS prints its banner from its C++ constructor to fd 1, once per process: run in a fresh
    process so the first construction is spherekin's; its output must stay clean."""
    import subprocess
    import sys

    code = ("import numpy as np\n"
            "from spherekin.search.lp_backends import make_backend\n"
            "for name in ('highspy', 'highs'):\n"
            "    b = make_backend(name, [(3, 3), (3, 3)])\n"
            "print('done')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out == "done\n"


def test_highspy_after_cvxpy_highs_in_one_process():
    """HiGHS's per-process thread scheduler: the direct backend must still solve (no doubt) after
    cvxpy's HIGHS backend has run (a 'threads' option mismatch made every direct run fail)."""
    b0, cps, tols, _ = protocol_case("highs")
    b0.box_bounds(cps, tols)
    backend, cps, tols, ref = protocol_case("highspy")
    res = backend.box_bounds(cps, tols)
    assert res.doubts == 0
    assert_matches_reference(res, ref)


def test_highspy_that_refuses_to_run_is_an_error_not_a_doubt():
    """A HiGHS configuration error makes every run fail before it starts (here: a thread count other
    than the one HiGHS's per-process scheduler was set up with by the first solve); the direct
    backend must say so instead of keeping every box as a 'doubt'."""
    backend, cps, tols, _ = protocol_case("highspy")
    backend.box_bounds(cps, tols)                      # the scheduler exists from here on
    backend.h.setOptionValue("threads", 3)
    with pytest.raises(RuntimeError, match="refused to run"):
        backend.box_bounds(cps, tols)


def test_certified_min_never_exceeds_the_exact_rational_minimum():
    """One equation, one variable, two control points (-a, b) scaled to (w0, w1) by load: Eq. (12)
    is min x = lambda_1 subject to lambda_0 + lambda_1 = 1 and |w0 lambda_0 + w1 lambda_1| <= h, whose
    exact minimum is (-w0 - h) / (w1 - w0) (derived by hand; computed here in Fractions from the
    floats load stored). Its optimal multipliers are y = (-w0, -1, 1) / (w1 - w0) on the (sum,
    variable, slab) rows, given in floats: weak duality with them lands within a few ulps of the
    minimum, on either side, and only the rounding allowance keeps every bound below it."""
    rng = np.random.default_rng(5)
    for _ in range(300):
        a, b = rng.uniform(0.1, 1.0, 2)
        st = LPStructure([(1, 2)])
        assert st.load([np.array([[-a, b]])], [np.array([rng.uniform(1e-4, 1e-2)])])
        w0, w1 = (Fraction(float(v)) for v in st.w_values)
        h = Fraction(float(st.half_widths[0]))
        exact = (-w0 - h) / (w1 - w0)
        eq = st.equations[0]
        y = np.zeros(st.nrow)
        y[eq.sum_row] = float(-w0 / (w1 - w0))
        y[eq.var_rows[0]] = -1.0
        y[eq.slab_row] = float(1 / (w1 - w0))
        bound = st.certified_min(st.objective(0, 1.0), y)
        assert Fraction(bound) <= exact
        assert float(exact) - bound < 1e-12                       # and it is still tight
