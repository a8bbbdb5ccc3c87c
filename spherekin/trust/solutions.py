"""From clusters of accepted boxes to solutions you can trust: polish, separate, prove, classify.

The box loop (:mod:`spherekin.search.boxloop`) proves that every root inside the joint ranges lies in one
of its clusters (unions of touching boxes). A cluster is not one solution by default: next to a
singularity it may hold two roots 1e-5 apart, or none (two roots that just turned complex). For
each cluster, :func:`finalize`

1. polishes (Gauss-Newton on the full closure residuals, :mod:`spherekin.trust.polish`) from its centre
   and from up to :data:`MAX_SEEDS` of its member boxes, and keeps the distinct converged points
   that stay in the cluster (a point that polishing moves out of its cluster is the root of
   another cluster, or of none in the ranges: it is never reported as this cluster's root);
2. certifies each point by the Krawczyk test (:mod:`spherekin.trust.krawczyk`) at radii below 0.4 times
   its distance to the nearest other point, so that distinct certified points are distinct roots;
   where the float test cannot (two roots closer than ~1e-5 next to a branch or change point), by
   the same test in extended precision on equations with exact constants
   (:mod:`spherekin.trust.extended`, at most :data:`MAX_EXTENDED_TESTS` tests per input);
3. accounts for the whole cluster: a member box inside a certified box holds no other root; the
   others go through Krawczyk tests on sub-boxes (:func:`spherekin.trust.krawczyk.krawczyk_many`): a box
   whose Krawczyk image misses it holds no root and is dropped, one whose image lies inside it
   holds exactly one (a known root, or a new one, polished and added), any other is bisected, up
   to :data:`MAX_RESOLVE_BOXES` boxes per cluster. Boxes left over make the count a lower bound.

Statuses (docs/results-format.md):

* ``certified``: a Krawczyk test proves that a box around the point holds exactly one root;
* ``singular``: the point is a solution within a stated bound (polishing converged; the interval
  bound of the closure equations at the point is below :data:`SOLUTION_BOUND`) and the mechanism
  is at a singularity there (:meth:`SphericalMechanism.singularity`; the evidence has its kind
  and margins). A serial singularity is usually an isolated, certifiable root: it is proven
  (``krawczyk_certified`` in the evidence) and counts as exact. A parallel one is not isolated
  (the passive joints can move with the actuators locked) and cannot be certified: the count
  is then a lower bound;
* ``unverified``: a converged point that could not be certified nor shown singular (the evidence
  says why), or a point whose polishing did not converge;
* ``continuum``: the cluster holds a continuum of solutions (a folded mechanism, a mobile one):
  several distinct polished points spread over it, each with a rank-deficient Jacobian; the
  evidence has the estimated dimension (the nullity there), sample points and the covering boxes;
* ``cluster``: part of a cluster that could not be resolved and holds no converged point: it may
  hold roots; its box and the reason are reported.

:func:`count_summary` gives the proven count and whether the count is exact: exact when every
entry is certified, or singular with a certificate.

:func:`finalize_many` does this for a chunk of inputs at once: the common case (each cluster one
polished point, certified in floats, its hull covered) runs every stage as one array call over all
the points of the chunk, each point evaluated in its own input's equations only; any other input
goes through :func:`finalize`. Both call the same stage functions, so the answers are the same.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..closure import closure_plan
from ..core.angles import RANGE_TOL, in_range_many, into_range_many, near_groups, wrap
from .extended import EXTENDED_RADII, certify_extended, krawczyk_boxes_extended, polish_extended
from .krawczyk import (ANGLE_TOLERANCE, CERTIFY_RADII, FINE_ANGLE_TOLERANCE, BoxTests, certify_many, certify_stacked,
                       krawczyk_many, krawczyk_stacked)
from .transversal import stack_inputs, transversal_equations
from .polish import polish, polish_many
from ..results import Cluster, Solution, Status, is_proven

__all__ = ["DEDUPE_TOL", "MAX_SEEDS", "MAX_RESOLVE_BOXES", "SEPARATION_FRACTION", "SOLUTION_BOUND", "STATUSES",
           "finalize", "finalize_many", "count_summary", "is_proven"]

#: Statuses a finalized entry can have (see the module docstring and docs/results-format.md).
STATUSES = tuple(Status)
#: Entries that stand for a region rather than one point.
_REGIONS = (Status.CLUSTER, Status.CONTINUUM)
#: Converged polished points closer than this (radians, every passive angle, modulo 2 pi) are one
#: point when neither is certified (certified points are compared through their boxes and root
#: enclosures, :func:`_relation`): polished points agree to ~1e-14 and two roots this close cannot be
#: separated by the float polish anyway.
DEDUPE_TOL = 1e-8
#: Half-width (radians) of the chart of the LoopSystem that finalize evaluates: one system per
#: input, built once for every cluster. Reason: polishing and certification evaluate the loops in
#: the angles themselves (Rx(theta), cos and sin), never through the chart's t = tan((theta - shift)/2),
#: so any valid chart (width below 2 pi) gives the same equations; 1 rad around 0 is one.
LOCAL_CHART = 1.0
#: Polishing starts per cluster at most: its centre and member boxes spread evenly over it. A
#: cluster of simple roots has a few members; near a fold it has ~100, and two roots 1e-5 apart
#: need seeds on both sides; 32 seeds cost ~10 ms of polishing.
MAX_SEEDS = 32
#: A point is certified on boxes of radius at most this fraction of its distance to the nearest
#: other point, so that certified boxes of distinct points are disjoint (the roots are distinct).
SEPARATION_FRACTION = 0.4
#: Sub-boxes tested per cluster while accounting for it, beyond one test per member box. Reason: a cluster of tol-sized boxes next
#: to a fold is resolved in ~10-100 tests; the cap bounds the work on clusters that cannot be
#: resolved (at a singular input), which are then reported with a lower-bound count.
MAX_RESOLVE_BOXES = 2000
#: Krawczyk tests in extended precision (:mod:`spherekin.trust.extended`: exact constants, 50 digits)
#: per input at most (a test of a box or a radius, or one extended Newton run), for the points and
#: sub-boxes the float tests cannot decide (next to a branch, change or singular input). Reason:
#: each costs 3-20 ms (four-bar to 3-RRR); two roots 5e-8 apart in a cluster of ~300 boxes of 1e-6
#: (a four-bar 1e-8 .. 1e-16 rad from its change point) are separated, certified and the rest of the
#: cluster excluded in ~900 (3 s); the cap bounds the time an input where nothing can be separated
#: spends before its count is flagged.
MAX_EXTENDED_TESTS = 1000
#: Sub-boxes narrower than this (radians) are not bisected further: their Krawczyk images are
#: dominated by rounding (~1e-15 relative), so smaller boxes cannot decide anything new.
MIN_RESOLVE_WIDTH = 1e-13
#: Bisection point (fraction of the widest side) of a sub-box; off-centre for the same reason as
#: :data:`spherekin.search.boxloop.SPLIT_POINT` (symmetric roots must not stay on box faces).
RESOLVE_SPLIT = 0.4917
#: A singular value of the Jacobian below this fraction of the largest (or of 1) counts as zero
#: when estimating the dimension of a continuum: on a continuum the polished points reach
#: residuals ~1e-15 and their null directions singular values ~1e-15; a regular root has ~1e-3+.
NULLITY_RCOND = 1e-8
#: A cluster is a continuum when at least this many distinct polished points, spread over at least
#: CONTINUUM_MIN_SPREAD radians, all have a rank-deficient Jacobian. Reason: polishing converges
#: linearly to a double root, and its points scatter by ~sqrt(1e-12) = 1e-6 rad, not 1e-4.
CONTINUUM_MIN_POINTS = 3
CONTINUUM_MIN_SPREAD = 1e-4
#: Non-proven entries whose boxes are within this many tolerances of each other are one region
#: the solver could not resolve (next to a singular input: the ghost of a complex pair leaves a
#: valley of near-solutions, polished to several look-alike points) and are reported as one
#: ``cluster`` entry; distinct assemblies of a mechanism are ~1e-3 rad apart or more.
NEARBY_TOLS = 100.0
#: A ``singular`` point must be a solution within this bound: the interval bound of the closure
#: equations at the polished point (certify's ``residual``). Polished points reach ~1e-15; 1e-12 is
#: polish's own convergence threshold (:data:`spherekin.trust.polish.CONVERGED_TOL`).
SOLUTION_BOUND = 1e-12


class _Point:
    """A polished point of a cluster (angles unwrapped next to the cluster) and what is known of it."""

    __slots__ = ("theta", "polished", "seed_moved", "cert", "box", "enc", "evidence")

    theta: np.ndarray
    polished: object
    seed_moved: float
    cert: object                      # the Krawczyk result at the point, or None
    box: tuple | None                 # (lo, hi) holding exactly this root, when certified
    enc: tuple | None                 # (lo, hi) a tight enclosure of that root: K(box), inside box
    evidence: dict

    def __init__(self, theta, polished, seed_moved, cert=None, box=None, enc=None, evidence=None):
        self.theta = theta
        self.polished = polished
        self.seed_moved = seed_moved
        self.cert = cert
        self.box = box
        self.enc = enc
        self.evidence = {} if evidence is None else evidence


class _Extended:
    """The extended-precision tests of one input (:mod:`spherekin.trust.extended`), within a budget of
    MAX_EXTENDED_TESTS; ``None`` answers once the budget is spent or the system is not the
    mechanism's own unknowns."""

    __slots__ = ("mechanism", "inputs", "names", "left")

    def __init__(self, mechanism, inputs, names):
        self.mechanism = mechanism
        self.inputs = inputs
        self.names = tuple(names)
        self.left = MAX_EXTENDED_TESTS if self.names == tuple(mechanism.loop_unknowns) else 0

    def certify(self, theta, radii):
        """A KrawczykResult of the extended test at ``radii`` (ascending), or None (budget spent)."""
        if self.left <= 0:
            return None
        radii = [r for r in EXTENDED_RADII if r <= max(radii)] or list(radii)
        self.left -= len(radii)
        return certify_extended(self.mechanism, self.inputs, dict(zip(self.names, theta)), radii)

    def polish(self, theta):
        """The root Newton converges to in extended precision from ``theta`` (floats), or None."""
        if self.left <= 0:
            return None
        self.left -= 1
        return polish_extended(self.mechanism, self.inputs, dict(zip(self.names, theta)))

    def boxes(self, lo, hi):
        """BoxTests of the boxes [lo, hi] (B, M) in extended precision, or None (budget spent)."""
        if self.left < len(lo):
            return None
        self.left -= len(lo)
        return krawczyk_boxes_extended(self.mechanism, self.inputs, lo, hi)


