"""Formulations: which polynomial equations of each loop the solver works on (Section 2.2 and beyond).

A formulation turns the loop polynomials of a parameterization (:class:`LoopPolynomials`, built by
:mod:`spherekin.search.parameterizations`) into *equation blocks*: for each loop, a stack of Bernstein
tensors over the global unit box [0, 1]^N of all variables. A variable that a loop does not contain
gets a tensor axis of length 1 (degree 0), so every block has N polynomial axes and the Bernstein
core can restrict all of them to a batch of boxes in one call.

* ``paper``: the scalar closure equation of Eq. (10), f = f11bar + f22bar - 2 q_n, one per loop.
  f <= 0 everywhere and f = 0 exactly at closure, so every root is a double root (a maximum): the
  hull-based pruning converges only linearly there (measured in the benchmarks).
* ``transversal``: per loop the three strictly lower-triangular entries q f21, q f31, q f32 of
  q F_n (q = q_n for tan-half, 1 for sin-cos), which vanish at F = I with a Jacobian of full rank
  on so(3) (F = I + [w]x gives (f21, f31, f32) = (w_z, -w_y, w_x)), so roots are simple where the
  mechanism is regular; plus the scalar equation, which removes the spurious upper-triangular
  rotations diag(1, -1, -1), diag(-1, 1, -1), diag(-1, -1, 1). This departs from the paper
  (Section 5 asks for better conditioned formulations).
* ``halves``: per loop, the same three transversal entries (the square system of simple roots)
  plus the nine entries of the loop closed "in the middle": with P the product of the first
  factors of the loop (up to its floor(k/2)-th unknown) and S the product of the rest, F = P S = I
  exactly when P = S^T, i.e. when all nine entries of q_b (q_a P) - q_a (q_b S)^T vanish (no
  spurious roots, so Eq. (10) is not needed). Each half depends on only half of the loop's
  unknowns, so its Bernstein enclosure over a large box is far tighter than that of the full
  product: on the Gosselin platform this cuts the boxes processed 3x (benchmarks/README.md). An
  addition to the paper.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np

from ..closure import TRANSVERSAL_ENTRIES
from .registry import Registry

__all__ = ["EquationBlock", "LoopPolynomials", "Bilinear", "ChartBilinear", "Formulation", "FORMULATIONS", "Paper", "Transversal", "Halves",
           "TRANSVERSAL_ENTRIES", "formulate_polynomials", "embed_axes"]


@dataclass(slots=True, eq=False)
class EquationBlock:
    """Equations of one loop (or one side condition), each = 0 at a solution, on the unit box.

    ``coeffs`` has shape (E, d_1, ..., d_N) over the N variables of the parameterization, d_k = 1
    where the block does not depend on variable k; ``labels`` names the E equations; ``scale`` (E,)
    bounds the size of the terms behind the control points on the whole unit box
    (:func:`spherekin.closure.matrix_magnitude`; at least max |control point|), the magnitude that
    the rounding errors of the control points and of their later restrictions are relative to; ``square`` lists the equations that belong to the square system
    of simple roots used by the Krawczyk test (:mod:`spherekin.search.isolation`); ``loop_index`` is -1
    for a side condition such as the sin-cos circle equation. ``bilinear``, when present, gives
    the same equations as sums of outer products of the loop's two halves (:class:`Bilinear`),
    which the solver restricts far more cheaply than ``coeffs``; ``scale`` then also bounds the
    terms of those sums, so that it bounds the rounding of either evaluation. ``prune=False``
    marks a block that only serves the Krawczyk test (the pruners do not see it).
    """

    loop_index: int
    labels: tuple[str, ...]
    coeffs: np.ndarray
    scale: np.ndarray
    square: tuple[int, ...] = ()
    bilinear: "Bilinear | None" = None
    prune: bool = True

    @property
    def variables(self) -> tuple[int, ...]:
        """Global indices of the variables this block depends on."""
        return tuple(k for k, d in enumerate(self.coeffs.shape[1:]) if d > 1)


class LoopPolynomials:
    """The polynomials of one loop in some parameterization (:mod:`spherekin.search.parameterizations`).

    ``matrix`` (3, 3, *dims): control points of q F_n (F_n of Eq. 2); ``q`` (*dims): those of the
    cleared denominator (q_n = prod (1 + t_k^2) for tan-half, 1 for sin-cos); ``scalar``: the
    control points of Eq. (10) by the paper's recursion route, or None where the parameterization
    has none (then it is read off ``matrix``). Tensor axis a is global variable ``variables[a]``.
    ``half_a`` (10, *dims_a) and ``half_b`` (10, *dims_b): the loop cut in the middle, F_n = P S
    with P the product of the factors up to the floor(k/2)-th unknown: rows 0..8 are the entries
    (row-major) of q_a P and q_b S, row 9 is q_a or q_b; their axes are the first ``split`` and
    the remaining axes of ``variables``. None for a loop with one unknown.
    ``matrix_mag`` (3, 3), ``half_a_mag``, ``half_b_mag`` (10,): per entry (row of a half), a bound
    on the size of the terms behind each of its control points
    (:func:`spherekin.closure.matrix_magnitude`), which the rounding tolerances are relative to;
    None: the control points' own largest absolute values (only for polynomials computed without
    cancellation).
    """

    __slots__ = ("loop_index", "variables", "matrix", "q", "scalar", "half_a", "half_b", "matrix_mag",
                 "half_a_mag", "half_b_mag")

    loop_index: int
    variables: tuple[int, ...]
    matrix: np.ndarray
    q: np.ndarray
    scalar: np.ndarray | None
    half_a: np.ndarray | None
    half_b: np.ndarray | None
    matrix_mag: np.ndarray
    half_a_mag: np.ndarray | None
    half_b_mag: np.ndarray | None

    def __init__(self, loop_index, variables, matrix, q, scalar=None, half_a=None, half_b=None, matrix_mag=None,
                 half_a_mag=None, half_b_mag=None):
        self.loop_index = loop_index
        self.variables = variables
        self.matrix = matrix
        self.q = q
        self.scalar = scalar
        self.half_a = half_a
        self.half_b = half_b
        self.matrix_mag = _largest_per_row(matrix, 2).reshape(3, 3) if matrix_mag is None else matrix_mag
        self.half_a_mag = None if half_a is None else _largest_per_row(half_a) if half_a_mag is None else half_a_mag
        self.half_b_mag = None if half_b is None else _largest_per_row(half_b) if half_b_mag is None else half_b_mag

    def entry_mag(self, r: int, c: int) -> float:
        """Magnitude of q f_rc (row r, column c of ``matrix``)."""
        return float(self.matrix_mag[r, c])

    def scalar_mag(self) -> float:
        """Magnitude of Eq. (10), q f11 + q f22 - 2 q, by either route (same terms)."""
        return float(self.matrix_mag[0, 0] + self.matrix_mag[1, 1] + 2.0 * np.max(np.abs(self.q)))

    @property
    def split(self) -> int:
        """Number of tensor axes (variables) in half a: its unknowns for tan-half, twice that for sin-cos."""
        return self.half_a.ndim - 1 if self.half_a is not None else 0


def _largest_per_row(tensor: np.ndarray, lead: int = 1) -> np.ndarray:
    """The largest |value| of each row (the first ``lead`` axes) of a tensor of control points."""
    t = np.abs(np.asarray(tensor, dtype=float))
    return t.reshape(t.shape[:lead] + (-1,)).max(axis=-1)


@dataclass(frozen=True)
class Bilinear:
    """Equations E_e = sum_t coef_t a[u_t] (x) b[v_t] in the control points of a loop's halves.

    ``a`` (U, *dims_a) and ``b`` (V, *dims_b) on the global variables ``a_vars``, ``b_vars``
    (disjoint); ``terms`` (T, 4) rows (e, u, v, coef). A product of polynomials in disjoint
    variables has the outer product of their control points as control points, so restricting
    a and b to a box and assembling gives the equations' control points on that box.
    """

    a_vars: tuple[int, ...]
    b_vars: tuple[int, ...]
    a: np.ndarray
    b: np.ndarray
    terms: np.ndarray
    #: Per row of a and b (U,), (V,): bounds on the terms behind its control points; None: max |row|.
    a_mag: np.ndarray | None = None
    b_mag: np.ndarray | None = None

    @property
    def n_equations(self) -> int:
        return int(self.terms[:, 0].max()) + 1

    def assemble(self, a: np.ndarray | None = None, b: np.ndarray | None = None) -> np.ndarray:
        """Control points (E, *dims_a, *dims_b, *batch) from a (U, *dims_a, *batch), b (V, *dims_b, *batch).

        Batch axes (if any) are last and must agree; defaults are the unit-box halves.
        """
        a = self.a if a is None else a
        b = self.b if b is None else b
        na, nb = len(self.a_vars), len(self.b_vars)
        batch = a.shape[1 + na:]
        da, db = a.shape[1:1 + na], b.shape[1:1 + nb]
        e, u, v = (self.terms[:, i].astype(int) for i in range(3))
        af = a.reshape((a.shape[0], -1) + (1,) + batch)[u]                  # (T, Ia, 1, *batch)
        bf = b.reshape((b.shape[0], 1, -1) + batch)[v]                      # (T, 1, Jb, *batch)
        outer = (af * bf).reshape(len(e), -1)
        w = np.zeros((self.n_equations, len(e)))
        w[e, np.arange(len(e))] = self.terms[:, 3]
        return (w @ outer).reshape((self.n_equations,) + da + db + batch)

    def magnitude(self) -> np.ndarray:
        """Per equation, sum_t |coef_t| max A[u_t] max B[v_t], with A, B the magnitudes of the halves'
        control points (``a_mag``, ``b_mag``): bounds every term of the sums on every sub-box
        (restricted control points are convex combinations), hence their rounding."""
        amax = _largest_per_row(self.a) if self.a_mag is None else np.asarray(self.a_mag, dtype=float)
        bmax = _largest_per_row(self.b) if self.b_mag is None else np.asarray(self.b_mag, dtype=float)
        e, u, v = (self.terms[:, i].astype(int) for i in range(3))
        out = np.zeros(self.n_equations)
        np.add.at(out, e, np.abs(self.terms[:, 3]) * amax[u] * bmax[v])
        return out


@dataclass(slots=True, eq=False)
class ChartBilinear:
    """The :class:`Bilinear` form of one block on every chart, laid out for the box loop.

    ``a`` (U, *dims_a, C) and ``b`` (V, *dims_b, C): each chart's halves, chart axis last (the box
    loop takes the charts of a batch of boxes with ``np.take(..., axis=-1)``); ``sums[e]``: the
    (u, v, coef) terms of equation e; ``shape``: (E, d_1..d_N) of the dense block it stands for.
    Built by :meth:`stack`; :meth:`assemble` is the fast form of :meth:`Bilinear.assemble` (its
    reference), tested against it.
    """

    a_vars: tuple[int, ...]
    b_vars: tuple[int, ...]
    a: np.ndarray
    b: np.ndarray
    sums: tuple
    shape: tuple[int, ...]

    @classmethod
    def stack(cls, forms: Sequence[Bilinear], n_vars: int) -> "ChartBilinear":
        """One chart's Bilinear per entry of ``forms`` (the same terms and variables on each)."""
        f0 = forms[0]
        e, u, v = (f0.terms[:, i].astype(int) for i in range(3))
        # per equation, its terms: a sparse sum, not a dense matrix product (a BLAS call of this
        # size costs more in threading than the ~3 terms per equation need)
        sums = tuple(tuple((int(u[t]), int(v[t]), float(f0.terms[t, 3])) for t in np.flatnonzero(e == k))
                     for k in range(f0.n_equations))
        shape = [f0.n_equations] + [1] * n_vars
        for var, d in zip(f0.a_vars + f0.b_vars, f0.a.shape[1:] + f0.b.shape[1:]):
            shape[1 + var] = d
        return cls(tuple(f0.a_vars), tuple(f0.b_vars), np.ascontiguousarray(np.stack([f.a for f in forms], axis=-1)),
                   np.ascontiguousarray(np.stack([f.b for f in forms], axis=-1)), sums, tuple(shape))

    def assemble(self, ra: np.ndarray, rb: np.ndarray) -> np.ndarray:
        """Control points (E, d_1..d_N, B) from the halves restricted to B boxes, ra (U, *dims_a, B)
        and rb (V, *dims_b, B): the equations' sparse sums of outer products, reordered to the
        global variables (axes of variables in neither half have length 1)."""
        nb = ra.shape[-1]
        da, db = ra.shape[1:-1], rb.shape[1:-1]
        af = ra.reshape(ra.shape[0], -1, 1, nb)
        bf = rb.reshape(rb.shape[0], 1, -1, nb)
        full = np.empty((len(self.sums), af.shape[1], bf.shape[2], nb))
        for k, terms in enumerate(self.sums):
            out = full[k]
            (u0, v0, c0), rest = terms[0], terms[1:]
            np.multiply(af[u0], bf[v0], out=out)
            if c0 != 1.0:
                out *= c0
            for u1, v1, c1 in rest:
                if c1 == 1.0:
                    out += af[u1] * bf[v1]
                elif c1 == -1.0:
                    out -= af[u1] * bf[v1]
                else:
                    out += c1 * (af[u1] * bf[v1])
        full = full.reshape((len(self.sums),) + da + db + (nb,))
        lv = list(self.a_vars) + list(self.b_vars)
        perm = (0,) + tuple(1 + int(i) for i in np.argsort(lv)) + (1 + len(lv),)
        return np.ascontiguousarray(np.transpose(full, perm)).reshape(self.shape + (nb,))


