"""LP backends for the Eq. (12) box reduction, behind one small interface and chosen by name.

For one box with equations e (control points w_e on the box's own unit grid), Eq. (12) asks for
the min and max of every x_k over

    m_k x_k = sum_I i_k lambda_{e,I}  (k in S(e)),  sum(lambda_e) = 1,  lambda_e >= 0,
    |w_e . lambda_e| <= tol_e   (all e)

where I = (i_1..i_n) runs over the control points and m_k is the degree of x_k (the abscissa
i_k / m_k of Eq. (12) multiplied out, so that every entry of these rows is an exactly
representable integer). Departures from the paper: the plane w = 0 is the slab |w| <= tol (see
:mod:`spherekin.search.pruners`), and each w_e is divided by its largest |w| on the box so the LP is
well scaled (the slab is widened by :data:`SLAB_ROUNDING` for the rounding of that division).

In matrix form (:class:`LPStructure`) the LP is  min c.z  s.t.  row_lo <= A z <= row_hi,
col_lo <= z <= col_hi,  z = (x, lambda_1, ..., lambda_E), with every column in [0, 1] (lambda <= 1
is implied by lambda >= 0 and sum(lambda) = 1, so the solvers need not be told).

**Nothing the solver says is trusted.** A bound comes only from a certificate verified here in
floating point with outward rounding (Neumaier & Shcherbina 2004, "Safe bounds in linear and
mixed-integer linear programming", Math. Program. 99; Jansson 2004, SIAM J. Optim. 14):

* for ANY row multipliers y (the solver's dual solution), weak duality over the bounded columns
  gives a lower bound on min c.z (:meth:`LPStructure.certified_min`); min x_k and max x_k use it
  with c = +e_k and c = -e_k. A bound worse than the box face leaves the face;
* an "infeasible" (or failed) verdict empties the box only with a Farkas certificate: row
  multipliers y (a HiGHS dual ray, or cvxpy's infeasibility certificate) for which the same bound
  with c = 0 is > 0, which no feasible z allows (:meth:`LPStructure.certifies_empty`). Otherwise
  the box is kept. A certified lower bound above a certified upper bound also empties it.

Backends (``LP_BACKENDS``), each supplying only its row duals mapped to the structure's rows:

* ``clarabel``, ``highs`` -- the problem modelled in cvxpy **once per problem
  shape**, with the w_e, tol_e and the objective direction as Parameters (DPP), re-solved by the
  named cvxpy solver for every box and bound;
* ``highspy`` -- HiGHS called directly through highspy: one reused model, the 2n objectives
  re-solved with a warm-started simplex (the LPs are tiny, so per-call overhead dominates).

OSQP and SCS (first-order solvers through cvxpy) are measured but not offered
(:data:`REJECTED_LP_BACKENDS`, with the numbers): their approximate duals do give valid certified
bounds (:class:`OsqpBackend` says why), but they are slower than every offered backend.

The solver's primal point is only a diagnostic: an LP counts as a *doubt* when it gave no usable
certificate (the bound stays at the face), or when its primal point violates Eq. (12) by more than
:data:`FEASIBILITY_TOL` or lies more than :data:`LP_BOUND_MARGIN` beyond the certified bound (the
certified bound is used all the same: it is valid whatever the solver did).
"""

from __future__ import annotations

import warnings
from itertools import product
from typing import ClassVar, Sequence

from dataclasses import dataclass

import numpy as np

from .registry import Registry

__all__ = ["LP_BACKENDS", "REJECTED_LP_BACKENDS", "REJECTED_BACKEND_CLASSES", "BoxBounds", "LPBackend", "CvxpyBackend",
           "ClarabelBackend", "HighsCvxpyBackend", "HighspyBackend", "OsqpBackend", "ScsBackend", "make_backend",
           "backend_class", "LPStructure"]

EPS = np.finfo(float).eps
#: Added to every scaled slab half-width tol/s (s = max|w|): fl(w_I / s) and fl(tol / s) are each
#: off by at most EPS/2 (both are <= 1 in size, and sum(lambda) = 1), so a lambda with
#: |w . lambda| <= tol has |fl(w/s) . lambda| <= fl(tol/s) + EPS; 4 EPS also covers rounding this sum.
SLAB_ROUNDING = 4 * EPS
#: The certified bound is the float value of the weak-duality bound minus
#: BOUND_ROUNDING_SAFETY * K * EPS * T (see :meth:`LPStructure.certified_min`): the first-order
#: error analysis gives gamma_K * T <= 1.01 K (EPS/2) T; the factor 2 over that covers the
#: second-order terms and T itself being computed in floats.
BOUND_ROUNDING_SAFETY = 2.0
#: Diagnostic only (bounds never depend on it): a primal point violating a row or column of
#: Eq. (12) by more than this (the LP is scaled to O(1); interior-point solvers reach ~1e-8,
#: simplex ~1e-9) counts as a doubt.
FEASIBILITY_TOL = 1e-7
#: Diagnostic only: a solver's primal objective more than this beyond the certified bound (unit
#: coordinates of the box) counts as a doubt -- the duals were poor and the bound, though valid,
#: is loose (honest solves, random and Gosselin boxes of tests/test_lp_backends.py: at most 1.1e-10
#: apart with HiGHS, 1e-9 with Clarabel).
LP_BOUND_MARGIN = 1e-6

