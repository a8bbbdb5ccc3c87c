"""LP backends for the Eq. (12) box reduction, behind one small interface and chosen by name.

For one box with equations e (control points w_e on the box's own unit grid), Eq. (12) asks for
the min and max of every x_k over

    x_S(e) = G_e lambda_e,  sum(lambda_e) = 1,  lambda_e >= 0,  |w_e . lambda_e| <= tol_e   (all e)

where G_e maps a control-point index I to its abscissae (i_k / m_k) for the variables S(e) the
equation depends on. Departures from the paper: the plane w = 0 is the slab |w| <= tol (see
:mod:`spherekin.pruners`), and each w_e is divided by its largest |w| on the box so the LP is
well scaled.

Backends (``LP_BACKENDS``):

* ``clarabel``, ``highs`` -- the problem modelled in cvxpy **once per problem
  shape**, with the w_e, tol_e and the objective direction as Parameters (DPP), re-solved by the
  named cvxpy solver for every box and bound;
* ``highspy`` -- HiGHS called directly through highspy: one model per box, the 2n objectives
  re-solved with a warm-started simplex (the LPs are tiny, so per-call overhead dominates).

Every answer is distrusted (as scipy's linprog does): the status is mapped to one vocabulary and an
"optimal" point is re-checked against Eq. (12) with :data:`FEASIBILITY_TOL`; an "infeasible" answer
is confirmed by re-solving with the slab widened by :data:`INFEASIBILITY_RELAX`. Whatever fails a
check counts as a doubt and leaves that bound at the box face.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from typing import Sequence

import numpy as np

__all__ = ["LP_BACKENDS", "REJECTED_LP_BACKENDS", "BoxBounds", "make_backend", "LPStructure"]

#: A returned point must satisfy every constraint of Eq. (12) within this (the LP is scaled to
#: O(1)); interior-point solvers reach ~1e-8, simplex ~1e-9.
FEASIBILITY_TOL = 1e-7
#: Reported optima are moved outward by this (unit coordinates of the box): interior-point backends
#: stop at a duality gap ~1e-8, so the true optimum may lie slightly beyond the reported one.
LP_BOUND_MARGIN = 1e-6
#: An infeasible LP is confirmed by re-solving with the slab |w| <= tol widened by this factor; if
#: the widened LP is feasible the verdict was too close to call, and the box is kept.
INFEASIBILITY_RELAX = 100.0

OPTIMAL, INFEASIBLE, OTHER = "optimal", "infeasible", "other"

#: HiGHS options for the direct backend: the LPs are tiny (~650 columns, ~40 rows) and re-solved
#: thousands of times, so presolve and parallelism cost more than they save; primal simplex
#: (strategy 4) measured fastest on the Gosselin system (benchmarks/bench_solve.py).
LP_OPTIONS = {"presolve": "off", "solver": "simplex", "simplex_strategy": 4, "threads": 1}


@dataclass(frozen=True)
class BoxBounds:
    """Result of the Eq. (12) reduction of one box (bounds in the box's unit coordinates)."""

    empty: bool
    lo: np.ndarray
    hi: np.ndarray
    lp_count: int
    doubts: int


class LPStructure:
    """The fixed part of Eq. (12) for given equation shapes: columns, grid abscissae, equations."""

    def __init__(self, shapes: Sequence[tuple[int, ...]]):
        if not shapes:
            raise ValueError("shapes: expected at least one equation block shape, got none")
        self.n = len(shapes[0]) - 1
        self.equations = []  # (block, index in block, variables, G (|S|, N))
        for b, shape in enumerate(shapes):
            dims = shape[1:]
            if len(dims) != self.n:
                raise ValueError(f"shapes: expected {self.n} polynomial axes in every block, got {shape}")
            grid = np.array(list(product(*(range(d) for d in dims))), dtype=float).reshape(-1, self.n)
            variables = tuple(k for k, d in enumerate(dims) if d > 1)
            g = np.stack([grid[:, k] / (dims[k] - 1) for k in variables]) if variables else np.zeros((0, len(grid)))
            for e in range(shape[0]):
                self.equations.append((b, e, variables, g))

    def scaled(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]):
        """Per equation (w / max|w|, tol / max|w|), flattened; equations with max|w| <= tol are dropped."""
        out = []
        for b, e, variables, g in self.equations:
            w = np.asarray(cps[b][e], dtype=float).ravel()
            scale = np.abs(w).max()
            tol = float(tols[b][e])
            if scale <= tol:
                out.append(None)  # the whole hull lies in the slab: no constraint from this equation
            else:
                out.append((w / scale, tol / scale))
        return out

    def check(self, x: np.ndarray, lams: Sequence[np.ndarray | None], scaled) -> bool:
        """Does (x, lambda) satisfy Eq. (12) within FEASIBILITY_TOL?"""
        if x is None or not np.all(np.isfinite(x)) or np.any(x < -FEASIBILITY_TOL) or np.any(x > 1 + FEASIBILITY_TOL):
            return False
        for (b, e, variables, g), lam, sc in zip(self.equations, lams, scaled):
            if sc is None:
                continue
            if lam is None or not np.all(np.isfinite(lam)) or lam.min() < -FEASIBILITY_TOL:
                return False
            if abs(lam.sum() - 1.0) > FEASIBILITY_TOL:
                return False
            if variables and np.abs(g @ lam - x[list(variables)]).max() > FEASIBILITY_TOL:
                return False
            w, tol = sc
            if abs(w @ lam) > tol + FEASIBILITY_TOL:
                return False
        return True