#: Rows of a loop half: the entry (r, c) of q P (or q S) is row 3 r + c; the denominator is row Q.
Q = 9


def _entry_terms(e: int, r: int, c: int) -> list:
    """Terms of q F_rc = sum_k (q_a P)_rk (q_b S)_kc."""
    return [(e, 3 * r + k, 3 * k + c, 1.0) for k in range(3)]


def _scalar_terms(e: int) -> list:
    """Terms of Eq. (10): q F_11 + q F_22 - 2 q."""
    return _entry_terms(e, 0, 0) + _entry_terms(e, 1, 1) + [(e, Q, Q, -2.0)]


def _halves_terms(e: int, r: int, c: int) -> list:
    """Terms of q_b (q_a P)_rc - q_a (q_b S)_cr (vanish for all r, c exactly when P = S^T)."""
    return [(e, 3 * r + c, Q, 1.0), (e, Q, 3 * c + r, -1.0)]


def embed_axes(tensor: np.ndarray, variables: Sequence[int], n_vars: int) -> np.ndarray:
    """Place a tensor whose last len(variables) axes are the given global variables on all n_vars axes.

    Axes of absent variables get length 1; axes are permuted into global order. Shape (..., n_vars).
    """
    k = len(variables)
    if len(set(variables)) != k or any(not 0 <= v < n_vars for v in variables):
        raise ValueError(f"variables: expected distinct indices in [0, {n_vars}), got {tuple(variables)}")
    lead = tensor.ndim - k
    order = np.argsort(variables)
    out = np.transpose(tensor, tuple(range(lead)) + tuple(lead + int(i) for i in order))
    shape = list(tensor.shape[:lead]) + [1] * n_vars
    for a, v in enumerate(variables):
        shape[lead + v] = tensor.shape[lead + a]
    return out.reshape(shape)


