"""Every root of three quadrics in P^3, proven without subdivision: a complete count (issue 44).

Three homogeneous quadrics q^T M_i q = 0 (i = 1, 2, 3; M_i real symmetric 4 x 4, q in C^4) meet in
at most 2 * 2 * 2 = 8 isolated points of P^3: Bezout's theorem in its refined form (Fulton,
*Intersection Theory*, 1984, Example 8.4.6: the irreducible components Z of the intersection of
hypersurfaces of degrees d_1, ..., d_r satisfy sum deg Z <= d_1 ... d_r, whatever their dimensions).
Each isolated point is a component of degree >= 1, so **8 pairwise distinct isolated roots are every
root, and no positive-dimensional component exists**. This module proves, for a batch of systems at
once:

1. *each root* on the affine chart q_k = 1 of its largest component (3 complex unknowns) by the
   Krawczyk test (:func:`spherekin.core.krawczyk.krawczyk_operator`) in outward-rounded interval
   arithmetic (:mod:`spherekin.core.intervals`), on the equivalent real system of 6 equations in
   6 unknowns (real and imaginary parts; F is holomorphic, so its real Jacobian is
   [[Re J, -Im J], [Im J, Re J]]). K(X) inside X proves exactly one root in the box X (for every
   M_i in the given interval matrices) and a regular Jacobian there: an isolated root of
   multiplicity one;
2. *which roots are real*: a box centred on a real point, its imaginary parts [-r, r], is mapped to
   itself by complex conjugation, and so is the root set of real quadrics; the one root in it is
   its own conjugate, hence real. A root whose enclosure K(X) has an imaginary part excluding 0 is
   not real;
3. *that the roots are distinct* as points of P^3: roots p (chart k, p_k = 1) and r are one point
   iff r = r_k p, so they are distinct when some component of r_k p - r, evaluated in interval
   arithmetic over both enclosures, excludes 0.

When all three hold for :data:`BEZOUT_BOUND` roots, the real ones are every real root (the count is
complete, :attr:`QuadricRoots.complete`). Anything less (a candidate missing, a test that does not
contract, a root neither proven real nor proven non-real, two enclosures that cannot be told apart)
leaves the count unproven: the caller must answer otherwise (the box search).

How the candidates are found is the caller's business (any method: the proof does not depend on it).
:func:`polish` refines them by Newton's method on their charts. Pure functions on numpy arrays;
shapes: K systems, N candidates each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import intervals as iv
from .krawczyk import INTERVALS, krawczyk_operator

__all__ = ["BEZOUT_BOUND", "FREE", "NEWTON_STEPS", "REAL_SNAP", "RADII", "CONDITION_MAX", "GAMMA", "ARITHMETICS",
           "QuadricRoots",
           "charts_of", "on_chart", "polish", "certify_roots", "count_complete"]

#: Most isolated roots of three quadrics in P^3 (Bezout: 2 * 2 * 2; the module doc).
BEZOUT_BOUND = 8
#: FREE[k]: the free components of chart k (q_k = 1).
FREE = np.array([[j for j in range(4) if j != k] for k in range(4)])
#: Newton steps on a chart from a candidate. Reason: candidates from an eigenproblem are accurate to
#: ~1e-8 or better where the roots are well conditioned (measured: residual median 2e-15, largest
#: 1e-12 over 2,048 candidates of general_3rrr); Newton doubles the digits each step, so 3 steps
#: reach rounding from ~1e-4, and a candidate not there by then is not worth proving (the input
#: then falls back).
NEWTON_STEPS = 3
#: A candidate whose imaginary parts (on its chart, largest component 1) are all below this is moved
#: onto the real space (its imaginary parts set to 0) and proven real or not at all. Reason: a real
#: root of a generic system comes out of an eigenproblem with imaginary parts ~1e-10; a non-real
#: one has them ~1e-2 or more; a complex pair this close to the real space is within ~1e-12 of a
#: double root (a fold), where no box of the radii below can prove it either way. A wrong move
#: costs a fallback, never a wrong count: the proof decides.
REAL_SNAP = 1e-7
#: Box radii tried (the chart's units; each component within +- r in real and imaginary part),
#: smallest first, each only for the roots the ones before did not prove. Reason: the width of
#: F(y) (the interval matrices' width, ~1e-12 when they hold a model tolerance, times |q|^2 <= 4)
#: times |J^-1| bounds K(X) from below, so a root with |J^-1| up to ~1e2 is proven at 1e-9;
#: 1e-6 proves |J^-1| up to ~1e5 and still lies far inside the distance between roots that a
#: float64 eigenproblem resolves.
RADII = (1e-9, 1e-7, 1e-6)
#: A chart Jacobian whose condition number (infinity norm, of its real 6 x 6 form) exceeds this is
#: not tested. Reason: K(X) is then wider than the largest radius (|C| |F(y)| >~ 1e12 * 1e-16 * ...), and
#: the root is next to a double root: the count falls back.
CONDITION_MAX = 1e10


@dataclass(frozen=True)
class QuadricRoots:
    """What :func:`certify_roots` proved of N candidate roots of each of K systems.

    ``roots`` (K, N, 4) complex: the polished roots on their charts (``roots[k, n, chart[k, n]] == 1``);
    ``chart`` (K, N) int; ``certified`` (K, N): a box holds exactly this one root (``radius``, its
    box radius, NaN where none proved it); ``real`` (K, N): proven real; ``nonreal`` (K, N): proven
    not real; ``re_lo``, ``re_hi``, ``im_lo``, ``im_hi`` (K, N, 4): the enclosure of each proven root
    (K(X), chart component exact); ``distinct`` (K,): every two proven roots of the system are
    proven distinct points of P^3; ``complete`` (K,): :data:`BEZOUT_BOUND` roots proven, each real
    or not, all distinct: the real ones are every real root (module doc).
    """

    roots: np.ndarray
    chart: np.ndarray
    certified: np.ndarray
    radius: np.ndarray
    real: np.ndarray
    nonreal: np.ndarray
    re_lo: np.ndarray
    re_hi: np.ndarray
    im_lo: np.ndarray
    im_hi: np.ndarray
    distinct: np.ndarray
    complete: np.ndarray

    @property
    def n_real(self) -> np.ndarray:
        """(K,) the number of proven real roots of each system."""
        return self.real.sum(axis=1)


def charts_of(q) -> np.ndarray:
    """The chart of each point (..., 4): the index of its component of largest modulus."""
    return np.argmax(np.abs(q), axis=-1)


def on_chart(q, chart) -> np.ndarray:
    """The points q (..., 4) scaled so that component ``chart`` (...) is 1 (complex; exactly 1 + 0i: a
    complex division x / x need not round to 1, and the chart, the realness argument and the
    distinctness test all take it as exact)."""
    q = np.asarray(q, dtype=complex)
    index = np.asarray(chart)[..., None]
    out = q / np.take_along_axis(q, index, axis=-1)
    np.put_along_axis(out, index, 1.0 + 0.0j, axis=-1)
    return out


def _free(x, chart):
    """The free components (..., 3) of x (..., 4) on charts ``chart`` (...)."""
    return np.take_along_axis(x, FREE[chart], axis=-1)


def polish(m, q, chart, steps: int = NEWTON_STEPS) -> np.ndarray:
    """Newton's method on the charts: q (B, 4) complex with q[chart] = 1, m (B, 3, 4, 4) real;
    ``steps`` steps on F_i(q) = q^T M_i q, J_ij = 2 (M_i q)_(free j). A step whose Jacobian is
    singular leaves its point where it is (NaN stays NaN). Returns the new points (B, 4)."""
    q = np.array(q, dtype=complex)
    free = FREE[chart]                                                       # (B, 3)
    for _ in range(steps):
        mq = np.einsum("bkij,bj->bki", m, q)                                 # (B, 3, 4)
        f = np.einsum("bki,bi->bk", mq, q)                                   # (B, 3)
        jac = 2.0 * np.take_along_axis(mq, free[:, None, :], axis=2)         # (B, 3, 3)
        np.put_along_axis(q, free, _free(q, chart) - _solve(jac, f), axis=1)
    return q


def _solve(jac, f):
    """x with jac x = f for a stack (B, n, n), (B, n); 0 where jac is singular or not finite."""
    ok = np.isfinite(jac).all(axis=(1, 2)) & np.isfinite(f).all(axis=1)
    try:
        if ok.all():
            return np.linalg.solve(jac, f[..., None])[..., 0]
    except np.linalg.LinAlgError:
        pass
    ok &= np.abs(np.linalg.det(np.where(ok[:, None, None], jac, np.eye(jac.shape[-1])))) > 0
    x = np.zeros_like(f)
    if ok.any():
        x[ok] = np.linalg.solve(jac[ok], f[ok][..., None])[..., 0]
    return x


def _inverse(jc):
    """(C, ok): the inverses of a stack (B, n, n) where they are finite and the condition number
    (infinity norm) is below :data:`CONDITION_MAX`; C = 0 elsewhere."""
    ok = np.isfinite(jc).all(axis=(1, 2))
    c = np.zeros_like(jc)
    try:
        if ok.all():
            c = np.linalg.inv(jc)
    except np.linalg.LinAlgError:
        ok &= np.abs(np.linalg.det(np.where(ok[:, None, None], jc, np.eye(jc.shape[-1])))) > 0
        if ok.any():
            c[ok] = np.linalg.inv(jc[ok])
    else:
        if not ok.all() and ok.any():
            c[ok] = np.linalg.inv(jc[ok])
    norm = lambda x: np.abs(x).sum(axis=2).max(axis=1)                       # noqa: E731
    with np.errstate(invalid="ignore", over="ignore"):
        ok &= np.isfinite(c).all(axis=(1, 2)) & (norm(c) * norm(jc) < CONDITION_MAX)
    return np.where(ok[:, None, None], c, 0.0), ok


def _real_jacobian(re, im):
    """[[Re J, -Im J], [Im J, Re J]] (..., 6, 6) from the parts (..., 3, 3) (floats or intervals)."""
    top = np.concatenate([re, -im if re.ndim == 3 else iv.neg(im)], axis=-1)
    bottom = np.concatenate([im, re], axis=-1)
    return np.concatenate([top, bottom], axis=-2)


# ---------------------------------------------------------------------- rounding bounds of the fast test

#: The unit roundoff of float64 (round to nearest).
_U = 2.0 ** -53
#: Most roundings in any chain of float operations the fast test bounds at once (a 16-term quadratic
#: form is 2 products and 16 additions; a 6-term dot product 6 and 6).
_OPS = 64
#: gamma_n = n u / (1 - n u) for n = _OPS, rounded up: |fl(E) - E| <= gamma_n * sum |terms| for any sum
#: of products E evaluated with at most n roundings, in any order, with or without FMA (Higham,
#: *Accuracy and Stability of Numerical Algorithms*, 2002, Lemma 3.1 and Sect. 3.1), barring underflow.
GAMMA = float(np.nextafter(_OPS * _U / (1.0 - _OPS * _U), np.inf))
#: Upward factor of a computed non-negative expression: its exact value is at most the float times this
#: (plus _TINY): at most _OPS roundings each lose a factor (1 - u), and the product by this rounds too.
_UP_FACTOR = 1.0 + 4.0 * (_OPS + 2) * _U
#: Absolute term for underflow: each rounding of a product below the normal range errs by at most
#: 2^-1075, so 2^-960 covers more roundings than any of these expressions has (and is far below any
#: quantity the test compares).
_TINY = 2.0 ** -960


def _up(x):
    """An upper bound of the exact value of a non-negative expression whose float value is ``x``
    (at most _OPS roundings)."""
    return x * _UP_FACTOR + _TINY


def _mid_rad(m_iv):
    """(mid, rad) floats with [lo, hi] inside [mid - rad, mid + rad] (exactly) for intervals (2, ...)."""
    mid = 0.5 * m_iv[0] + 0.5 * m_iv[1]
    rad = np.maximum(np.nextafter(mid - m_iv[0], np.inf), np.nextafter(m_iv[1] - mid, np.inf))
    return mid, _up(np.maximum(rad, 0.0))


def _krawczyk_fast(m_mid, m_rad, a, b, chart, radius):
    """The Krawczyk test of :func:`_krawczyk_intervals` in midpoint-radius form, rigorous by a priori
    rounding bounds instead of outward rounding (Rump, "Fast and parallel interval arithmetic", BIT 39,
    1999): plain float products and sums, each followed by a bound of its error (:data:`GAMMA`,
    :func:`_up`). For the box X = y +- r (r the ``radius`` (B,), X - y centred at 0):

        K(X) - y  in  -C F(y) + (I - C J(X)) [-r, r]  within  |C Fm| + |C| Fr + (|I - C Jc| + |C| Jr) r 1

    with F(y) in Fm +- Fr and J(X) in Jc +- Jr (every matrix M in ``m_mid`` +- ``m_rad``, every point
    of X). Returns (inside (B,): K(X) in the interior of X, the half-widths (B, 6) of K(X) about y)."""
    nb = len(a)
    free = FREE[chart]
    rho = np.zeros((nb, 4))
    np.put_along_axis(rho, free, radius[:, None], axis=1)                   # X - y: +- r on the free parts
    am, bm = np.abs(a), np.abs(b)
    mabs = np.abs(m_mid)
    # F(y) = (a.Ma - b.Mb, 2 a.Mb): centre with the midpoint matrices, radius their rounding and m_rad
    ma, mb = np.einsum("bkij,bj->bki", m_mid, a), np.einsum("bkij,bj->bki", m_mid, b)
    f_re = np.einsum("bki,bi->bk", ma, a) - np.einsum("bki,bi->bk", mb, b)
    f_im = 2.0 * np.einsum("bki,bi->bk", mb, a)
    mabs_a, mabs_b = np.einsum("bkij,bj->bki", mabs, am), np.einsum("bkij,bj->bki", mabs, bm)
    mrad_a, mrad_b = np.einsum("bkij,bj->bki", m_rad, am), np.einsum("bkij,bj->bki", m_rad, bm)
    r_re = _up(GAMMA * (np.einsum("bki,bi->bk", mabs_a, am) + np.einsum("bki,bi->bk", mabs_b, bm))
               + np.einsum("bki,bi->bk", mrad_a, am) + np.einsum("bki,bi->bk", mrad_b, bm))
    r_im = _up(2.0 * (GAMMA * np.einsum("bki,bi->bk", mabs_b, am) + np.einsum("bki,bi->bk", mrad_b, am)))
    f_m = np.concatenate([f_re, f_im], axis=1)                               # (B, 6)
    f_r = np.concatenate([r_re, r_im], axis=1)
    # J(X) = 2 M q over X (free columns): centre 2 Mm y, radius |Mm| rho + m_rad (|y| + rho) + rounding
    pick = free[:, None, :]
    jc_re, jc_im = 2.0 * np.take_along_axis(ma, pick, axis=2), 2.0 * np.take_along_axis(mb, pick, axis=2)
    mabs_rho = np.einsum("bkij,bj->bki", mabs, rho)
    spread = mabs_rho + np.einsum("bkij,bj->bki", m_rad, rho)
    jr_re = _up(2.0 * np.take_along_axis(spread + mrad_a + GAMMA * mabs_a, pick, axis=2))
    jr_im = _up(2.0 * np.take_along_axis(spread + mrad_b + GAMMA * mabs_b, pick, axis=2))
    jc = _real_jacobian(jc_re, jc_im)                                        # (B, 6, 6)
    jr = np.concatenate([np.concatenate([jr_re, jr_im], axis=2), np.concatenate([jr_im, jr_re], axis=2)], axis=1)
    # C: the inverse of the centre (any matrix keeps the test rigorous)
    c, ok = _inverse(jc)
    ok &= np.isfinite(jr).all(axis=(1, 2)) & np.isfinite(f_r).all(axis=1)
    cabs = np.abs(c)
    e = np.eye(6) - c @ jc                                                   # I - C Jc, rounded
    eabs = np.abs(e)
    mag = _up(eabs + GAMMA * (eabs + cabs @ np.abs(jc)) + cabs @ jr)          # >= |I - C J| over X
    cf = np.einsum("bij,bj->bi", c, f_m)
    half = _up(np.abs(cf) + GAMMA * np.einsum("bij,bj->bi", cabs, np.abs(f_m)) + np.einsum("bij,bj->bi", cabs, f_r)
               + radius[:, None] * mag.sum(axis=2))
    inside = ok & np.all(half < radius[:, None], axis=1)
    return inside, half


def _krawczyk_intervals(m_iv, a, b, chart, radius):
    """The reference of :func:`_krawczyk_fast` (slow, obviously correct): every operation in
    outward-rounded intervals (:mod:`spherekin.core.intervals`). One Krawczyk test per point
    y = a + i b (B, 4; chart component 1 + 0i) of the quadrics whose interval matrices are ``m_iv``
    (2, B, 3, 4, 4), on the box X = y +- radius (B,) in every free real and imaginary part. Returns
    (inside (B,) bool: K(X) in the interior of X, the half-widths (B, 6) of the hull of K(X) about y:
    real parts then imaginary)."""
    nb = len(a)
    free = FREE[chart]
    r = radius[:, None]
    m_mid = 0.5 * m_iv[0] + 0.5 * m_iv[1]
    # F(y) over every matrix of m_iv: Re = a.Ma - b.Mb, Im = 2 a.Mb (M symmetric)
    ma = iv.isum(iv.scale(a[:, None, None, :], m_iv), -1)                    # (2, B, 3, 4)
    mb = iv.isum(iv.scale(b[:, None, None, :], m_iv), -1)
    re_f = iv.sub(iv.isum(iv.scale(a[:, None, :], ma), -1), iv.isum(iv.scale(b[:, None, :], mb), -1))
    im_f = iv.scale(2.0, iv.isum(iv.scale(a[:, None, :], mb), -1))
    f6 = np.concatenate([re_f, im_f], axis=-1)                               # (2, B, 6)
    # the box X, its components as floats (the chart component exact: 1 + 0i)
    af, bf = _free(a, chart), _free(b, chart)
    x_lo = np.concatenate([af - r, bf - r], axis=1)
    x_hi = np.concatenate([af + r, bf + r], axis=1)
    box_a = iv.point(a)[:, :, None, :].copy()                                # (2, B, 1, 4)
    box_b = iv.point(b)[:, :, None, :].copy()
    rows = np.arange(nb)[:, None]
    box_a[:, rows, 0, free] = np.stack([x_lo[:, :3], x_hi[:, :3]])
    box_b[:, rows, 0, free] = np.stack([x_lo[:, 3:], x_hi[:, 3:]])
    # J(X) = 2 M q over X, free columns only
    mx_a = iv.isum(iv.mul(m_iv, box_a[:, :, :, None, :]), -1)               # (2, B, 3, 4)
    mx_b = iv.isum(iv.mul(m_iv, box_b[:, :, :, None, :]), -1)
    pick = np.broadcast_to(free[None, :, None, :], (2, nb, 3, 3))
    j6 = _real_jacobian(iv.scale(2.0, np.take_along_axis(mx_a, pick, axis=3)),
                        iv.scale(2.0, np.take_along_axis(mx_b, pick, axis=3)))   # (2, B, 6, 6)
    # C: the inverse of the midpoint Jacobian (floats; any matrix keeps the test rigorous)
    q = a + 1j * b
    jc = 2.0 * np.take_along_axis(np.einsum("bkij,bj->bki", m_mid, q), free[:, None, :], axis=2)
    j6c = _real_jacobian(jc.real, jc.imag)
    c, ok = _inverse(j6c)
    y6 = np.concatenate([af, bf], axis=1)
    dx = iv.sub(iv.from_bounds(x_lo, x_hi), iv.point(y6))
    k = krawczyk_operator(INTERVALS, y6, f6, c, j6, dx)
    inside = ok & np.all((k[0] > x_lo) & (k[1] < x_hi), axis=1)
    half = np.maximum(np.nextafter(y6 - k[0], np.inf), np.nextafter(k[1] - y6, np.inf))
    return inside, half


#: The two arithmetics of the Krawczyk test: "fast" (midpoint-radius, a priori rounding bounds: the
#: default) and "intervals" (outward rounding at every operation: the slow reference). Both rigorous.
ARITHMETICS = ("fast", "intervals")


def _components(half, a, b, chart):
    """The enclosure (re, im: each (2, B, 4) intervals) of a proven root y = a + i b (B, 4) from the
    half-widths (B, 6) of K(X) about it (chart component exact)."""
    nb = len(a)
    free = FREE[chart]
    rows = np.arange(nb)[:, None]
    re, im = iv.point(a), iv.point(b)
    for part, y, h in ((re, a, half[:, :3]), (im, b, half[:, 3:])):
        yf = y[rows, free]
        part[:, rows, free] = np.stack([np.nextafter(yf - h, -np.inf), np.nextafter(yf + h, np.inf)])
    return re, im


def _excludes_zero(x):
    """Whether the interval x (2, ...) lies on one side of 0."""
    return (x[0] > 0.0) | (x[1] < 0.0)


def _distinct_intervals(re, im, chart, valid):
    """(K,) whether every two ``valid`` roots (K, N) of each system are proven distinct points of
    P^3 (module doc, 3): enclosures re, im (2, K, N, 4), charts (K, N). The reference of
    :func:`_distinct_fast`: outward-rounded intervals."""
    kk, n = chart.shape
    if n < 2:
        return np.ones(kk, dtype=bool)
    i, j = np.triu_indices(n, 1)
    ci = chart[:, i]                                                          # (K, P)
    # lambda = r_k (the component of root j at root i's chart), then lambda p - r, componentwise
    lam_re = np.take_along_axis(re[:, :, j, :], ci[None, :, :, None], axis=3)[..., 0]    # (2, K, P)
    lam_im = np.take_along_axis(im[:, :, j, :], ci[None, :, :, None], axis=3)[..., 0]
    p_re, p_im = re[:, :, i, :], im[:, :, i, :]                              # (2, K, P, 4)
    lr, li = lam_re[..., None], lam_im[..., None]
    d_re = iv.sub(iv.sub(iv.mul(lr, p_re), iv.mul(li, p_im)), re[:, :, j, :])
    d_im = iv.sub(iv.add(iv.mul(lr, p_im), iv.mul(li, p_re)), im[:, :, j, :])
    apart = np.any(_excludes_zero(d_re) | _excludes_zero(d_im), axis=-1)    # (K, P)
    both = valid[:, i] & valid[:, j]
    return np.all(apart | ~both, axis=1)


def _distinct_fast(y, h_re, h_im, chart, valid):
    """:func:`_distinct_intervals` in midpoint-radius form (a priori rounding bounds, as
    :func:`_krawczyk_fast`): roots y (K, N, 4) complex with half-widths h_re, h_im (K, N, 4) of their
    enclosures (0 on the chart component). Roots i, j are apart when some component of
    lambda p - r (lambda = r's component at p's chart) is farther from 0 than its bound."""
    kk, n = chart.shape
    if n < 2:
        return np.ones(kk, dtype=bool)
    i, j = np.triu_indices(n, 1)
    ci = chart[:, i][..., None]                                               # (K, P, 1)
    p_re, p_im, r_re, r_im = y.real[:, i], y.imag[:, i], y.real[:, j], y.imag[:, j]   # (K, P, 4)
    hp_re, hp_im, hr_re, hr_im = h_re[:, i], h_im[:, i], h_re[:, j], h_im[:, j]
    l_re, l_im = np.take_along_axis(r_re, ci, axis=2), np.take_along_axis(r_im, ci, axis=2)   # (K, P, 1)
    hl_re, hl_im = np.take_along_axis(hr_re, ci, axis=2), np.take_along_axis(hr_im, ci, axis=2)
    d_re = l_re * p_re - l_im * p_im - r_re
    d_im = l_re * p_im + l_im * p_re - r_im
    al_re, al_im, ap_re, ap_im = np.abs(l_re), np.abs(l_im), np.abs(p_re), np.abs(p_im)
    # the products' spread over the enclosures: |x y - xc yc| <= |xc| hy + hx (|yc| + hy)
    spread_rr = al_re * hp_re + hl_re * (ap_re + hp_re)
    spread_ii = al_im * hp_im + hl_im * (ap_im + hp_im)
    spread_ri = al_re * hp_im + hl_re * (ap_im + hp_im)
    spread_ir = al_im * hp_re + hl_im * (ap_re + hp_re)
    b_re = _up(GAMMA * (al_re * ap_re + al_im * ap_im + np.abs(r_re)) + spread_rr + spread_ii + hr_re)
    b_im = _up(GAMMA * (al_re * ap_im + al_im * ap_re + np.abs(r_im)) + spread_ri + spread_ir + hr_im)
    apart = np.any((np.abs(d_re) > b_re) | (np.abs(d_im) > b_im), axis=-1)  # (K, P)
    both = valid[:, i] & valid[:, j]
    return np.all(apart | ~both, axis=1)


def certify_roots(m_iv, candidates, arithmetic: str = "fast", radii=RADII) -> QuadricRoots:
    """Prove the candidate roots ``candidates`` (K, N, 4) complex (NaN: none) of K systems of three
    quadrics, given by interval matrices ``m_iv`` (2, K, 3, 4, 4) (symmetric; the proof holds for
    every real matrix in them): each polished (:func:`polish`), proven by the Krawczyk test on its
    chart, real or not, and all proven distinct (module doc). ``arithmetic``: one of
    :data:`ARITHMETICS`; ``radii``: the box radii tried, smallest first (default :data:`RADII`, for
    matrices as wide as a model tolerance; wider matrices, such as those of a mechanism under
    geometric tolerances, move the roots further and need wider boxes). Returns a :class:`QuadricRoots`."""
    if arithmetic not in ARITHMETICS:
        raise ValueError(f"arithmetic: expected one of {list(ARITHMETICS)}, got {arithmetic!r}")
    m_iv = np.asarray(m_iv, dtype=float)
    cand = np.asarray(candidates, dtype=complex)
    kk, n = cand.shape[:2]
    flat = cand.reshape(kk * n, 4)
    finite = np.isfinite(flat).all(axis=1) & (np.abs(flat).max(axis=1) > 0)
    chart = np.where(finite, charts_of(np.where(finite[:, None], flat, 1.0)), 0)
    q = on_chart(np.where(finite[:, None], flat, 1.0), chart)
    m_mid, m_rad = _mid_rad(m_iv)
    m_mid, m_rad = np.repeat(m_mid, n, axis=0), np.repeat(m_rad, n, axis=0)   # (B, 3, 4, 4)
    # a candidate near the real space is polished there (and proven real, or not at all)
    snap = np.abs(q.imag).max(axis=1) <= REAL_SNAP
    q = np.where(snap[:, None], q.real + 0j, q)
    q = polish(m_mid, q, chart)
    # a polished root may now have a larger component elsewhere: move it to that chart
    finite &= np.isfinite(q).all(axis=1)
    q = np.where(finite[:, None], q, 1.0)
    chart = charts_of(q)
    q = on_chart(q, chart)
    q = np.where(snap[:, None], q.real + 0j, q)
    a, b = q.real.copy(), q.imag.copy()
    nb = kk * n
    certified = np.zeros(nb, dtype=bool)
    radius = np.full(nb, np.nan)
    re, im = iv.point(a), iv.point(b)
    for r in radii:
        todo = np.flatnonzero(finite & ~certified)
        if not len(todo):
            break
        rr = np.full(len(todo), r)
        if arithmetic == "fast":
            inside, half = _krawczyk_fast(m_mid[todo], m_rad[todo], a[todo], b[todo], chart[todo], rr)
        else:
            m_b = np.repeat(m_iv, n, axis=1)[:, todo]
            inside, half = _krawczyk_intervals(m_b, a[todo], b[todo], chart[todo], rr)
        got = todo[inside]
        certified[got] = True
        radius[got] = r
        re[:, got], im[:, got] = _components(half[inside], a[got], b[got], chart[got])
    real = certified & snap                       # a box symmetric about the real space (module doc, 2)
    nonreal = certified & ~snap & np.any(_excludes_zero(im), axis=-1)
    shape = (kk, n)
    certified, real, nonreal = certified.reshape(shape), real.reshape(shape), nonreal.reshape(shape)
    re4, im4 = re.reshape((2, kk, n, 4)), im.reshape((2, kk, n, 4))
    chart2 = chart.reshape(shape)
    if arithmetic == "fast":
        y = q.reshape(kk, n, 4)
        h_re = np.nextafter(np.maximum(re4[1] - y.real, y.real - re4[0]), np.inf)   # the enclosures' half-widths
        h_im = np.nextafter(np.maximum(im4[1] - y.imag, y.imag - im4[0]), np.inf)
        distinct = _distinct_fast(y, h_re, h_im, chart2, certified)
    else:
        distinct = _distinct_intervals(re4, im4, chart2, certified)
    return QuadricRoots(roots=q.reshape(kk, n, 4), chart=chart2, certified=certified, radius=radius.reshape(shape),
                        real=real, nonreal=nonreal, re_lo=re4[0], re_hi=re4[1], im_lo=im4[0], im_hi=im4[1],
                        distinct=distinct, complete=count_complete(certified, real, nonreal, distinct))


def count_complete(certified, real, nonreal, distinct) -> np.ndarray:
    """(K,) the module doc's rule: :data:`BEZOUT_BOUND` roots proven (``certified`` (K, N)), each
    proven real or not real, all proven distinct (``distinct`` (K,))."""
    decided = certified & (real | nonreal)
    return (decided.sum(axis=1) >= BEZOUT_BOUND) & np.all(decided | ~certified, axis=1) & distinct