class LPBackend:
    """Base class: subclasses implement ``_load(scaled, relax)`` (set the box's data; ``relax``
    multiplies every slab width) and ``_solve(direction) -> (status, x, lams)`` (minimize c . x).
    """

    name = "?"

    def __init__(self, shapes: Sequence[tuple[int, ...]]):
        self.structure = LPStructure(shapes)

    def _load(self, scaled, relax: float) -> None:
        raise NotImplementedError

    def _solve(self, direction: np.ndarray):
        raise NotImplementedError

    def box_bounds(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]) -> BoxBounds:
        st = self.structure
        n = st.n
        scaled = st.scaled(cps, tols)
        lo, hi = np.zeros(n), np.ones(n)
        count = doubts = 0
        if all(sc is None for sc in scaled):
            return BoxBounds(False, lo, hi, 0, 0)
        self._load(scaled, 1.0)
        for k in range(n):
            for sign in (1.0, -1.0):
                c = np.zeros(n)
                c[k] = sign
                status, x, lams = self._solve(c)
                count += 1
                if status == INFEASIBLE:
                    self._load(scaled, INFEASIBILITY_RELAX)
                    status2, _, _ = self._solve(c)
                    count += 1
                    if status2 == INFEASIBLE:
                        return BoxBounds(True, np.ones(n), np.zeros(n), count, doubts)
                    doubts += 1
                    return BoxBounds(False, np.zeros(n), np.ones(n), count, doubts)
                if status != OPTIMAL or not st.check(x, lams, scaled):
                    doubts += 1
                    continue
                if sign > 0:
                    lo[k] = max(0.0, x[k] - LP_BOUND_MARGIN)
                else:
                    hi[k] = min(1.0, x[k] + LP_BOUND_MARGIN)
        return BoxBounds(bool(np.any(lo > hi)), lo, hi, count, doubts)


class CvxpyBackend(LPBackend):
    """Eq. (12) modelled once in cvxpy with Parameters (DPP); solved by the named cvxpy solver."""

    #: spherekin backend name -> (cvxpy solver name, solver options)
    SOLVERS = {
        "clarabel": ("CLARABEL", {}),
        "highs": ("HIGHS", {}),
    }

    def __init__(self, shapes, name: str):
        super().__init__(shapes)
        import cvxpy as cp  # imported here: only the cvxpy backends pay for it

        self.name = name
        self._cp = cp
        self._solver, self._options = self.SOLVERS[name]
        st = self.structure
        self.x = cp.Variable(st.n)
        self.c = cp.Parameter(st.n)
        self.lams, self.ws, self.ts, cons = [], [], [], [self.x >= 0, self.x <= 1]
        for b, e, variables, g in st.equations:
            lam = cp.Variable(g.shape[1], nonneg=True)
            w = cp.Parameter(g.shape[1])
            t = cp.Parameter(nonneg=True)
            cons += [cp.sum(lam) == 1, w @ lam <= t, -t <= w @ lam]
            if variables:
                cons.append(g @ lam == self.x[list(variables)])
            self.lams.append(lam)
            self.ws.append(w)
            self.ts.append(t)
        self.problem = cp.Problem(cp.Minimize(self.c @ self.x), cons)
        assert self.problem.is_dpp()

    def _load(self, scaled, relax):
        for w, t, sc in zip(self.ws, self.ts, scaled):
            if sc is None:  # no constraint: a zero row with an infinite-like slab
                w.value = np.zeros(w.shape)
                t.value = 1.0
            else:
                w.value, t.value = sc[0], sc[1] * relax

    def _solve(self, direction):
        self.c.value = direction
        try:
            self.problem.solve(solver=self._solver, **self._options)
        except self._cp.error.SolverError:
            return OTHER, None, None
        status = self.problem.status
        if status in (self._cp.INFEASIBLE,):
            return INFEASIBLE, None, None
        if status != self._cp.OPTIMAL:
            return OTHER, None, None
        return OPTIMAL, np.asarray(self.x.value), [np.asarray(lam.value) for lam in self.lams]