def _block(lp: LoopPolynomials, n_vars: int, labels, tensors, mags, square=(), terms=None,
           prune=True) -> EquationBlock:
    """A block from dense tensors (loop axes), or, with ``terms``, from the bilinear form in the halves.

    ``mags``: per equation, the magnitude of the terms behind its control points
    (:attr:`LoopPolynomials.matrix_mag`); the block's ``scale`` is the largest, so that the rounding
    tolerance of the equation (ROUNDING_SAFETY eps scale) bounds its rounding wherever it is small.
    """
    bil = None
    if terms is not None and lp.half_a is not None:
        k = lp.split
        bil = Bilinear(tuple(lp.variables[:k]), tuple(lp.variables[k:]), lp.half_a, lp.half_b,
                       np.array(terms, dtype=float), lp.half_a_mag, lp.half_b_mag)
        tensors = list(bil.assemble())
    coeffs = embed_axes(np.stack(np.broadcast_arrays(*tensors)), lp.variables, n_vars)
    scale = np.abs(coeffs).reshape(len(tensors), -1).max(axis=1)
    scale = np.maximum(scale, np.asarray(mags, dtype=float))
    if bil is not None:
        scale = np.maximum(scale, bil.magnitude())
    return EquationBlock(lp.loop_index, tuple(labels), coeffs, scale, tuple(square), bil, prune)