OPTIMAL, INFEASIBLE, OTHER = "optimal", "infeasible", "other"

#: HiGHS options for the direct backend: the LPs are tiny (~650 columns, ~40 rows) and re-solved
#: thousands of times, so presolve and parallelism cost more than they save; primal simplex
#: (strategy 4) measured fastest on the Gosselin system (benchmarks/bench_solve.py).
#: No "threads" option: HiGHS has one thread scheduler per process, created by the first run with
#: the then-current "threads"; a later run asking for another count fails (model status kNotset).
#: cvxpy's HIGHS runs with the default, so "threads": 1 here made every direct solve fail once a
#: cvxpy HIGHS solve had happened in the process (the simplex strategy used is serial anyway).
LP_OPTIONS = {"presolve": "off", "solver": "simplex", "simplex_strategy": 4}
#: Clarabel's gap and feasibility tolerances. At its defaults (1e-8) its duals, multiplied by slab
#: multipliers up to ~1e2, left certified bounds up to 1.1e-6 looser than the true optimum
#: (random boxes of tests/test_lp_backends.py); at 1e-9 at most 1.1e-8, at no measurable cost
#: (cvxpy's per-solve overhead dominates). At 1e-10 it is no tighter and Clarabel starts to
#: report "inaccurate" solutions (3 of 122 LPs of the tests/test_boxloop.py Gosselin case).
CLARABEL_TOL = 1e-9
#: On an "infeasible" (or failed) verdict without a dual ray (Farkas certificate) in HiGHS's state,
#: the direct backend re-runs HiGHS with the dual simplex (strategy 1), warm-started, which returns
#: one: the primal simplex gave none on any of 60 narrow Gosselin boxes of the paper formulation.
DUAL_SIMPLEX_STRATEGY = 1


@dataclass(slots=True, eq=False)
class BoxBounds:
    """Result of the Eq. (12) reduction of one box (bounds in the box's unit coordinates)."""

    empty: bool
    lo: np.ndarray
    hi: np.ndarray
    lp_count: int
    doubts: int


@dataclass(slots=True, eq=False)
class EquationRows:
    """Where one equation of Eq. (12) sits in the matrix form: its lambda columns and its rows.

    Rows: ``sum_row`` (sum(lambda) = 1), ``var_rows`` (i_k . lambda - m_k x_k = 0 for k in
    ``variables``; ``abscissae`` (|S|, N) holds the integers i_k, ``degrees`` the m_k) and
    ``slab_row`` (|w . lambda| <= tol).
    """

    block: int
    index: int
    variables: tuple[int, ...]
    abscissae: np.ndarray
    degrees: np.ndarray
    cols: slice
    sum_row: int
    var_rows: np.ndarray
    slab_row: int


