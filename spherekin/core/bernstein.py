"""Tensor-product Bernstein polynomials on the unit box (paper Sections 3 and 4).

Convention. A polynomial in n variables on [0, 1]^n with degrees M = (m_1, ..., m_n) is a numpy
array ``c`` of control points whose LAST n axes have lengths m_k + 1; any leading axes are batch
axes (many polynomials, or one polynomial on many boxes, in one numpy call). The entry
c[..., i_1, ..., i_n] multiplies the multivariate Bernstein basis polynomial of Section 3,

    B_{I,M}(x) = prod_k C(m_k, i_k) x_k^{i_k} (1 - x_k)^{m_k - i_k}.

Functions that cannot infer n take ``nvars=None`` meaning ``c.ndim`` (no batch axes); a variable
index ``var`` is 0-based among the n polynomial axes. Subdivision (Section 4) is the affine
reparametrization x_k = a_k + u_k (b_k - a_k) of a sub-box [a, b] of [0, 1]^n back onto the unit
box [Farin, Sec. 15.7]; :func:`bounds` is the convex-hull range enclosure min c_I <= p <= max c_I.

Dtypes. Computation follows the dtype of ``c`` (integer/bool input is promoted to float64). With a
``dtype=object`` array of :class:`fractions.Fraction` (or sympy Rational) every routine is exact:
basis matrices are built from Python ints and Fractions, and parameters (x, s, box) are converted
to exact Fractions, floats by their exact binary value. Slow obviously-correct references sit
beside the fast routines (:func:`evaluate_de_casteljau`, :func:`restrict_reference`).
"""

from __future__ import annotations

from math import comb, prod

import numpy as np

from .arrays import namespace_of

__all__ = [
    "from_power", "to_power", "evaluate", "evaluate_de_casteljau", "subdivide",
    "restriction_matrix", "restrict", "restrict_reference", "bounds", "multiply", "elevate",
    "degrees", "restriction_matrices", "restrict_batch_last",
]


# --------------------------------------------------------------------------- private helpers
def _coeffs(c, name: str = "c") -> np.ndarray:
    """Control points as an array; integer/bool dtypes become float64."""
    c = np.asarray(c)
    if c.dtype.kind in "biu":
        return c.astype(np.float64)
    if c.dtype.kind not in "fcO":
        raise ValueError(f"{name}: expected a numeric or object array, got dtype {c.dtype}")
    return c


def _check_int(name: str, value, lo: int, hi: int | None = None, text: str | None = None) -> int:
    """A Python int with lo <= value (< hi if given)."""
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    if not ok or value < lo or (hi is not None and value >= hi):
        rng = text or (f"{lo} <= {name} < {hi}" if hi is not None else f"an integer {name} >= {lo}")
        raise ValueError(f"{name}: expected {rng}, got {value!r}")
    return int(value)


def _check_nvars(c: np.ndarray, nvars, name: str = "c") -> int:
    """Number n of polynomial axes (default c.ndim); every one must have length >= 1."""
    n = c.ndim if nvars is None else _check_int("nvars", nvars, 1, c.ndim + 1,
                                                 f"1 <= nvars <= {name}.ndim={c.ndim}")
    if n < 1:
        raise ValueError(f"{name}: expected at least one polynomial axis, got shape {c.shape}")
    if 0 in c.shape[c.ndim - n:]:
        raise ValueError(f"{name}: expected polynomial axes of length >= 1, got shape {c.shape}")
    return n


def _mat_dtype(*arrays: np.ndarray):
    """dtype of basis matrices and parameters: object (exact) if any input is object, else float."""
    return object if any(a.dtype == object for a in arrays) else np.float64


def _to_exact(v):
    """Exact number: floats by their exact binary value, ints as Fractions (so / stays exact)."""
    if isinstance(v, (bool, int, float, np.integer, np.floating, np.bool_)):
        from fractions import Fraction  # here: the float path never needs it (each import is paid by every process)

        return Fraction(v.item() if isinstance(v, np.generic) else v)
    return v