def _scalar(lp: LoopPolynomials) -> np.ndarray:
    """Eq. (10): f11bar + f22bar - 2 q (the paper's recursion route when available)."""
    if lp.scalar is not None:
        return lp.scalar
    return lp.matrix[0, 0] + lp.matrix[1, 1] - 2 * lp.q


class Formulation(ABC):
    """A formulation: which equations of each loop's polynomials the solver works on.

    A new one subclasses this, sets ``name`` and implements :meth:`blocks`, and is registered with
    ``@FORMULATIONS.register``; every check and the command line then accept it.
    """

    name: ClassVar[str]
    #: Whether the blocks use Eq. (10) of every loop: the parameterization then computes it by the
    #: paper's recursion route (Cor. 2); when False it skips that route and :func:`_scalar` reads the
    #: same polynomial off the matrix for the loops that need it.
    uses_scalar: ClassVar[bool] = True

    @abstractmethod
    def blocks(self, polys: Sequence[LoopPolynomials], n_vars: int) -> list[EquationBlock]:
        """Equation blocks over the global unit box of ``n_vars`` variables, from the loops' polynomials."""


#: The formulations of the loop equations, by name.
FORMULATIONS = Registry("formulation")


@FORMULATIONS.register
class Paper(Formulation):
    """One scalar equation per loop (Eq. 10)."""

    name = "paper"

    def blocks(self, polys, n_vars):
        return [_block(lp, n_vars, [f"loop{lp.loop_index + 1}:f11+f22-2q"], [_scalar(lp)], [lp.scalar_mag()])
                for lp in polys]