class LPStructure:
    """Eq. (12) in matrix form for given equation shapes; per box only the w entries and slab bounds change.

    Columns: x (n), then lambda of each equation in order, all in [0, 1] (``col_lo``, ``col_hi``).
    ``csc_start``, ``csc_index``, ``csc_value`` hold A column-wise for solvers (w entries 0, set per
    box); ``AT`` is A^T (columns x rows) dense, with the loaded box's w (at ~650 x 48 a BLAS
    mat-vec takes ~5 us, scipy.sparse ~12 us).
    """

    def __init__(self, shapes: Sequence[tuple[int, ...]]):
        if not shapes:
            raise ValueError("shapes: expected at least one equation block shape, got none")
        self.shapes = [tuple(int(d) for d in s) for s in shapes]
        self.n = n = len(self.shapes[0]) - 1
        if n < 1:
            raise ValueError(f"shapes: expected (equations, d_1, ..., d_n) with n >= 1, got {shapes[0]}")
        rows, cols, vals, slots = [], [], [], []       # COO entries; slots: w position or -1
        self.equations: list[EquationRows] = []
        nrow, ncol, nslot = 0, n, 0
        for b, shape in enumerate(self.shapes):
            dims = shape[1:]
            if len(dims) != n or shape[0] < 1 or min(dims) < 1:
                raise ValueError(f"shapes: expected (equations >= 1, d_1..d_{n} >= 1) in every block, got {shape}")
            grid = np.array(list(product(*(range(d) for d in dims))), dtype=float).reshape(-1, n)
            nl = len(grid)
            variables = tuple(k for k, d in enumerate(dims) if d > 1)
            absc = grid[:, list(variables)].T.copy()                    # (|S|, N) integers i_k
            degrees = np.array([dims[k] - 1 for k in variables], dtype=float)
            for e in range(shape[0]):
                lam = np.arange(ncol, ncol + nl)
                sum_row = nrow
                rows.append(np.full(nl, sum_row)); cols.append(lam); vals.append(np.ones(nl))
                slots.append(np.full(nl, -1))
                var_rows = np.arange(nrow + 1, nrow + 1 + len(variables))
                for r, k, a, m in zip(var_rows, variables, absc, degrees):
                    nz = np.flatnonzero(a)
                    rows.append(np.full(len(nz) + 1, r)); cols.append(np.r_[lam[nz], k])
                    vals.append(np.r_[a[nz], -m]); slots.append(np.full(len(nz) + 1, -1))
                slab_row = nrow + 1 + len(variables)
                rows.append(np.full(nl, slab_row)); cols.append(lam); vals.append(np.zeros(nl))
                slots.append(np.arange(nslot, nslot + nl))
                self.equations.append(EquationRows(b, e, variables, absc, degrees, slice(ncol, ncol + nl),
                                                   sum_row, var_rows, slab_row))
                nrow, ncol, nslot = slab_row + 1, ncol + nl, nslot + nl
        self.nrow, self.ncol = nrow, ncol
        rows, cols, vals, slots = (np.concatenate(a) for a in (rows, cols, vals, slots))
        order = np.lexsort((rows, cols))                                  # column-major: CSC order
        rows, cols, vals, slots = rows[order], cols[order], vals[order], slots[order]
        self.csc_start = np.searchsorted(cols, np.arange(ncol + 1)).astype(np.int32)
        self.csc_index = rows.astype(np.int32)
        self.csc_value = vals.astype(float)
        self.AT = np.zeros((ncol, nrow))
        self.AT[cols, rows] = vals
        w_pos = np.flatnonzero(slots >= 0)[np.argsort(slots[slots >= 0])]   # entry index per w slot
        self.w_rows, self.w_cols = rows[w_pos].astype(np.int32), cols[w_pos].astype(np.int32)
        self.slab_rows = np.array([eq.slab_row for eq in self.equations], dtype=np.int32)
        self.sum_rows = np.array([eq.sum_row for eq in self.equations])
        self.lambda_starts = np.array([eq.cols.start for eq in self.equations])
        self.row_lo, self.row_hi = np.zeros(nrow), np.zeros(nrow)
        sums = [eq.sum_row for eq in self.equations]
        self.row_lo[sums] = self.row_hi[sums] = 1.0
        self.row_lo[self.slab_rows], self.row_hi[self.slab_rows] = -1.0, 1.0
        self.col_lo, self.col_hi = np.zeros(ncol), np.ones(ncol)
        #: per row max(|lo_r|, |hi_r|) + sum_j |A_rj|: the row's weight in the rounding bound T
        self.row_size = np.maximum(np.abs(self.row_lo), np.abs(self.row_hi)) + np.abs(self.AT).sum(axis=0)
        #: the K of the rounding analysis: terms of a column of A (dense: all rows), rows, columns
        self.rounding_terms = 2 * nrow + ncol + 4
        self.w_values = np.zeros(nslot)
        self.half_widths = np.ones(len(self.equations))
        self.active = np.zeros(len(self.equations), dtype=bool)

    def objective(self, k: int, sign: float) -> np.ndarray:
        """The cost vector over all columns for min sign * x_k."""
        c = np.zeros(self.ncol)
        c[k] = sign
        return c

    def load(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]) -> bool:
        """Write one box's scaled w rows and slab bounds; False if no equation constrains the box.

        Each w_e is divided by s = max|w_e| and the slab becomes |w_e/s . lambda| <= tol_e/s +
        SLAB_ROUNDING; an equation with s <= tol_e lies inside its slab everywhere and gets a zero
        row with bounds [-1, 1] (no constraint).
        """
        if len(cps) != len(self.shapes) or len(tols) != len(self.shapes):
            raise ValueError(f"cps, tols: expected {len(self.shapes)} blocks each, got {len(cps)} and {len(tols)}")
        ws, widths, active = [], [], []
        for b, (shape, c, t) in enumerate(zip(self.shapes, cps, tols)):
            c = np.asarray(c, dtype=float)
            t = np.asarray(t, dtype=float)
            if c.shape != shape:
                raise ValueError(f"cps[{b}]: expected shape {shape}, got {c.shape}")
            if t.shape != (shape[0],):
                raise ValueError(f"tols[{b}]: expected shape ({shape[0]},), got {t.shape}")
            flat = c.reshape(shape[0], -1)
            scale = np.abs(flat).max(axis=1)                 # NaN / inf control points show here
            if not (np.isfinite(scale).all() and np.isfinite(t).all() and (t >= 0).all()):
                raise ValueError(f"cps[{b}], tols[{b}]: expected finite control points and finite tolerances >= 0")
            act = scale > t
            safe = np.where(act, scale, 1.0)
            ws.append(np.where(act[:, None], flat / safe[:, None], 0.0).ravel())
            widths.append(np.where(act, t / safe + SLAB_ROUNDING, 1.0))
            active.append(act)
        self.w_values = np.concatenate(ws)
        self.half_widths = np.concatenate(widths)
        self.active = np.concatenate(active)
        self.AT[self.w_cols, self.w_rows] = self.w_values
        self.row_lo[self.slab_rows] = -self.half_widths
        self.row_hi[self.slab_rows] = self.half_widths
        self.row_size[self.slab_rows] = self.half_widths + np.add.reduceat(np.abs(self.w_values),
                                                                           self.lambda_starts - self.n)
        return bool(self.active.any())

    def certified_min(self, c: np.ndarray, y) -> float:
        """A rigorous lower bound on min c.z over Eq. (12) (the loaded box) from ANY row multipliers y.

        Weak duality (Neumaier & Shcherbina 2004, Sec. 2): with r = c - A^T y, every feasible z has
        c.z = y.(Az) + r.z >= sum_rows (y_r lo_r if y_r > 0 else y_r hi_r)
        + sum_cols min(r_j l_j, r_j u_j)  -- each row term is the least of y_r t over t in
        [lo_r, hi_r] (equality rows: lo = hi), each column term the least of r_j z_j over
        [l_j, u_j] = [0, 1], i.e. min(r_j, 0) (exact in floats).
        Floats: with u = EPS/2 and K = 2 rows + columns + 4, the computed value is within
        gamma_K * T of the exact one, T = sum_r |y_r| max(|lo_r|, |hi_r|) + sum_j (|c_j| +
        (|A|^T |y|)_j) (the errors of A^T y, of r = c - A^T y, of the row products and of the two
        sums; |z_j| <= 1); BOUND_ROUNDING_SAFETY * K * EPS * T is subtracted. Returns -inf when y
        is missing, has the wrong length or is not finite (no certificate).
        """
        if y is None:
            return -np.inf
        y = np.array(y, dtype=float)                 # a copy: the sum rows are changed below
        if y.shape != (self.nrow,):
            return -np.inf
        # A non-finite y_r needs no separate test: every row has a positive weight in T, so it makes
        # T, and the bound, non-finite (-> -inf). First each sum row's multiplier is moved by the
        # least reduced cost min_j r_j of its lambda block (any y is allowed, so this is just a
        # better y): the least of r . lambda_e over the simplex lambda_e is min_j r_j, so the block's
        # column terms become 0 and the row term gains min_j r_j. This absorbs the small negative
        # reduced costs an interior-point solver leaves on hundreds of lambda columns.
        with np.errstate(over="ignore", invalid="ignore"):
            y[self.sum_rows] += np.minimum.reduceat(c - self.AT @ y, self.lambda_starts)
            r = c - self.AT @ y
            value = np.where(y > 0, y * self.row_lo, y * self.row_hi).sum() + np.minimum(r, 0.0).sum()
            size = np.abs(y) @ self.row_size + np.abs(c).sum()          # T (columns: |z_j| <= 1)
            bound = value - BOUND_ROUNDING_SAFETY * self.rounding_terms * EPS * size
        return float(bound) if np.isfinite(bound) else -np.inf

    def certifies_empty(self, y) -> bool:
        """Is y (or -y) a verified Farkas certificate that the loaded Eq. (12) has no point?

        certified_min(0, y) > 0 would make 0 = min 0.z positive: impossible unless the LP is
        empty. Any y may be tried, so both signs are (solvers differ in their ray conventions).
        """
        if y is None:
            return False
        y = np.asarray(y, dtype=float)
        zero = np.zeros(self.ncol)
        return self.certified_min(zero, y) > 0 or self.certified_min(zero, -y) > 0

    def confirms(self, c: np.ndarray, z, bound: float) -> bool:
        """Diagnostic: is z a point of Eq. (12) within FEASIBILITY_TOL whose objective c.z lies
        within LP_BOUND_MARGIN of the certified bound (i.e. the solver was right)?"""
        if z is None:
            return False
        z = np.asarray(z, dtype=float)
        if z.shape != (self.ncol,):
            return False
        az = z @ self.AT                              # a NaN in z makes the violation NaN: False
        violation = max(-z.min(), z.max() - 1.0, (self.row_lo - az).max(), (az - self.row_hi).max())
        return bool(violation <= FEASIBILITY_TOL and c @ z - bound <= LP_BOUND_MARGIN)