def count_summary(solutions) -> tuple[int, bool]:
    """(proven count, exact): the number of proven roots, and whether that is all there is."""
    proven = sum(is_proven(s) for s in solutions)
    return proven, proven == len(solutions)


def _contains(lo, hi, p) -> bool:
    return bool(np.all(lo <= p) and np.all(p <= hi))


def _inside_any(boxes, lo, hi) -> bool:
    return any(bool(np.all(blo <= lo) and np.all(hi <= bhi)) for blo, bhi in boxes)


def _seeds(sol: Cluster) -> np.ndarray:
    """The cluster's centre (unwrapped next to its hull) then up to MAX_SEEDS - 1 member centres."""
    centre = 0.5 * (sol.lo + sol.hi)
    if sol.members is None or len(sol.members) <= 1:
        return centre[None]
    mids = 0.5 * (sol.members[:, 0] + sol.members[:, 1])
    if len(mids) > MAX_SEEDS - 1:
        # spread along the cluster's main direction: sort by the projection on it, take evenly
        d = mids - mids.mean(axis=0)
        axis = np.linalg.svd(d, full_matrices=False)[2][0] if np.any(d) else np.ones(d.shape[1])
        order = np.argsort(d @ axis)
        mids = mids[order[np.linspace(0, len(mids) - 1, MAX_SEEDS - 1).round().astype(int)]]
    return np.vstack((centre[None], mids))