class HighspyBackend(LPBackend):
    """Eq. (12) passed to HiGHS directly (highspy) with one reused model.

    The constraint matrix is built once (CSC, every w-row entry present); per box only the w-row
    values and slab bounds are overwritten, and the 2n objectives re-solve warm-started.
    """

    name = "highspy"

    def __init__(self, shapes):
        super().__init__(shapes)
        import highspy

        self._hs = highspy
        self.h = highspy.Highs()
        self.h.setOptionValue("output_flag", False)
        st = self.structure
        offsets = np.cumsum([st.n] + [g.shape[1] for *_, g in st.equations])
        self._offsets = offsets
        ncol = int(offsets[-1])
        entries = []               # (col, row, value, w-slot or -1)
        row_lo, row_hi, self._w_rows = [], [], []
        slot = 0
        for (b, e, variables, g), off in zip(st.equations, offsets[:-1]):
            nl = g.shape[1]
            r = len(row_lo)
            entries += [(off + i, r, 1.0, -1) for i in range(nl)]           # sum(lambda) = 1
            row_lo.append(1.0)
            row_hi.append(1.0)
            for k, grow in zip(variables, g):                              # G lambda - x_k = 0
                r = len(row_lo)
                entries += [(off + i, r, float(grow[i]), -1) for i in np.flatnonzero(grow)]
                entries.append((k, r, -1.0, -1))
                row_lo.append(0.0)
                row_hi.append(0.0)
            r = len(row_lo)                                                 # |w . lambda| <= tol
            entries += [(off + i, r, 0.0, slot + i) for i in range(nl)]
            self._w_rows.append(r)
            slot += nl
            row_lo.append(-1.0)
            row_hi.append(1.0)
        entries.sort(key=lambda t: (t[0], t[1]))
        cols = np.array([t[0] for t in entries])
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = ncol, len(row_lo)
        lp.col_cost_ = np.zeros(ncol)
        lp.col_lower_ = np.zeros(ncol)
        upper = np.full(ncol, highspy.kHighsInf)
        upper[: st.n] = 1.0
        lp.col_upper_ = upper
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = np.searchsorted(cols, np.arange(ncol + 1)).astype(np.int32)
        lp.a_matrix_.index_ = np.array([t[1] for t in entries], dtype=np.int32)
        self._values = np.array([t[2] for t in entries])
        slots = np.array([t[3] for t in entries])
        self._w_pos = np.flatnonzero(slots >= 0)[np.argsort(slots[slots >= 0])]
        self._row_lo, self._row_hi = np.array(row_lo), np.array(row_hi)
        self._w_cols = cols[self._w_pos].astype(np.int32)
        self._w_row_of = np.array([t[1] for t in entries], dtype=np.int32)[self._w_pos]
        lp.a_matrix_.value_ = self._values
        lp.row_lower_, lp.row_upper_ = self._row_lo, self._row_hi
        self.h.passModel(lp)
        for k, v in LP_OPTIONS.items():
            self.h.setOptionValue(k, v)

    def _load(self, scaled, relax):
        # update the w rows in place: the model (and the simplex basis of the previous box, a good
        # warm start for a neighbouring box) is kept
        h = self.h
        ws = np.concatenate([np.zeros(g.shape[1]) if sc is None else sc[0]
                             for (*_, g), sc in zip(self.structure.equations, scaled)])
        for r, c, v in zip(self._w_row_of.tolist(), self._w_cols.tolist(), ws.tolist()):
            h.changeCoeff(r, c, v)
        widths = np.array([1.0 if sc is None else sc[1] * relax for sc in scaled])
        rows = np.array(self._w_rows, dtype=np.int32)
        h.changeRowsBounds(len(rows), rows, -widths, widths)

    def _solve(self, direction):
        st, h = self.structure, self.h
        h.changeColsCost(st.n, np.arange(st.n, dtype=np.int32), direction.astype(float))
        h.run()
        status = h.getModelStatus()
        if status == self._hs.HighsModelStatus.kInfeasible:
            return INFEASIBLE, None, None
        if status != self._hs.HighsModelStatus.kOptimal:
            return OTHER, None, None
        v = np.asarray(h.getSolution().col_value)
        lams = [v[a:b] for a, b in zip(self._offsets[:-1], self._offsets[1:])]
        return OPTIMAL, v[: st.n], lams


LP_BACKENDS = ("clarabel", "highs", "highspy")

#: Backends that cvxpy offers but that cannot serve Eq. (12), with the measured reason
#: (tests/test_lp_backends.py; Gosselin boxes around a root, formulations paper and transversal).
REJECTED_LP_BACKENDS = {
    "osqp": "OSQP (ADMM) does not reach the 1e-7 feasibility every Eq. (12) answer is checked against: "
            "85-99% of its LPs were rejected as doubts, at 0.7-2.2 s per LP (highspy: ~1 ms)",
    "scs": "SCS (first-order conic) does not reach the 1e-7 feasibility every Eq. (12) answer is checked "
           "against: 25-51% of its LPs were rejected as doubts, at 0.26-1.9 s per LP (highspy: ~1 ms)",
}


def make_backend(name: str, shapes: Sequence[tuple[int, ...]]) -> LPBackend:
    """The LP backend called ``name`` (one of LP_BACKENDS), set up for the given block shapes."""
    if name in REJECTED_LP_BACKENDS:
        raise ValueError(f"lp_backend: {name!r} is not supported: {REJECTED_LP_BACKENDS[name]}; "
                         f"use one of {LP_BACKENDS}")
    if name == "highspy":
        return HighspyBackend(shapes)
    if name in CvxpyBackend.SOLVERS:
        return CvxpyBackend(shapes, name)
    raise ValueError(f"lp_backend: expected one of {LP_BACKENDS}, got {name!r}")