#: The LP backends of Eq. (12), by name (:func:`make_backend`).
LP_BACKENDS = Registry("lp_backend")


class LPBackend:
    """Base class of the LP backends. Subclasses set ``name``, implement ``_load()`` (pass the box
    loaded into ``self.structure`` to the solver), ``_solve(direction) -> (status, z, y)``
    (minimize direction . x; z the primal point over all columns, y the row duals in the
    structure's convention c = A^T y + r, either may be None) and ``_farkas() -> (y or None,
    extra LP solves)`` after a verdict other than OPTIMAL (candidate Farkas multipliers, any
    sign), and are registered with ``@LP_BACKENDS.register``.
    All bounds are computed here, from certificates (:meth:`LPStructure.certified_min`): a backend
    is trusted for nothing.
    """

    name: ClassVar[str]

    def __init__(self, shapes: Sequence[tuple[int, ...]]):
        self.structure = LPStructure(shapes)
        st = self.structure
        self._objectives = {(k, s): st.objective(k, s) for k in range(st.n) for s in (1.0, -1.0)}

    def _load(self) -> None:
        raise NotImplementedError

    def _solve(self, direction: np.ndarray):
        raise NotImplementedError

    def _farkas(self):
        raise NotImplementedError

    def box_bounds(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]) -> BoxBounds:
        """min and max of every x_k over Eq. (12) for one box, each a certified bound (or the face).

        cps: per block the box's control points (E, d_1..d_n); tols: per block (E,) slab half-widths.
        Any verdict other than "optimal" (infeasible, or a failed solve) first asks the backend
        for a Farkas certificate; unproven, it is a doubt: after "infeasible" the bounds certified
        so far are returned, after a failed solve its duals (if any) still give a certified bound.
        The box is empty only when a Farkas certificate is verified or a certified lower bound
        exceeds a certified upper bound.
        """
        st = self.structure
        n = st.n
        lo, hi = np.zeros(n), np.ones(n)
        count = doubts = 0
        if not st.load(cps, tols):
            return BoxBounds(False, lo, hi, 0, 0)
        self._load()
        for k in range(n):
            for sign in (1.0, -1.0):
                c = self._objectives[(k, sign)]
                status, z, y = self._solve(c[:n].copy())
                count += 1
                if status != OPTIMAL:
                    ray, extra = self._farkas()
                    count += extra
                    if st.certifies_empty(ray):
                        return BoxBounds(True, np.ones(n), np.zeros(n), count, doubts)
                    doubts += 1
                    if status == INFEASIBLE:      # unproven: keep what is certified so far
                        return BoxBounds(False, lo, hi, count, doubts)
                bound = st.certified_min(c, y)   # valid for any y, whatever the status
                if bound == -np.inf:
                    doubts += status == OPTIMAL
                    continue
                if sign > 0:
                    lo[k] = max(lo[k], bound)
                else:
                    hi[k] = min(hi[k], -bound)
                doubts += status == OPTIMAL and not st.confirms(c, z, bound)
                if lo[k] > hi[k]:                 # a certified bound beyond the other one: no point
                    return BoxBounds(True, np.ones(n), np.zeros(n), count, doubts)
        return BoxBounds(False, lo, hi, count, doubts)