def _resolve(system, sol: Cluster, points: list[_Point], certify_fn, stats: dict, extended=None) -> list:
    """Account for every member box of the cluster; returns the boxes left unresolved [(lo, hi)].

    Adds the roots found on the way to ``points`` (certified on the sub-box that isolated them).
    Sub-boxes the float test leaves undecided are tested again in extended precision (``extended``,
    an :class:`_Extended`, while its budget lasts) before they are bisected.
    """
    members = sol.members if sol.members is not None else np.array([[sol.lo, sol.hi]])
    certified = [p.box for p in points if p.box is not None]
    # fast path (a simple root): the whole hull, tested at the one certified point
    if len(points) == 1 and points[0].box is not None and np.any(sol.hi > sol.lo):
        # X = the hull and the point's certified box (so that X holds that root, not just the float y)
        y = points[0].theta
        xlo, xhi = np.minimum(sol.lo, points[0].box[0]), np.maximum(sol.hi, points[0].box[1])
        test = krawczyk_many(system, xlo[None], xhi[None], y[None], angle_tolerance=FINE_ANGLE_TOLERANCE)
        stats["tests"] += 1
        if test.certified[0]:
            points[0].evidence["covers_cluster"] = True
            return []
    queue = [(m[0], m[1]) for m in members if not _inside_any(certified, m[0], m[1])]
    unresolved = []
    while queue:
        if stats["tests"] >= MAX_RESOLVE_BOXES + len(members):
            unresolved += queue
            stats["capped"] = True
            break
        thin = [b for b in queue if np.max(b[1] - b[0]) < MIN_RESOLVE_WIDTH]
        unresolved += thin
        queue = [b for b in queue if np.max(b[1] - b[0]) >= MIN_RESOLVE_WIDTH]
        if not queue:
            break
        batch, queue = queue[:256], queue[256:]
        lo = np.array([b[0] for b in batch])
        hi = np.array([b[1] for b in batch])
        test = krawczyk_many(system, lo, hi, angle_tolerance=FINE_ANGLE_TOLERANCE)
        stats["tests"] += len(batch)
        if extended is not None:
            test = _retest_extended(extended, test, lo, hi, certified, stats)
        for i, (blo, bhi) in enumerate(batch):
            if _inside_any(certified, blo, bhi) or test.no_solution[i]:
                stats["excluded" if test.no_solution[i] else "covered"] += 1
                continue
            if test.certified[i]:
                # B holds exactly one root r_B, in K(B). A known root r_p lies in its enclosure E_p:
                # E_p inside B means r_B = r_p (covered); E_p missing K(B) for every p means r_B is
                # new; an E_p that meets K(B) without lying inside B leaves it undecided (bisect)
                kb = (test.krawczyk_lo[i], test.krawczyk_hi[i])
                known = [p for p in points if p.enc is not None and _inside_any([(blo, bhi)], *p.enc)]
                if known:
                    certified.append((blo, bhi))
                    continue
                touching = [p for p in points if p.enc is not None and np.all(p.enc[0] <= kb[1])
                            and np.all(kb[0] <= p.enc[1])]
                new = None if touching else _new_root(system, blo, bhi, kb[0], kb[1], certify_fn, extended)
                if new is not None:
                    points.append(new)
                    certified.append((blo, bhi))
                    stats["new_roots"] += 1
                    continue
            w = bhi - blo
            axis = int(np.argmax(w))
            mid = blo[axis] + RESOLVE_SPLIT * w[axis]
            left_hi, right_lo = bhi.copy(), blo.copy()
            left_hi[axis] = mid
            right_lo[axis] = mid
            queue += [(blo, left_hi), (right_lo, bhi)]
    return unresolved


def _retest_extended(extended, test: BoxTests, lo, hi, certified, stats: dict) -> BoxTests:
    """``test`` with its undecided boxes (neither certified nor without solution, not inside a
    certified box) tested again in extended precision; the decided ones replace the float verdicts."""
    undecided = [i for i in range(len(lo)) if not (test.certified[i] or test.no_solution[i])
                 and not _inside_any(certified, lo[i], hi[i])]
    if not undecided:
        return test
    ext = extended.boxes(lo[undecided], hi[undecided])
    if ext is None:
        return test
    stats["extended_tests"] = stats.get("extended_tests", 0) + len(undecided)
    out = BoxTests(test.certified.copy(), test.no_solution.copy(), test.krawczyk_lo.copy(), test.krawczyk_hi.copy())
    for j, i in enumerate(undecided):
        if ext.certified[j] or ext.no_solution[j]:
            out.certified[i], out.no_solution[i] = ext.certified[j], ext.no_solution[j]
            out.krawczyk_lo[i], out.krawczyk_hi[i] = ext.krawczyk_lo[j], ext.krawczyk_hi[j]
    return out


def _float_certificates(run, n: int) -> list:
    """The float certificates of n points: ``run(indices, angle_tolerance)`` (the results of those
    points) at the default angle tolerance, then, for each whose K(X) was computed but not inside X,
    at the finer one (:data:`spherekin.trust.krawczyk.FINE_ANGLE_TOLERANCE`); one result per point."""
    certs = list(run(list(range(n)), ANGLE_TOLERANCE))
    again = [i for i, c in enumerate(certs) if not c.certified and c.krawczyk_box is not None and not c.no_solution]
    if again:
        for i, f in zip(again, run(again, FINE_ANGLE_TOLERANCE)):
            if f.certified:
                certs[i] = f
    return certs


def _certify_with_fallback(certify_fn, system, thetas, radii, extended=None) -> list:
    """``certify_fn`` on the points ``thetas`` at the default angle tolerance, then, for each whose
    K(X) was computed but not inside X, at the finer one (:data:`spherekin.trust.krawczyk.FINE_ANGLE_TOLERANCE`),
    then in extended precision (``extended``, an :class:`_Extended`, at radii up to the largest of
    ``radii``; the evidence records which: ``angle_tolerance`` 0); one result per point, in order."""
    if not len(thetas):
        return []
    certs = _float_certificates(lambda idx, t: certify_fn(system, [thetas[i] for i in idx], radii=radii,
                                                          angle_tolerance=t), len(thetas))
    if extended is not None:
        for i, c in enumerate(certs):
            if not c.certified and c.krawczyk_box is not None and not c.no_solution:
                e = extended.certify(thetas[i], radii)
                if e is not None and e.certified:
                    certs[i] = e
    return certs


def _new_root(system, lo, hi, k_lo, k_hi, certify_fn, extended=None):
    """The one root of a sub-box whose Krawczyk image lies inside it: polished from the image's centre."""
    start = 0.5 * (k_lo + k_hi)
    p = polish(system.loops, system.unknowns, start)
    if not (p.converged and _contains(k_lo, k_hi, p.theta)):
        return None
    point = _Point(np.asarray(p.theta, float), p, float(np.abs(p.theta - start).max()),
                   evidence={"found_by": "Krawczyk test on a sub-box of the cluster"})
    point.box = (lo, hi)
    point.enc = (np.asarray(k_lo, float), np.asarray(k_hi, float))
    half = 0.5 * float(np.min(hi - lo))
    point.cert = _certify_with_fallback(certify_fn, system, [point.theta],
                                        [r for r in CERTIFY_RADII if r <= half] or [half], extended)[0]
    return point


def finalize(mechanism, inputs, names, clusters, tol, certify=None, refine=None, extended=None) -> list[Solution]:
    """Polish, separate, prove and classify the clusters found for ``mechanism`` at ``inputs``.

    ``names``: the passive unknowns (order of ``Solution.angles``); ``clusters``: :class:`~spherekin.results.Cluster` s of the
    box loop (with their member boxes when known); ``tol``: the solver tolerance (radians);
    ``certify(system, thetas, radii=..., angle_tolerance=...)``: the batch certification function,
    one result per point (default :func:`spherekin.trust.krawczyk.certify_many`; the points of every
    cluster are certified together). ``refine(lo, hi, tol)``, optional: the clusters of a new
    search of the box [lo, hi] at a finer tolerance, as ``(clusters, finer_tol)``, or None when
    there is none; a cluster that cannot be resolved is replaced by the clusters of that search
    (recursively) before it is reported as unresolved. ``extended``: whether points and sub-boxes
    the float tests cannot decide are tested in extended precision (:mod:`spherekin.trust.extended`);
    default: when ``certify`` is the default (an injected ``certify`` stands for all certification).
    Returns the entries sorted by angles; see the module docstring for the statuses and
    :func:`count_summary` for the count.
    """
    if extended is None:
        extended = certify is None
    if certify is None:
        certify = certify_many
    out = []
    if clusters:
        system = _system_of(mechanism, inputs, names)
        ext = _Extended(mechanism, inputs, names) if extended else None
        out = _finalize_clusters(mechanism, system, inputs, names, clusters, tol, certify, refine, ext)
    return _tail(out, tol)