@FORMULATIONS.register
class Transversal(Formulation):
    """Per loop q f21, q f31, q f32 (simple roots; the square system) plus Eq. (10) (removes spurious roots)."""

    name = "transversal"

    def blocks(self, polys, n_vars):
        blocks = []
        for lp in polys:
            j = lp.loop_index + 1
            tensors = [lp.matrix[r, c] for r, c in TRANSVERSAL_ENTRIES] + [_scalar(lp)]
            labels = [f"loop{j}:qf{r + 1}{c + 1}" for r, c in TRANSVERSAL_ENTRIES] + [f"loop{j}:f11+f22-2q"]
            terms = [t for e, (r, c) in enumerate(TRANSVERSAL_ENTRIES) for t in _entry_terms(e, r, c)]
            terms += _scalar_terms(len(TRANSVERSAL_ENTRIES))
            mags = [lp.entry_mag(r, c) for r, c in TRANSVERSAL_ENTRIES] + [lp.scalar_mag()]
            blocks.append(_block(lp, n_vars, labels, tensors, mags, square=range(len(TRANSVERSAL_ENTRIES)),
                                 terms=terms))
        return blocks


@FORMULATIONS.register
class Halves(Formulation):
    """Per loop the nine entries of q_b q_a (P - S^T), pruned, and q f21, q f31, q f32, the square system.

    The transversal entries add almost nothing to the pruning power of the nine (Gosselin: 2855 vs
    2865 boxes), so they form a second block with ``prune=False`` that only the Krawczyk test
    evaluates, on small boxes. A loop with one unknown has no middle to close at: it keeps the
    transversal block (pruned) with Eq. (10), which removes the spurious roots.
    """

    name = "halves"
    uses_scalar = False          # Eq. (10) only on loops with one unknown

    def blocks(self, polys, n_vars):
        blocks = []
        for lp in polys:
            j = lp.loop_index + 1
            tensors = [lp.matrix[r, c] for r, c in TRANSVERSAL_ENTRIES]
            labels = [f"loop{j}:qf{r + 1}{c + 1}" for r, c in TRANSVERSAL_ENTRIES]
            terms = [t for e, (r, c) in enumerate(TRANSVERSAL_ENTRIES) for t in _entry_terms(e, r, c)]
            mags = [lp.entry_mag(r, c) for r, c in TRANSVERSAL_ENTRIES]
            square = range(len(TRANSVERSAL_ENTRIES))
            if lp.half_a is None:
                blocks.append(_block(lp, n_vars, labels + [f"loop{j}:f11+f22-2q"], tensors + [_scalar(lp)],
                                     mags + [lp.scalar_mag()], square=square))
                continue
            hterms = [t for r in range(3) for c in range(3) for t in _halves_terms(3 * r + c, r, c)]
            hlabels = [f"loop{j}:P{r + 1}{c + 1}-S{c + 1}{r + 1}" for r in range(3) for c in range(3)]
            # the halves' magnitudes enter through the bilinear form's (Bilinear.magnitude)
            blocks.append(_block(lp, n_vars, hlabels, [lp.q] * 9, [0.0] * 9, terms=hterms))
            blocks.append(_block(lp, n_vars, labels, tensors, mags, square=square, terms=terms, prune=False))
        return blocks


def formulate_polynomials(name: str, polys: Sequence[LoopPolynomials], n_vars: int) -> list[EquationBlock]:
    """Equation blocks of the formulation called ``name`` (one of FORMULATIONS) from loop polynomials."""
    formulation = FORMULATIONS.lookup(name)
    if not polys:
        raise ValueError("loops: expected at least one closure loop, got none")
    return formulation().blocks(polys, n_vars)