def _params(name: str, value, dtype) -> np.ndarray:
    """Validate finite real parameters and convert them to the computation dtype."""
    try:
        arr = np.asarray(value, dtype=object if dtype == object else None)
        if arr.dtype.kind in "USV":
            raise TypeError
        as_float = arr.astype(np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: expected real numbers, got {value!r}") from None
    if not np.all(np.isfinite(as_float)):
        raise ValueError(f"{name}: expected finite values, got {value!r}")
    if dtype != object:
        return as_float
    return np.asarray(np.frompyfunc(_to_exact, 1, 1)(arr), dtype=object)


def _matrix(rows, dtype) -> np.ndarray:
    """Matrix from nested lists of ints/Fractions (exact for object, correctly rounded float)."""
    return np.array(rows, dtype=dtype)


def _apply_along(c: np.ndarray, var: int, matrix: np.ndarray, n: int) -> np.ndarray:
    """new = matrix @ old along polynomial axis ``var`` of n; matrix (k_new, k_old) or
    (*mbatch, k_new, k_old) with mbatch broadcasting against c's batch axes."""
    ct = np.moveaxis(c, var - n, -1)
    mb = matrix.shape[:-2]
    if matrix.ndim == 2:
        out = ct @ matrix.T
    elif len(mb) <= c.ndim - n and mb[0] == c.shape[0] and all(d == 1 for d in mb[1:]):
        # one matrix per leading batch index (the solver's case): one (rest x k) @ (k x k) product
        # per index instead of many 1 x k products, an order of magnitude faster
        flat = np.ascontiguousarray(ct).reshape(c.shape[0], -1, ct.shape[-1])
        out = (flat @ np.swapaxes(matrix.reshape(mb[0], *matrix.shape[-2:]), -1, -2)).reshape(ct.shape)
    else:
        mt = np.swapaxes(matrix, -1, -2)
        mt = mt.reshape(mt.shape[:-2] + (1,) * (n - 1) + mt.shape[-2:])
        out = (ct[..., None, :] @ mt)[..., 0, :]
    return np.moveaxis(out, -1, var - n)


def _scale_axes(c: np.ndarray, vectors, n: int) -> np.ndarray:
    """c_I * prod_k vectors[k][i_k] over the last n axes."""
    for k, v in enumerate(vectors):
        c = c * v.reshape((-1,) + (1,) * (n - 1 - k))
    return c


def _basis_terms(t, m: int) -> list:
    """Bernstein basis b_{i,m}(t), i = 0..m, one array shaped like t each (Python-int exponents;
    any array module)."""
    return [comb(m, i) * t**i * (1 - t) ** (m - i) for i in range(m + 1)]


def _basis(t: np.ndarray, m: int) -> np.ndarray:
    """Bernstein basis b_{i,m}(t), i = 0..m, stacked on a new last axis (Python-int exponents)."""
    return np.stack(_basis_terms(t, m), axis=-1)


def _restriction_entries(xp, m: int, a, b) -> list[list]:
    """The entries R[k][j] of :func:`restriction_matrix` (m, a, b) for float arrays a, b of one
    shape, as a nested list of arrays of that shape (module ``xp``): closed forms for m <= 2, the
    blossom otherwise, summed in the order :func:`restriction_matrix` sums (i ascending from 0), so
    the floats are the same."""
    if m == 0:
        return [[xp.ones_like(a)]]
    a1, b1 = 1.0 - a, 1.0 - b
    if m == 1:
        return [[a1, a], [b1, b]]
    if m == 2:
        return [[a1 * a1, 2.0 * a * a1, a * a], [a1 * b1, a * b1 + a1 * b, a * b], [b1 * b1, 2.0 * b * b1, b * b]]
    rows = []
    for k in range(m + 1):
        ba, bb = _basis_terms(a, m - k), _basis_terms(b, k)
        row = []
        for j in range(m + 1):
            entry = xp.zeros_like(a)
            for i in range(max(0, j - k), min(m - k, j) + 1):
                entry = entry + ba[i] * bb[j - i]
            row.append(entry)
        rows.append(row)
    return rows


def _casteljau_steps(ct: np.ndarray, s):
    """All de Casteljau levels of the last axis at parameter s (level j has m + 1 - j points)."""
    levels = [ct]
    while levels[-1].shape[-1] > 1:
        cur = levels[-1]
        levels.append((1 - s) * cur[..., :-1] + s * cur[..., 1:])
    return levels


def _check_points(c: np.ndarray, x, nvars) -> tuple[np.ndarray, int]:
    nvars = None if nvars is None else _check_nvars(c, nvars)
    x = _params("x", x, _mat_dtype(c))
    if x.ndim == 0:
        raise ValueError("x: expected shape (..., n) with n coordinates in the last axis, got ()")
    n = x.shape[-1]
    if nvars is not None and n != nvars:
        raise ValueError(f"x: expected n={nvars} coordinates in the last axis, got {n}")
    if not 1 <= n <= c.ndim:
        raise ValueError(f"x: expected 1 <= n <= c.ndim={c.ndim} coordinates in the last axis, got {n}")
    _check_nvars(c, n)
    return x, n


def _check_box(c: np.ndarray, box, nvars, batched: bool = True) -> tuple[np.ndarray, int]:
    """Validate a box (n, 2) or (*batch, n, 2) with 0 <= a <= b <= 1; n from box unless nvars."""
    nvars = None if nvars is None else _check_nvars(c, nvars)
    box = _params("box", box, _mat_dtype(c))
    n = nvars if nvars is not None else (box.shape[-2] if box.ndim >= 2 else 0)
    want = f"({n}, 2) or (..., {n}, 2)" if batched else f"({n}, 2)"
    if nvars is None:
        want = ("(n, 2) or (..., n, 2)" if batched else "(n, 2)") + f" with 1 <= n <= c.ndim={c.ndim}"
    if box.ndim < 2 or box.shape[-2:] != (n, 2) or not 1 <= n <= c.ndim or (box.ndim > 2 and not batched):
        raise ValueError(f"box: expected shape {want}, got {box.shape}")
    _check_nvars(c, n)
    try:
        np.broadcast_shapes(c.shape[:-n], box.shape[:-2])
    except ValueError:
        raise ValueError(f"box: expected batch shape broadcastable with c's batch shape "
                         f"{c.shape[:-n]}, got {box.shape[:-2]}") from None
    a, b = box[..., 0], box[..., 1]
    for bad, what in ((a < 0, "a={a} < 0"), (b > 1, "b={b} > 1"), (a > b, "a={a} > b={b}")):
        hits = np.argwhere(np.asarray(bad, dtype=bool))
        if len(hits):
            idx = tuple(int(i) for i in hits[0])
            where = f"for variable {idx[-1]}" + (f" of batch element {idx[:-1]}" if idx[:-1] else "")
            raise ValueError("box: expected 0 <= a <= b <= 1 for every variable, got "
                             + what.format(a=a[idx], b=b[idx]) + " " + where)
    return box, n


# --------------------------------------------------------------------------- public API
def degrees(c, nvars=None) -> tuple[int, ...]:
    """Degrees (m_1, ..., m_n): the last n axis lengths minus one."""
    c = _coeffs(c)
    n = _check_nvars(c, nvars)
    return tuple(k - 1 for k in c.shape[c.ndim - n:])


def from_power(a, nvars=None) -> np.ndarray:
    """Power coefficients a[..., J] (of x^J) -> Bernstein control points, same degrees and shape.

    Per axis c_k = sum_{i<=k} C(k,i)/C(m,i) a_i (exact Fractions for object input).
    """
    a = _coeffs(a, "a")
    n = _check_nvars(a, nvars, "a")
    from fractions import Fraction  # here, not at the top: see _to_exact

    for var, m in enumerate(degrees(a, n)):
        mat = [[Fraction(comb(k, i), comb(m, i)) for i in range(m + 1)] for k in range(m + 1)]
        a = _apply_along(a, var, _matrix(mat, _mat_dtype(a)), n)
    return a


def to_power(c, nvars=None) -> np.ndarray:
    """Inverse of :func:`from_power`: per axis a_i = sum_{k<=i} (-1)^(i-k) C(m,i) C(i,k) c_k."""
    c = _coeffs(c)
    n = _check_nvars(c, nvars)
    for var, m in enumerate(degrees(c, n)):
        mat = [[(-1) ** (i - k) * comb(m, i) * comb(i, k) if k <= i else 0 for k in range(m + 1)]
               for i in range(m + 1)]
        c = _apply_along(c, var, _matrix(mat, _mat_dtype(c)), n)
    return c


def evaluate(c, x, nvars=None) -> np.ndarray:
    """p(x) = sum_I c_I B_{I,M}(x) at points x of shape (*pts, n) (or (n,)) -> (*batch, *pts).

    Contracts the control net with one Bernstein basis vector per variable. n is taken from
    x.shape[-1]; the optional ``nvars`` (an extension) only checks it.
    """
    c = _coeffs(c)
    x, n = _check_points(c, x, nvars)
    pts, batch = x.shape[:-1], c.shape[:c.ndim - n]
    flat = x.reshape(-1, n)
    bases = [_basis(flat[:, k], m) for k, m in enumerate(degrees(c, n))]  # each (P, m_k + 1)
    out = c @ bases[-1].T                                                  # (*batch, ..., P)
    for k in range(n - 2, -1, -1):
        out = (out * bases[k].T).sum(axis=-2)
    return out.reshape(batch + pts)


def evaluate_de_casteljau(c, x, nvars=None) -> np.ndarray:
    """Reference for :func:`evaluate`: per point, repeated linear interpolation along each axis."""
    c = _coeffs(c)
    x, n = _check_points(c, x, nvars)
    pts, batch = x.shape[:-1], c.shape[:c.ndim - n]
    out = np.empty(batch + pts, dtype=np.result_type(c.dtype, x.dtype))
    for p in np.ndindex(*pts):
        val = c
        for k in range(n - 1, -1, -1):
            val = _casteljau_steps(val, x[p + (k,)])[-1][..., 0]
        out[(Ellipsis,) + p] = val
    return out


def subdivide(c, var, s=0.5, nvars=None) -> tuple[np.ndarray, np.ndarray]:
    """de Casteljau split along ``var`` at s: (left, right) = p on [0, s] and on [s, 1], each
    reparametrized to [0, 1] (left_j = level j's first point, right_j = level m-j's last)."""
    c = _coeffs(c)
    n = _check_nvars(c, nvars)
    var = _check_int("var", var, 0, n)
    s_arr = _params("s", s, _mat_dtype(c))
    if s_arr.ndim != 0 or not 0 <= s_arr[()] <= 1:
        raise ValueError(f"s: expected a scalar with 0 <= s <= 1, got {s!r}")
    levels = _casteljau_steps(np.moveaxis(c, var - n, -1), s_arr[()])
    left = np.stack([lev[..., 0] for lev in levels], axis=-1)
    right = np.stack([lev[..., -1] for lev in reversed(levels)], axis=-1)
    return np.moveaxis(left, -1, var - n), np.moveaxis(right, -1, var - n)


def restriction_matrix(m, a, b) -> np.ndarray:
    """R (m+1, m+1) with new = R @ old restricting a degree-m univariate polynomial to [a, b].

    Blossom: R[k, j] = sum_i b_{i,m-k}(a) b_{j-i,k}(b), the z^j coefficient of
    ((1-a) + a z)^(m-k) ((1-b) + b z)^k. a, b broadcast to (*batch,) -> (*batch, m+1, m+1).
    Any finite a, b are accepted (a > b or outside [0, 1] reverses / extrapolates).
    """
    m = _check_int("m", m, 0)
    exact = any(np.asarray(v).dtype == object for v in (a, b))
    a, b = (_params(name, v, object if exact else np.float64) for name, v in (("a", a), ("b", b)))
    try:
        a, b = np.broadcast_arrays(a, b)
    except ValueError:
        raise ValueError(f"b: expected a shape broadcastable with a's {a.shape}, got {b.shape}") from None
    rows = []
    for k in range(m + 1):
        ba, bb = _basis(a, m - k), _basis(b, k)
        row = np.zeros(a.shape + (m + 1,), dtype=a.dtype)
        for i in range(m - k + 1):
            row[..., i:i + k + 1] += ba[..., i:i + 1] * bb
        rows.append(row)
    return np.stack(rows, axis=-2)


def restrict(c, box, nvars=None) -> np.ndarray:
    """Control points of q(u) = p(a + u (b - a)) on the sub-box box[k] = (a_k, b_k) of [0, 1]^n.

    box (n, 2) applies to every batch element; box (*bbatch, n, 2) gives one box per batch
    element (bbatch broadcasts with c's batch). n = box.shape[-2] (``nvars`` optionally pins it).
    Fast path: one restriction matrix per axis; a_k == b_k is allowed (constant along axis k).
    """
    c = _coeffs(c)
    box, n = _check_box(c, box, nvars)
    for var, m in enumerate(degrees(c, n)):
        if m == 0:  # a constant along this axis: restriction is the identity
            continue
        c = _apply_along(c, var, restriction_matrix(m, box[..., var, 0], box[..., var, 1]), n)
    return c


def restriction_matrices(m: int, a, b):
    """Float fast path of :func:`restriction_matrix` for 1-D arrays a, b (B,): shape (B, m+1, m+1),
    in the array module of a and b (:func:`spherekin.core.arrays.namespace_of`).

    Closed forms for m <= 2 (the degrees of the closure equations), the blossom otherwise:
    m = 1: rows (1-a, a), (1-b, b); m = 2: rows ((1-a)^2, 2a(1-a), a^2),
    ((1-a)(1-b), a(1-b) + (1-a)b, ab), ((1-b)^2, 2b(1-b), b^2).
    """
    xp = namespace_of(a, b)
    a = xp.asarray(a, dtype=xp.float64)
    b = xp.asarray(b, dtype=xp.float64)
    return xp.stack([xp.stack(row, axis=-1) for row in _restriction_entries(xp, m, a, b)], axis=-2)


def restrict_batch_last(c, lo, hi, cache: dict | None = None, keys=None):
    """Restrict B polynomials to B boxes, with the BATCH AXIS LAST: the solver's hot path.

    ``c`` (*lead, d_1, ..., d_n, B) float: polynomial b has control points c[..., b] on [0, 1]^n;
    ``lo``, ``hi`` (B, n): box b is prod_k [lo[b, k], hi[b, k]]. Returns the control points on the
    boxes (same shape), as :func:`restrict` does with the batch first. Keeping the batch axis last
    makes every step a contiguous vector operation over boxes (about twice as fast as batched
    matrix products on the batch-first layout; benchmarks/bench_bernstein.py). ``cache`` (a dict,
    optional) shares the restriction matrices' entries between calls on the same boxes, under the
    key (keys[k], degree) for axis k (``keys`` default: the axis indices).
    No validation beyond shapes: callers pass 0 <= lo <= hi <= 1. Any array module
    (:func:`spherekin.core.arrays.namespace_of`): array API standard calls only; each new control
    point is the sum over j of R[i][j] * old_j in that order, so a box's numbers do not depend on
    its batch.
    """
    xp = namespace_of(c, lo, hi)
    c = xp.asarray(c, dtype=xp.float64)
    lo = xp.asarray(lo, dtype=xp.float64)
    hi = xp.asarray(hi, dtype=xp.float64)
    if lo.ndim != 2 or lo.shape != hi.shape or c.ndim < lo.shape[1] + 1 or c.shape[-1] != lo.shape[0]:
        raise ValueError(f"lo, hi: expected shape (B, n) matching c's last axes (..., d_1..d_n, B); "
                         f"got lo {lo.shape}, hi {hi.shape}, c {c.shape}")
    n = lo.shape[1]
    shape = c.shape
    nb = shape[-1]
    dims = shape[-n - 1:-1]
    lead = prod(shape[:-n - 1])
    cache = {} if cache is None else cache
    for k, d in enumerate(dims):
        if d == 1:
            continue
        key = (k if keys is None else keys[k], d)
        if key not in cache:
            cache[key] = _restriction_entries(xp, d - 1, lo[:, k], hi[:, k])
        mat = cache[key]                                          # d x d entries, each (B,)
        v = xp.reshape(c, (lead * prod(dims[:k]), d, prod(dims[k + 1:]), nb))
        rows = []
        for i in range(d):
            o = mat[i][0] * v[:, 0, ...]
            for j in range(1, d):
                o += mat[i][j] * v[:, j, ...]
            rows.append(o)
        c = xp.reshape(xp.stack(rows, axis=1), shape)
    return c


def restrict_reference(c, box, nvars=None) -> np.ndarray:
    """Reference for :func:`restrict` (box (n, 2) only, a_k < b_k): per axis split at b_k, keep
    the left part, then split it at a_k / b_k and keep the right part."""
    c = _coeffs(c)
    box, n = _check_box(c, box, nvars, batched=False)
    for var in range(n):
        a, b = box[var]
        if not a < b:
            raise ValueError(f"box: expected a < b for every variable, got a={a} >= b={b} "
                             f"for variable {var}")
        c = subdivide(c, var, b, n)[0]
        c = subdivide(c, var, a / b, n)[1]
    return c


def bounds(c, nvars=None) -> tuple[np.ndarray, np.ndarray]:
    """(min_I c_I, max_I c_I), each of shape batch: encloses p over [0, 1]^n (convex hull)."""
    c = _coeffs(c)
    n = _check_nvars(c, nvars)
    axes = tuple(range(c.ndim - n, c.ndim))
    return np.asarray(c.min(axis=axes)), np.asarray(c.max(axis=axes))


def multiply(c1, c2, nvars=None) -> np.ndarray:
    """Control points of p1 * p2 (degrees add); batch axes broadcast. n defaults to c1.ndim.

    c_K = sum_{I+J=K} prod_k [C(m_k,i_k) C(p_k,j_k) / C(m_k+p_k,k_k)] c1_I c2_J, computed as a
    convolution of the binomially scaled nets.
    """
    c1, c2 = _coeffs(c1, "c1"), _coeffs(c2, "c2")
    n = _check_nvars(c1, nvars, "c1")
    if c2.ndim < n:
        raise ValueError(f"c2: expected at least n={n} axes, got shape {c2.shape}")
    _check_nvars(c2, n, "c2")
    b1, b2 = c1.shape[:c1.ndim - n], c2.shape[:c2.ndim - n]
    try:
        batch = np.broadcast_shapes(b1, b2)
    except ValueError:
        raise ValueError(f"c2: expected batch shape broadcastable with c1's {b1}, got {b2}") from None
    dt = _mat_dtype(c1, c2)
    m, p = degrees(c1, n), degrees(c2, n)
    d1 = _scale_axes(c1, [_matrix([comb(mk, i) for i in range(mk + 1)], dt) for mk in m], n)
    d2 = _scale_axes(c2, [_matrix([comb(pk, j) for j in range(pk + 1)], dt) for pk in p], n)
    out = np.zeros(batch + tuple(mk + pk + 1 for mk, pk in zip(m, p)), dtype=np.result_type(d1, d2))
    for idx in np.ndindex(*(mk + 1 for mk in m)):
        window = tuple(slice(i, i + pk + 1) for i, pk in zip(idx, p))
        out[(Ellipsis,) + window] += d1[(Ellipsis,) + idx + (None,) * n] * d2
    from fractions import Fraction  # here, not at the top: see _to_exact

    inv = [_matrix([Fraction(1, comb(mk + pk, k)) for k in range(mk + pk + 1)], dt)
           for mk, pk in zip(m, p)]
    return _scale_axes(out, inv, n)


def elevate(c, var, r=1, nvars=None) -> np.ndarray:
    """Raise the degree of ``var`` from m to m + r without changing p.

    One step is c'_i = (i/(m+1)) c_{i-1} + (1 - i/(m+1)) c_i; r steps are applied at once with
    the composed matrix E[i, j] = C(m,j) C(r,i-j) / C(m+r,i).
    """
    c = _coeffs(c)
    n = _check_nvars(c, nvars)
    var = _check_int("var", var, 0, n)
    r = _check_int("r", r, 0)
    m = degrees(c, n)[var]
    from fractions import Fraction  # here, not at the top: see _to_exact

    mat = [[Fraction(comb(m, j) * comb(r, i - j), comb(m + r, i)) if 0 <= i - j <= r else 0
            for j in range(m + 1)] for i in range(m + r + 1)]
    return _apply_along(c, var, _matrix(mat, _mat_dtype(c)), n)