def _tail(entries: list, tol: float) -> list:
    """An input's entries with the roots found twice kept once (:func:`_unique`), the nearby unproven
    ones merged (:func:`_merge_nearby_unproven`), sorted by angles (rounded to 1e-9)."""
    unique = _merge_nearby_unproven(_unique(entries), tol)
    unique.sort(key=lambda s: tuple(np.round(s.angles, 9)))
    return unique


def finalize_many(mechanism, inputs, names, clusters, tol, refine=None) -> list[list[Solution]]:
    """:func:`finalize` for a chunk of K inputs at once: ``inputs`` (K, number of actuated joints;
    radians), ``clusters[k]`` the clusters found at ``inputs[k]`` (as finalize takes them),
    ``refine``: None or ``refine(k)``, the ``refine`` callable of input k (or None). Returns, for
    every k, what ``finalize(mechanism, inputs[k], names, clusters[k], tol, refine=refine(k))``
    returns (default certification, extended precision where it needs it).

    The common case runs over every point of the chunk at once: every cluster whose seeds polish
    to one point that the float Krawczyk test certifies, whose hull that test covers (or whose
    members lie in the certified box), and whose entries are distinct roots. Each stage is one
    array call over all such points, each point evaluated only with its own input's constants
    (:class:`~spherekin.trust.transversal.SystemStack`, an input-index column): polishing
    (:func:`~spherekin.trust.polish.polish_many`), certification
    (:func:`~spherekin.trust.krawczyk.certify_stacked`, :func:`~spherekin.trust.krawczyk.krawczyk_stacked`),
    classification (:meth:`~spherekin.mechanism.SphericalMechanism.singularities`). An input with any
    other cluster (one to resolve, refine, a continuum, a point not certified in floats) goes
    through :func:`finalize` whole. Both paths call the same stage functions, and a stage gives a
    point the same floats alone or in a chunk.
    """
    values = np.asarray(inputs, dtype=float)
    n_act = len(mechanism.actuated)
    if values.size == 0:
        values = values.reshape(0, n_act)                # an empty chunk
    if values.ndim != 2 or values.shape[1] != n_act:
        raise ValueError(f"inputs: expected shape (K, {n_act}) (one row of actuator angles per input), "
                         f"got {values.shape}")
    if len(clusters) != len(values):
        raise ValueError(f"clusters: expected one sequence of clusters per input ({len(values)}), got {len(clusters)}")
    names = tuple(names)
    out: list = [[] for _ in values]
    todo = [k for k in range(len(values)) if len(clusters[k])]
    fast = _fast_entries(mechanism, values, names, clusters, todo, tol) if todo else {}
    for k in todo:
        if k in fast:
            out[k] = fast[k]
        else:
            out[k] = finalize(mechanism, tuple(float(v) for v in values[k]), names, clusters[k], tol,
                              refine=refine(k) if refine is not None else None)
    return out