class CvxpyBackend(LPBackend):
    """Eq. (12) modelled once in cvxpy with Parameters (DPP); solved by the cvxpy solver ``solver``
    with ``options`` (set by the registered subclasses).

    Duals to the structure's rows (cvxpy's multipliers are >= 0 for ``<=`` and enter the
    Lagrangian as + mu (lhs - rhs); for ``==`` as + nu (lhs - rhs)): sum and abscissa rows
    y = -nu; slab row y = mu(-t <= w.lambda) - mu(w.lambda <= t).
    """

    solver: ClassVar[str]
    options: ClassVar[dict]

    def __init__(self, shapes):
        super().__init__(shapes)
        import cvxpy as cp  # imported here: only the cvxpy backends pay for it

        self._cp = cp
        self._solver, self._options = self.solver, dict(self.options)
        if self._solver == cp.HIGHS:
            import highspy

            _quiet_highs(highspy)   # HiGHS prints its banner once per process: spend it here, silently
        st = self.structure
        self.x = cp.Variable(st.n)
        self.c = cp.Parameter(st.n)
        self.lams, self.ws, self.ts, self._rows, cons = [], [], [], [], [self.x >= 0, self.x <= 1]
        for eq in st.equations:
            lam = cp.Variable(eq.abscissae.shape[1], nonneg=True)
            w = cp.Parameter(eq.abscissae.shape[1])
            t = cp.Parameter(nonneg=True)
            rows = [cp.sum(lam) == 1, w @ lam <= t, -t <= w @ lam]
            if eq.variables:
                rows.append(eq.abscissae @ lam - cp.multiply(eq.degrees, self.x[list(eq.variables)]) == 0)
            cons += rows
            self.lams.append(lam)
            self.ws.append(w)
            self.ts.append(t)
            self._rows.append(rows)
        self.problem = cp.Problem(cp.Minimize(self.c @ self.x), cons)
        assert self.problem.is_dpp()
        self._status = {cp.OPTIMAL: OPTIMAL, cp.OPTIMAL_INACCURATE: OPTIMAL,   # any dual is checked
                        cp.INFEASIBLE: INFEASIBLE, cp.INFEASIBLE_INACCURATE: INFEASIBLE}

    def _load(self):
        st = self.structure
        for eq, w, t, width in zip(st.equations, self.ws, self.ts, st.half_widths):
            w.value = st.w_values[eq.cols.start - st.n: eq.cols.stop - st.n]
            t.value = width

    def _duals(self):
        """The constraints' dual values as row multipliers y of the structure (None if missing)."""
        y = np.zeros(self.structure.nrow)
        for eq, rows in zip(self.structure.equations, self._rows):
            duals = [r.dual_value for r in rows]
            if any(d is None for d in duals):
                return None
            y[eq.sum_row] = -duals[0]
            y[eq.slab_row] = duals[2] - duals[1]
            if eq.variables:
                y[eq.var_rows] = -np.asarray(duals[3])
        return y

    def _solve(self, direction):
        self.c.value = direction
        try:
            with warnings.catch_warnings():
                # "Solution may be inaccurate": every answer is checked by its dual certificate
                # (an inaccurate one only gives a looser bound or a doubt), so the warning says nothing
                warnings.simplefilter("ignore", UserWarning)
                self.problem.solve(solver=self._solver, **self._options)
        except self._cp.error.SolverError:
            return OTHER, None, None
        except ValueError as exc:
            # cvxpy raises a bare ValueError ("Cannot unpack invalid solution") when the solver
            # ends in a status it does not map (HiGHS: UNKNOWN); a doubt like any other: the box
            # is kept unshrunk
            if "invalid solution" not in str(exc):
                raise
            return OTHER, None, None
        status = self._status.get(self.problem.status, OTHER)
        if status != OPTIMAL:
            return status, None, None
        if self.x.value is None or any(lam.value is None for lam in self.lams):
            z = None
        else:
            z = np.concatenate([self.x.value] + [lam.value for lam in self.lams])
        return OPTIMAL, z, self._duals()

    def _farkas(self):
        # after an infeasible solve cvxpy stores the solver's certificate of infeasibility as the
        # dual values (None if the solver gave none); the base class checks it
        return self._duals(), 0