def _fast_entries(mechanism, values, names, clusters, todo, tol) -> dict:
    """input k -> its entries, for the inputs of ``todo`` whose clusters all take the common case
    of :func:`finalize_many`; the others are left out (finalize answers them)."""
    stack = stack_inputs(mechanism, values[todo], _chart(names))
    sols = [sol for k in todo for sol in clusters[k]]
    n_cl = len(sols)
    cl_in = np.repeat(np.arange(len(todo)), [len(clusters[k]) for k in todo])     # stack index of each cluster
    lo = np.array([sol.lo for sol in sols], dtype=float)
    hi = np.array([sol.hi for sol in sols], dtype=float)
    centre = 0.5 * (lo + hi)
    # 1. polish every seed of every cluster (the centre; member boxes of clusters of several)
    many = {c: _seeds(sol) for c, sol in enumerate(sols) if sol.members is not None and len(sol.members) > 1}
    n_seeds = np.ones(n_cl, dtype=int)
    seeds = centre
    if many:
        n_seeds[list(many)] = [len(v) for v in many.values()]
        seeds = np.concatenate([many[c] if c in many else centre[c:c + 1] for c in range(n_cl)])
    seed_cl = np.repeat(np.arange(n_cl), n_seeds)
    batch, theta, outside = _polish_seeds(stack.closure, stack.consts[cl_in[seed_cl]], seeds, centre[seed_cl],
                                          lo[seed_cl], hi[seed_cl], tol)
    valid = batch.converged & ~outside
    left = np.bincount(seed_cl, weights=batch.converged & outside, minlength=n_cl).astype(int)
    first = np.full(n_cl, -1)
    idx = np.flatnonzero(valid)
    with_valid, at = np.unique(seed_cl[idx], return_index=True)                  # first valid seed of each
    first[with_valid] = idx[at]
    # one point per cluster: every valid seed within DEDUPE_TOL of the cluster's first one (_polish_cluster)
    far = valid & (np.abs(theta - theta[first[seed_cl]]).max(axis=1) > DEDUPE_TOL)
    ok = (first >= 0) & (np.bincount(seed_cl, weights=far, minlength=n_cl) == 0)
    ok &= _all_per_input(ok, cl_in, len(todo))[cl_in]
    # 2. certify the points (one per cluster) at CERTIFY_RADII (no other point to keep apart)
    cand = np.flatnonzero(ok)
    pts = theta[first[cand]]
    certs = _float_certificates(lambda i, t: certify_stacked(stack, cl_in[cand][i], pts[i], list(CERTIFY_RADII), t),
                                len(cand))
    ok[cand] = [c.certified for c in certs]
    cert_of = dict(zip(cand.tolist(), certs))
    # 3. account for each cluster (_resolve): the hull with the certified box in one Krawczyk test,
    #    or (a cluster of one point) every member box inside the certified box
    ok &= _all_per_input(ok, cl_in, len(todo))[cl_in]
    cand = np.flatnonzero(ok)
    box = np.array([cert_of[c].box for c in cand], dtype=float).reshape(len(cand), len(names), 2)
    hull = np.any(hi[cand] > lo[cand], axis=1)
    tests = np.zeros(n_cl, dtype=int)
    if hull.any():
        c_h = cand[hull]
        test = krawczyk_stacked(stack, cl_in[c_h], np.minimum(lo[c_h], box[hull, :, 0]),
                                np.maximum(hi[c_h], box[hull, :, 1]), theta[first[c_h]], FINE_ANGLE_TOLERANCE)
        ok[c_h] = test.certified
        tests[c_h] = 1
    if (~hull).any():
        c_p = cand[~hull]
        mem = [sols[c].members if sols[c].members is not None else np.array([[sols[c].lo, sols[c].hi]]) for c in c_p]
        mem_cl = np.repeat(np.arange(len(c_p)), [len(m) for m in mem])
        mem = np.concatenate(mem).astype(float)
        b = box[~hull][mem_cl]
        out_of_box = ~(np.all(b[:, :, 0] <= mem[:, 0], axis=1) & np.all(mem[:, 1] <= b[:, :, 1], axis=1))
        ok[c_p] = np.bincount(mem_cl, weights=out_of_box, minlength=len(c_p)) == 0
    ok &= _all_per_input(ok, cl_in, len(todo))[cl_in]
    # 4. classify every point of the inputs kept, all at once, and build their entries
    cand = np.flatnonzero(ok)
    if not len(cand):
        return {}
    keep, angles = _readings(mechanism, names, theta[first[cand]])
    sings, poses = _classify_many(mechanism, values[todo], cl_in[cand[keep]], names, angles[keep])
    stats = dict(tests=0, excluded=0)
    entries: dict = {int(j): [] for j in np.unique(cl_in[cand])}
    for n, (c, i) in enumerate(zip(cand[keep], np.flatnonzero(keep))):
        sol, cert, s0 = sols[c], cert_of[c], first[c]
        pt = _Point(theta[s0], batch.result(s0), float(np.abs(theta[s0] - seeds[s0]).max()), cert=cert,
                    box=tuple(np.array(v) for v in zip(*cert.box)),
                    enc=tuple(np.array(v) for v in zip(*cert.krawczyk_box)))
        if tests[c]:
            pt.evidence["covers_cluster"] = True
        stats["tests"] = int(tests[c])
        ev = _cluster_evidence(sol, int(n_seeds[c]), 1, stats, 0, int(left[c]))
        entries[int(cl_in[c])].append(_classify(sol, pt, names, angles[i], ev, [], sings[n],
                                                None if poses is None else poses[n]))
    # 5. the tail of finalize: with every pair of an input's entries distinct roots, _unique keeps
    #    them all and there is nothing unproven to merge; else finalize's own tail
    flat = [e for j in sorted(entries) for e in entries[j]]
    owner = np.array([j for j in sorted(entries) for _ in entries[j]])
    clash = _not_all_distinct(flat, owner)
    order = _sort_order(flat, owner)                       # by owner first: each input's run in order
    runs = np.split(order, np.cumsum([len(entries[j]) for j in sorted(entries)])[:-1])
    return {todo[j]: _tail(entries[j], tol) if clash.get(j, False) else [flat[i] for i in run]
            for j, run in zip(sorted(entries), runs)}         # an input whose roots all left its ranges: none


def _all_per_input(flags, of, n: int) -> np.ndarray:
    """(n,) whether every flag of each input is set (``of``: the input of each flag)."""
    return np.bincount(of, weights=~np.asarray(flags, bool), minlength=n) == 0


def _not_all_distinct(entries: list, owner) -> dict:
    """input -> whether some pair of its proven entries is not shown distinct by :func:`_relation`
    (later entry against earlier, as :func:`_unique` compares them), for all pairs at once."""
    owner = np.asarray(owner)
    clash = {int(j): False for j in np.unique(owner)}
    if len(entries) < 2:
        return clash
    ang = np.array([e.angles for e in entries])
    box_lo = np.array([e.lo for e in entries])
    box_hi = np.array([e.hi for e in entries])
    enc = [_enclosure(e) for e in entries]
    enc_lo = np.array([a for a, _ in enc])
    enc_hi = np.array([b for _, b in enc])
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
    counts = np.diff(np.r_[starts, len(owner)])
    pairs = [(starts[counts > b] + a, starts[counts > b] + b) for b in range(1, counts.max()) for a in range(b)]
    if not pairs:
        return clash
    u = np.concatenate([p[0] for p in pairs])
    e = np.concatenate([p[1] for p in pairs])
    d = ang[e] - ang[u]
    k = d - wrap(d)
    ee_lo, ee_hi, be_lo, be_hi = enc_lo[e] - k, enc_hi[e] - k, box_lo[e] - k, box_hi[e] - k
    same = (np.all(box_lo[u] <= ee_lo, axis=1) & np.all(ee_hi <= box_hi[u], axis=1)) | \
           (np.all(be_lo <= enc_lo[u], axis=1) & np.all(enc_hi[u] <= be_hi, axis=1))
    distinct = (np.any(ee_hi < box_lo[u], axis=1) | np.any(box_hi[u] < ee_lo, axis=1)) | \
               (np.any(enc_hi[u] < be_lo, axis=1) | np.any(be_hi < enc_lo[u], axis=1))
    for j in np.unique(owner[e[same | ~distinct]]):
        clash[int(j)] = True
    return clash


def _sort_order(entries: list, owner) -> np.ndarray:
    """Indices of ``entries`` by owner, then by angles rounded to 1e-9 (finalize's order), stably."""
    if not entries:
        return np.zeros(0, int)
    keys = np.round(np.array([e.angles for e in entries]), 9)
    return np.lexsort(tuple(keys.T[::-1]) + (np.asarray(owner),))


def _system_of(mechanism, inputs, names):
    """The LoopSystem finalize evaluates at ``inputs``: every unknown on the chart LOCAL_CHART."""
    return mechanism.loop_system(inputs, _chart(names))


def _chart(names) -> dict:
    """Every unknown on the chart of half-width LOCAL_CHART around 0."""
    return {n: (-LOCAL_CHART, LOCAL_CHART) for n in names}


def _shifted(box, e: Solution, ref: Solution):
    """The box (lo, hi) of entry ``e`` moved by the whole turns that bring e's angles next to ref's."""
    d = e.angles - ref.angles
    k = d - wrap(d)
    return np.asarray(box[0]) - k, np.asarray(box[1]) - k


def _enclosure(e: Solution):
    enc = e.evidence.get("root_enclosure")
    return (np.array(enc["lo"]), np.array(enc["hi"])) if enc else (e.lo, e.hi)


def _relation(e: Solution, u: Solution) -> str:
    """Whether two proven entries hold the "same" root, "distinct" roots, or it is "unknown".

    Each certified box holds exactly one root, which lies in its enclosure (K(X)): an enclosure
    inside the other's box puts both roots in that box (same); an enclosure outside it cannot hold
    the other's root (distinct). Nothing weaker: two roots 6e-9 apart are both certified in extended
    precision (the agile eye next to a singular line), so nearness of the points proves nothing.
    """
    enc_e, box_e = _shifted(_enclosure(e), e, u), _shifted((e.lo, e.hi), e, u)
    enc_u, box_u = _enclosure(u), (u.lo, u.hi)
    if _inside_any([box_u], *enc_e) or _inside_any([box_e], *enc_u):
        return "same"
    if _disjoint(enc_e, box_u) or _disjoint(enc_u, box_e):
        return "distinct"
    return "unknown"


def _unique(entries: list) -> list:
    """The entries with the roots found twice (from two clusters: a refined search of a hull can reach
    a neighbour's root) kept once. A proven entry is dropped when it holds the same root as one kept
    (:func:`_relation`) and loses its proof when that cannot be decided; an entry that is not proven
    is dropped when its point lies in a proven entry's box (the one root there is that entry's) or
    within DEDUPE_TOL of another unproven point."""
    unique: list[Solution] = []
    for e in sorted(entries, key=lambda e: not is_proven(e)):
        if e.status in _REGIONS:
            unique.append(e)
            continue
        kept = [u for u in unique if u.status not in _REGIONS]
        if is_proven(e):
            relations = [_relation(e, u) for u in kept if is_proven(u)]
            if "same" in relations:
                continue
            if "unknown" in relations:
                e = dataclasses.replace(e, status=Status.UNVERIFIED, evidence={
                    **e.evidence, "krawczyk_certified": False,
                    "reason": "its certified box overlaps another certified box without either enclosing the "
                              "other's root: it may be the same root"})
        elif any(_inside_any([(u.lo, u.hi)], *_shifted((e.angles, e.angles), e, u)) for u in kept if is_proven(u)) \
                or any(not is_proven(u) and np.abs(wrap(e.angles - u.angles)).max() <= DEDUPE_TOL for u in kept):
            continue
        unique.append(e)
    return unique


def _merge_nearby_unproven(entries: list, tol: float) -> list:
    """Non-proven entries (not continua) whose boxes lie within NEARBY_TOLS * tol of each other
    (modulo 2 pi) merged into one ``cluster`` entry each (see :func:`_merge_unproven`)."""
    idx = [i for i, e in enumerate(entries) if not is_proven(e) and e.status != Status.CONTINUUM]
    if len(idx) < 2:
        return entries
    lo = np.array([entries[i].lo for i in idx])
    hi = np.array([entries[i].hi for i in idx])
    chosen = set(idx)
    out = [e for i, e in enumerate(entries) if i not in chosen]
    for members in near_groups(lo, hi, NEARBY_TOLS * tol):
        group = [entries[idx[k]] for k in members]
        if len(group) == 1:
            out += group
            continue
        ref = group[0]
        shifted = [dataclasses.replace(e, lo=e.lo - (e.angles - ref.angles - wrap(e.angles - ref.angles)),
                                       hi=e.hi - (e.angles - ref.angles - wrap(e.angles - ref.angles)))
                   for e in group]
        out += _merge_unproven(shifted, ref, tol)
    return out


def _polish_seeds(plan, offsets, seeds, centre, lo, hi, tol: float):
    """Polish the seeds (S, M) of clusters at once (:func:`spherekin.trust.polish.polish_many`; seed s
    with the constants ``offsets[s]``, None: the plan's). ``centre``, ``lo``, ``hi`` (S, M): the hull
    of each seed's cluster. Returns (the PolishBatch, the polished points (S, M) unwrapped next to
    their cluster's centre, whether each lies outside its cluster by more than tol + RANGE_TOL)."""
    batch = polish_many(plan, seeds, offsets)
    theta = centre + wrap(batch.theta - centre)
    slack = tol + RANGE_TOL
    outside = np.any(theta < lo - slack, axis=1) | np.any(theta > hi + slack, axis=1)
    return batch, theta, outside


def _polish_cluster(system, sol: Cluster, tol: float):
    """(distinct converged points that stay in the cluster, how many left it, the best point) from
    polishing the cluster's seeds (:func:`_seeds`)."""
    seeds = _seeds(sol)
    centre = np.broadcast_to(0.5 * (sol.lo + sol.hi), seeds.shape)
    plan = closure_plan(system.loops, system.unknowns, system.loop_indices)
    batch, thetas, outside = _polish_seeds(plan, None, seeds, centre, np.broadcast_to(sol.lo, seeds.shape),
                                           np.broadcast_to(sol.hi, seeds.shape), tol)
    points: list[_Point] = []
    left_cluster = 0
    best = None
    for i, (seed, theta) in enumerate(zip(seeds, thetas)):
        if best is None or batch.residual[i] < best[1].residual:
            best = (theta, batch.result(i), float(np.abs(theta - seed).max()))
        if not batch.converged[i]:
            continue
        if outside[i]:
            left_cluster += 1
            continue
        if any(np.abs(theta - q.theta).max() <= DEDUPE_TOL for q in points):
            continue
        points.append(_Point(theta, batch.result(i), float(np.abs(theta - seed).max())))
    return points, left_cluster, best


def _certify_all(certify_fn, system, groups: list[list[_Point]], extended=None) -> None:
    """Certify every point of every cluster (``groups``: the points of each cluster), each at the
    radii below SEPARATION_FRACTION of its distance to the nearest other point of its cluster; one
    batch call per distinct list of radii (usually one for the whole input)."""
    by_radii: dict[tuple, list[_Point]] = {}
    for points in groups:
        for i, pt in enumerate(points):
            sep = min((np.abs(pt.theta - q.theta).max() for j, q in enumerate(points) if j != i), default=math.inf)
            radii = [r for r in CERTIFY_RADII if r <= SEPARATION_FRACTION * sep] or [SEPARATION_FRACTION * sep]
            by_radii.setdefault(tuple(radii), []).append(pt)
    for radii, pts in by_radii.items():
        certs = _certify_with_fallback(certify_fn, system, [pt.theta for pt in pts], list(radii), extended)
        for pt, cert in zip(pts, certs):
            pt.cert = cert
            if cert.certified:
                pt.box = tuple(np.array(v) for v in zip(*cert.box))
                pt.enc = tuple(np.array(v) for v in zip(*cert.krawczyk_box))


def _disjoint(a, b) -> bool:
    """Whether the boxes a = (lo, hi) and b share no point."""
    return bool(np.any(a[1] < b[0]) or np.any(b[1] < a[0]))