@LP_BACKENDS.register
class ClarabelBackend(CvxpyBackend):
    """Clarabel (interior point, conic) through cvxpy; the paper-faithful configuration's backend."""

    name = "clarabel"
    solver = "CLARABEL"
    options = {"tol_gap_abs": CLARABEL_TOL, "tol_gap_rel": CLARABEL_TOL, "tol_feas": CLARABEL_TOL}


@LP_BACKENDS.register
class HighsCvxpyBackend(CvxpyBackend):
    """HiGHS through cvxpy (the model is rebuilt by cvxpy's canonicalization for every box)."""

    name = "highs"
    solver = "HIGHS"
    options: ClassVar[dict] = {}


def _quiet_highs(highspy):
    """A highspy.Highs with output off, created without its banner on standard output.

    HiGHS prints "Running HiGHS ..." from its C++ constructor, before any option can be set
    (ERGO-Code/HiGHS#2749), straight to file descriptor 1: redirect that descriptor to /dev/null
    while the object is built, so `spherekin solve` output (and JSON written to stdout) stays clean.
    """
    import os
    import sys

    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError):        # no usable descriptor 1 (embedded interpreters): build it as is
        h = highspy.Highs()
    else:
        try:
            with open(os.devnull, "w") as null:
                os.dup2(null.fileno(), 1)
                h = highspy.Highs()
        finally:
            os.dup2(saved, 1)
            os.close(saved)
    h.setOptionValue("output_flag", False)
    return h