def _sharpen(certify_fn, system, points: list[_Point], extended) -> list[_Point]:
    """A cluster's points with those the float tests could not certify polished again in extended
    precision (:func:`spherekin.trust.extended.polish_extended`) and certified there.

    Next to a branch or change point the float polish leaves a valley of near-solutions (residuals
    ~1e-15 spread over ~1e-7) around two roots ~1e-8 apart; Newton in extended precision converges
    from them to the roots themselves. Each distinct root it reaches replaces the points that led to
    it, unless a certified box already holds it; a new root counts (box set) only when its certified
    box and the enclosure of its root miss every other certified box and enclosure (so that distinct
    certified boxes hold distinct roots). Points Newton does not converge from stay as they were.
    """
    if extended is None or all(p.box is not None for p in points):
        return points
    proven = [p for p in points if p.box is not None]
    stay, new = [], []
    for p in points:
        if p.box is not None:
            continue
        theta = extended.polish(p.theta)
        if theta is None:
            stay.append(p)
            continue
        # next to the cluster, as p, by whole turns: the same root reached from two points is then the
        # same floats (p.theta + wrap(theta - p.theta) rounds differently for each p: one root kept twice)
        theta = theta - 2 * math.pi * np.round((theta - p.theta) / (2 * math.pi))
        if _inside_any([q.box for q in proven], theta, theta) or any(np.array_equal(theta, q.theta) for q in new):
            continue                                                    # a root already in hand
        new.append(_Point(theta, p.polished, p.seed_moved + float(np.abs(theta - p.theta).max()),
                          evidence={"polished_in_extended_precision": True}))
    if not new:
        return points
    anchors = proven + new
    for pt in new:
        sep = min((np.abs(pt.theta - q.theta).max() for q in anchors if q is not pt), default=math.inf)
        radii = [r for r in EXTENDED_RADII if r <= SEPARATION_FRACTION * sep] or [SEPARATION_FRACTION * sep]
        pt.cert = _certify_with_fallback(certify_fn, system, [pt.theta], radii, extended)[0]
        if pt.cert.certified:
            box = tuple(np.array(v) for v in zip(*pt.cert.box))
            enc = tuple(np.array(v) for v in zip(*pt.cert.krawczyk_box))
            if all(_disjoint(box, q.enc) and _disjoint(enc, q.box) for q in anchors if q.box is not None):
                pt.box, pt.enc = box, enc
    return proven + new + stay


def _finalize_clusters(mechanism, system, inputs, names, clusters, tol, certify, refine, extended=None) -> list[Solution]:
    """The entries of ``clusters``: polish each, certify all their points together, then account
    for each cluster and classify its points."""
    out: list[Solution] = []
    todo = []
    for sol in clusters:
        points, left_cluster, best = _polish_cluster(system, sol, tol)
        cont = _continuum(system, sol, points, names)
        if cont is not None:
            out.append(cont)
        else:
            todo.append((sol, points, left_cluster, best))
    _certify_all(certify, system, [points for _, points, _, _ in todo], extended)
    todo = [(sol, _sharpen(certify, system, points, extended), left, best) for sol, points, left, best in todo]
    for sol, points, left_cluster, best in todo:
        out += _account(mechanism, system, inputs, names, sol, tol, certify, refine, points, left_cluster, best,
                        extended)
    return out


def _account(mechanism, system, inputs, names, sol, tol, certify, refine, points, left_cluster, best,
             extended=None) -> list[Solution]:
    """One cluster's entries from its certified points: the rest of the cluster accounted for
    (:func:`_resolve`), searched again finer when unresolved, its points classified."""
    stats = dict(tests=0, excluded=0, covered=0, new_roots=0, capped=False)
    unresolved = _resolve(system, sol, points, certify, stats, extended)
    refined_empty = None
    if unresolved and refine is not None:
        finer = refine(sol.lo, sol.hi, tol)
        if finer is not None:
            subs, finer_tol = finer
            out = _finalize_clusters(mechanism, system, inputs, names, subs, finer_tol, certify, refine, extended)
            for e in out:
                e.evidence.setdefault("refined", []).insert(0, {"tol": tol, "cluster_boxes": sol.n_boxes,
                                                                "to_tol": finer_tol})
            if out or not points:
                return _merge_unproven(out, sol, tol)
            # The finer search let go of every box, yet polishing converged in this cluster: the
            # two disagree, so neither is a proof; the region is reported, never dropped (issue 26)
            refined_empty = finer_tol
    cluster_ev = _cluster_evidence(sol, len(_seeds(sol)), len(points), stats, len(unresolved), left_cluster,
                                   refined_empty)
    kept = []
    if points:
        keep, angles = _readings(mechanism, names, np.array([pt.theta for pt in points]))
        sings, poses = _classify_many(mechanism, np.array([inputs], dtype=float), np.zeros(int(keep.sum()), int),
                                      names, angles[keep])
        for j, i in enumerate(np.flatnonzero(keep)):
            kept.append(_classify(sol, points[i], names, angles[i], cluster_ev, unresolved, sings[j],
                                  None if poses is None else poses[j]))
    if unresolved and all(is_proven(s) for s in kept):   # else a non-proven entry already says so
        kept.append(_cluster_entry(sol, unresolved, cluster_ev, stats, best))
    return kept


def _merge_unproven(entries: list, sol: Cluster | Solution, tol: float) -> list:
    """The entries of one cluster's refined search, with its non-proven entries merged into one.

    Next to a singular input a refined search can leave several sub-clusters, each with a point of
    residual below 1e-12 along a valley of near-solutions (the ghost of a complex pair) or with
    one of two roots too close to separate. They are one region the solver could not resolve: one
    ``cluster`` entry, its points listed in the evidence, instead of a list of look-alike entries.
    """
    proven = [e for e in entries if is_proven(e)]
    other = [e for e in entries if not is_proven(e)]
    if len(other) <= 1:
        return entries
    lo = np.min([e.lo for e in other], axis=0)
    hi = np.max([e.hi for e in other], axis=0)
    points = [dict(angles=[float(a) for a in e.angles], status=str(e.status), residual=e.residual) for e in other]
    ev = {"reason": (f"next to a singularity, {len(other)} nearby entries (tol {tol:g}) could not be proven: converged points that could not be certified or separated, or boxes that could "
                     "not be excluded; the region may hold none, one or several roots"),
          "candidates": points[:16], "refined": other[0].evidence.get("refined", [])}
    best = min(other, key=lambda e: e.residual if e.residual is not None else math.inf)
    merged = Solution(best.angles, lo, hi, sol.n_boxes, residual=best.residual, status=Status.CLUSTER, evidence=ev)
    return proven + [merged]


def _cluster_evidence(sol, n_seeds: int, n_points: int, stats: dict, n_unresolved: int, left_cluster: int,
                      refined_empty=None) -> dict:
    """The ``cluster`` evidence of a cluster's entries: its boxes, seeds, points, sub-box tests."""
    ev = {"cluster_boxes": sol.n_boxes, "seeds": n_seeds, "points": n_points,
          "subbox_tests": stats["tests"], "subboxes_excluded": stats["excluded"],
          "unresolved_boxes": n_unresolved}
    if stats.get("extended_tests"):
        ev["extended_precision_tests"] = stats["extended_tests"]
    if left_cluster:
        ev["polished_out_of_cluster"] = int(left_cluster)
    if refined_empty is not None:
        ev["refined_search_empty"] = {"tol": refined_empty}
    return ev


def _readings(mechanism, names, thetas):
    """(keep (N,), angles (N, M)): whether each point (N, M; radians, unknowns ``names``) lies in the
    joint ranges (every angle, modulo 2 pi), and its angles wrapped into them."""
    ranges = mechanism.ranges
    wrapped = wrap(np.asarray(thetas, dtype=float).reshape(len(thetas), len(names)))
    keep = np.ones(len(wrapped), bool)
    angles = np.empty_like(wrapped)
    for j, n in enumerate(names):
        keep &= in_range_many(wrapped[:, j], ranges[n])
        angles[:, j] = into_range_many(wrapped[:, j], ranges[n])
    return keep, angles


def _classify_many(mechanism, inputs, of, names, angles):
    """(singularity reports, poses (N, 3, 3) or None) at N points: ``angles`` (N, M; radians, unknowns
    ``names``) at the inputs ``inputs[of]`` ((K, actuated) radians, ``of`` (N,) ints), in one call each
    (:meth:`~spherekin.mechanism.SphericalMechanism.singularities`, ``poses_from_passive``)."""
    if not len(angles):
        return [], None
    at = np.asarray(inputs, dtype=float)[of]
    passive = {n: angles[:, j] for j, n in enumerate(names)}
    joints = {**{n: at[:, i] for i, n in enumerate(mechanism.actuated)}, **passive}
    return mechanism.singularities(joints), mechanism.poses_from_passive(at, passive)


def _classify(sol, pt: _Point, names, theta, cluster_ev: dict, unresolved, sing, pose) -> Solution:
    """The entry of a polished point ``pt`` of cluster ``sol``: ``theta`` (M,) its angles in the
    joint ranges, ``sing`` its singularity report and ``pose`` its platform rotation (or None)."""
    p, cert = pt.polished, pt.cert
    ev = {"polish_iterations": p.iterations, "polish_residual": p.residual, "moved": pt.seed_moved,
          **pt.evidence, "serial_margin": float(sing.serial_margin), "parallel_margin": float(sing.parallel_margin),
          "singularity": sing.kind, "krawczyk_certified": bool(cert.certified), "krawczyk": cert.summary(),
          "cluster": dict(cluster_ev)}
    theta = np.array(theta, dtype=float)
    proven = pt.box is not None       # a Krawczyk test proved a box holding exactly this root
    ev["krawczyk_certified"] = proven
    if proven and sing.kind == "regular":
        status = Status.CERTIFIED
    elif proven or (sing.kind != "regular" and cert.residual <= SOLUTION_BOUND):
        status = Status.SINGULAR
        if not proven:
            ev["reason"] = (f"a solution within {cert.residual:.1e} (interval bound of the closure equations) "
                            f"at a {sing.kind} singularity; not isolated, so not certified")
    else:
        status = Status.UNVERIFIED
        ev["reason"] = f"Krawczyk test failed: {cert.reason}"
        if unresolved:
            ev["reason"] += f"; {len(unresolved)} boxes of its cluster could not be resolved (it may hold more roots)"
    lo, hi = pt.box if pt.box is not None else (sol.lo, sol.hi)
    shift = theta - pt.theta
    if proven and pt.enc is not None:
        # where the root is, in the box's frame: what tells two proven entries apart (_unique)
        ev["root_enclosure"] = {"lo": (pt.enc[0] + shift).tolist(), "hi": (pt.enc[1] + shift).tolist()}
    return Solution(theta, lo + shift, hi + shift, sol.n_boxes, residual=p.residual,
                    singularity=sing.kind, platform_rotation=pose,
                    status=status, evidence=ev)


def _nullity(system, theta) -> int:
    """Dimension of the null space of the float Jacobian of the transversal system at ``theta``."""
    _, jac = transversal_equations(system, theta)
    m = jac.shape[1]
    sv = np.linalg.svd(jac, compute_uv=False)
    return int(m - np.sum(sv > NULLITY_RCOND * max(sv[0], 1.0)))


def _continuum(system, sol, points: list, names) -> Solution | None:
    """A ``continuum`` entry when the cluster's polished points spread over a set of non-isolated roots."""
    if len(points) < CONTINUUM_MIN_POINTS:
        return None
    thetas = np.array([p.theta for p in points])
    spread = float(np.max(thetas.max(axis=0) - thetas.min(axis=0)))
    if spread < CONTINUUM_MIN_SPREAD:
        return None
    dims = [_nullity(system, t) for t in thetas]
    if min(dims) < 1:
        return None
    members = sol.members if sol.members is not None else np.array([[sol.lo, sol.hi]])
    ev = {"dimension": int(np.median(dims)), "nullity_at_samples": dims,
          "sample_points": [dict(zip(names, (float(a) for a in wrap(t)))) for t in thetas[:8]],
          "sample_residuals": [float(p.polished.residual) for p in points[:8]],
          "spread": spread, "covering_boxes": [[m[0].tolist(), m[1].tolist()] for m in members],
          "reason": (f"{len(points)} distinct polished solutions spread over {spread:.3g} rad, each with a "
                     f"{int(np.median(dims))}-dimensional null space of the Jacobian: a continuum of solutions, "
                     f"covered by {len(members)} boxes")}
    return Solution(wrap(thetas[0]), sol.lo, sol.hi, sol.n_boxes, residual=float(points[0].polished.residual),
                    status=Status.CONTINUUM, evidence=ev)


def _cluster_entry(sol, unresolved, cluster_ev, stats, best) -> Solution:
    lo = np.min([b[0] for b in unresolved], axis=0)
    hi = np.max([b[1] for b in unresolved], axis=0)
    ev = {"cluster": dict(cluster_ev),
          "reason": (f"{len(unresolved)} boxes of this cluster could neither be excluded nor shown to hold a known "
                     "root" + (f" (the cap of {MAX_RESOLVE_BOXES} sub-box tests was reached)" if stats["capped"]
                               else "") + "; polishing found no converged root in them: they may hold roots")}
    if best is not None:
        ev.update(best_residual=float(best[1].residual), polish_iterations=best[1].iterations)
    centre = 0.5 * (lo + hi)
    return Solution(wrap(centre), lo, hi, sol.n_boxes, residual=float(best[1].residual) if best else None,
                    status=Status.CLUSTER, evidence=ev)