@LP_BACKENDS.register
class HighspyBackend(LPBackend):
    """Eq. (12) passed to HiGHS directly (highspy) with one reused model.

    The constraint matrix is the structure's (CSC, every w-row entry present); per box only the
    w-row values and slab bounds are overwritten, and the 2n objectives re-solve warm-started.
    HiGHS's row duals already follow the structure's convention (col_dual = c - A^T row_dual).
    """

    name = "highspy"

    def __init__(self, shapes):
        super().__init__(shapes)
        import highspy

        self._hs = highspy
        self.h = _quiet_highs(highspy)
        st = self.structure
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = st.ncol, st.nrow
        lp.col_cost_ = np.zeros(st.ncol)
        lp.col_lower_ = st.col_lo.copy()
        upper = np.full(st.ncol, highspy.kHighsInf)     # lambda <= 1 is implied by the sum rows
        upper[: st.n] = 1.0
        lp.col_upper_ = upper
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = st.csc_start
        lp.a_matrix_.index_ = st.csc_index
        lp.a_matrix_.value_ = st.csc_value
        lp.row_lower_, lp.row_upper_ = st.row_lo.copy(), st.row_hi.copy()
        self.h.passModel(lp)
        for k, v in LP_OPTIONS.items():
            self.h.setOptionValue(k, v)
        self._cols = np.arange(st.n, dtype=np.int32)

    def _load(self):
        # update the w rows in place: the model (and the simplex basis of the previous box, a good
        # warm start for a neighbouring box) is kept
        st, h = self.structure, self.h
        for r, c, v in zip(st.w_rows.tolist(), st.w_cols.tolist(), st.w_values.tolist()):
            h.changeCoeff(r, c, v)
        h.changeRowsBounds(len(st.slab_rows), st.slab_rows, st.row_lo[st.slab_rows], st.row_hi[st.slab_rows])

    def _solve(self, direction):
        st, h = self.structure, self.h
        h.changeColsCost(st.n, self._cols, np.asarray(direction, dtype=float))
        ran = h.run()
        status = h.getModelStatus()
        if ran == self._hs.HighsStatus.kError and status == self._hs.HighsModelStatus.kNotset:
            # HiGHS refused to start (an option it rejects, or its per-process thread scheduler set
            # up differently by another HiGHS user): every LP would fail the same way, so this is a
            # configuration error, not a doubt about one box
            raise RuntimeError("highspy: HiGHS refused to run the Eq. (12) LP (model status kNotset); "
                               f"options {LP_OPTIONS}; rerun with output_flag on to see HiGHS's reason")
        if status == self._hs.HighsModelStatus.kInfeasible:
            return INFEASIBLE, None, None
        sol = h.getSolution()
        z = np.asarray(sol.col_value) if sol.value_valid else None
        y = np.asarray(sol.row_dual) if sol.dual_valid else None
        # a failed solve (e.g. kUnknown on nearly infeasible boxes) may still leave duals: any y
        # gives a certified bound, so they are passed on
        return (OPTIMAL if status == self._hs.HighsModelStatus.kOptimal else OTHER), z, y

    def _farkas(self):
        h = self.h
        _, has_ray, ray = h.getDualRay()
        if has_ray:
            return np.asarray(ray), 0
        # the primal simplex found infeasibility without a ray: the dual simplex, warm-started from
        # its basis, proves it with one (getDualRay)
        h.setOptionValue("simplex_strategy", DUAL_SIMPLEX_STRATEGY)
        try:
            h.run()
            _, has_ray, ray = h.getDualRay()
        finally:
            h.setOptionValue("simplex_strategy", LP_OPTIONS["simplex_strategy"])
        return (np.asarray(ray) if has_ray else None), 1


#: OSQP's settings in :class:`OsqpBackend` (measured, not offered): polishing on, as issue 18 asked;
#: eps 1e-3, the fastest of those measured (cvxpy's default 1e-5 and 1e-4, 1e-7 were slower per LP
#: and, hitting OSQP's iteration cap, left more LPs without duals: 22 of 84 at 1e-5, 64 of 84 at 1e-7
#: on the Gosselin +-0.3 rad boxes), and its bounds are certified however loose its duals are.
#: The polishing switch itself is set in OsqpBackend.__init__: OSQP >= 1 calls it "polishing" ("polish"
#: before), and cvxpy turns it off on a warm-started re-solve unless it is given under the right name.
OSQP_OPTIONS = {"eps_abs": 1e-3, "eps_rel": 1e-3}
#: SCS's settings in :class:`ScsBackend` (measured, not offered): eps 1e-3, the fastest measured
#: (30 ms per LP on the Gosselin +-1 rad problem against 59 ms at cvxpy's default 1e-5), with the
#: same boxes and solutions as HiGHS; its bounds are certified however loose its duals are.
SCS_OPTIONS = {"eps_abs": 1e-3, "eps_rel": 1e-3}


class OsqpBackend(CvxpyBackend):
    """OSQP (ADMM, with solution polishing) through cvxpy: measured and refused
    (:data:`REJECTED_LP_BACKENDS`), kept so that experiments/lp_backends.py can measure it again.

    **Why its bounds are valid although its duals are only approximate.** cvxpy maps OSQP's dual
    vector to the constraints like any other solver's (:meth:`CvxpyBackend._duals`); an ADMM
    solution at eps 1e-3 is neither primal- nor dual-feasible to more than ~1e-3. The bound is
    taken by :meth:`LPStructure.certified_min`, which needs no dual feasibility at all: for ANY
    row multipliers y, c.z = y.(A z) + r.z with r = c - A^T y, and every feasible z has A z in
    [row_lo, row_hi] and z in [0, 1]^ncol, so c.z >= sum_r min(y_r lo_r, y_r hi_r) + sum_j
    min(r_j, 0). The dual infeasibility (negative reduced costs r_j < 0) is thus charged at its
    size times the box size (|z_j| <= 1), which is the correction issue 18 asked for. Before that,
    the repair that is exact on the simplex: for equation e, sum(lambda_e) = 1 and lambda_e >= 0
    give r.lambda_e >= min_j r_j over its block, so moving y on its sum row by min_j r_j (another
    valid y) makes every reduced cost of the block >= 0 and loses nothing; only the x columns keep
    a charge. Rounding is bounded there too. A missing dual (OSQP stopped at its iteration cap:
    cvxpy reports no solution) gives no bound: the box keeps its face, never a guessed bound.
    """

    name = "osqp"
    solver = "OSQP"
    options: ClassVar[dict] = OSQP_OPTIONS

    def __init__(self, shapes):
        super().__init__(shapes)
        import osqp

        major = int(getattr(osqp, "__version__", "0").split(".")[0])
        self._options["polishing" if major >= 1 else "polish"] = True


class ScsBackend(CvxpyBackend):
    """SCS (first-order conic, homogeneous self-dual embedding) through cvxpy: measured and refused
    (:data:`REJECTED_LP_BACKENDS`), kept so that experiments/lp_backends.py can measure it again.
    Its bounds are valid for the reason given in :class:`OsqpBackend` (any dual gives a certified
    bound through :meth:`LPStructure.certified_min`; dual infeasibility is charged, never trusted).
    """

    name = "scs"
    solver = "SCS"
    options: ClassVar[dict] = SCS_OPTIONS


#: Backends that cvxpy offers and spherekin measured on Eq. (12) but does not offer, with the measured
#: reason (experiments/lp_backends.py, experiments/README.md Q7; every bound from a checked dual
#: certificate). Their classes are in :data:`REJECTED_BACKEND_CLASSES`, for that experiment only.
REJECTED_LP_BACKENDS = {
    "osqp": "OSQP (ADMM, polishing on, eps 1e-3) gives valid certified bounds (94-100% of its LPs give one, median "
            "3.5e-3 looser than HiGHS's in box coordinates) but is far slower than every offered backend: Gosselin "
            "+-1 rad (halves, pruner lp): 188 ms per LP, 261 boxes, 353 s, against highspy's 2.5 ms, 119 boxes, "
            "3.6 s (97x) and clarabel's 26 s (experiments/lp_backends.py, full run)",
    "scs": "SCS (first-order conic, eps 1e-3) gives valid certified bounds (100% of its LPs, median 1.1e-3 looser "
           "than HiGHS's) and the same solutions, but is slower than highspy and no faster than clarabel, with looser "
           "bounds: Gosselin +-1 rad (halves, pruner lp): 29 ms per LP, 25 s, against highspy's 2.5 ms, 3.6 s (6.8x) "
           "and clarabel's 26 s (experiments/lp_backends.py, full run)",
}
REJECTED_BACKEND_CLASSES = {"osqp": OsqpBackend, "scs": ScsBackend}


def make_backend(name: str, shapes: Sequence[tuple[int, ...]]) -> LPBackend:
    """The LP backend called ``name`` (one of LP_BACKENDS), set up for the given block shapes."""
    return backend_class(name)(shapes)


def backend_class(name: str) -> type:
    """The class of the LP backend called ``name``; ValueError naming the valid ones (and saying
    why, for a backend of cvxpy's that was measured and rejected) otherwise. Builds nothing."""
    if name in REJECTED_LP_BACKENDS:
        raise ValueError(f"lp_backend: expected one of {list(LP_BACKENDS)}, got {name!r}, which is not supported: "
                         f"{REJECTED_LP_BACKENDS[name]}")
    return LP_BACKENDS.lookup(name)
