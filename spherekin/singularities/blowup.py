"""A stationary assembly's neighbourhood blown up: the singular set near it as a regular curve (issue 31).

At a stationary assembly q* (an orientation closing every input: :func:`spherekin.singularities.planes.
stationary_quaternions`, proven in rational arithmetic; the agile eye has four) the moving assemblies cross
the stationary sheet {q*} x plane transversally where D(q*, beta) = 0. There the plane system (F, D) of
:class:`spherekin.singularities.planes.PlatformPlane` is degenerate: near q* the closure forms F are small on
both sheets, the Bernstein hulls separate them only on boxes of the size of their distance (~|D(q*, beta)|),
and the box count of a cover grows like T^-2.5 instead of 1 / T (measured: the whole plane of the agile eye
did not finish at T = 0.1). No Krawczyk test can prove a crossing (the square slice's Jacobian is singular
there).

The blow-up. On the quaternion chart k of q*'s largest component (q*_k = 1), let U = u* + [-r, r]^3 (chart
coordinates, r = BLOWUP_RADIUS) and write q = q* + rho w, w = e_c + a e_c' + b e_c'' (three patches, c = the
component of largest size of q - q*; rho in [-r, r], a, b in [-1, 1]): the three patches cover U. Since
F_i(q*) = 0 exactly for every input, F_i(q* + rho w) = rho G_i with

    G_i(rho, a, b, beta) = 2 (M_i q*) . w + rho w^T M_i w      (M_i symmetrized; degree (1, 2, 2)),

and the system (G, D) on the patches has as solutions (a) for rho != 0, exactly the singular configurations of
the mechanism in U off q* (G = F / rho), and (b) for rho = 0, the points where [(M_i q*)_j] w = 0 for a w != 0:
then det [(M_i q*)_j]_(j != k) = D(q*, beta) = 0, the stationary assembly is singular: every solution is a
singular configuration, and every singular configuration in U is one (at q*: w in the kernel). The blow-up
separates the sheets (the stationary one becomes rho = 0 with w in a kernel, met only on the curve D(q*, .)
= 0), and where the crossing is transversal (the agile eye: l . (k^T M_i k) = +-1.556, helper notes) the
system is regular there: the box loop covers it with ~1/T boxes and the Krawczyk slices prove its cells.

:class:`StationaryPlane` is this system (a :class:`PlatformPlane` on the blow-up patches, no quaternion
contraction); :func:`outside` gives the start boxes of the plane system without the neighbourhoods of the
stationary assemblies (on q*'s chart U itself, on the other charts a box proven inside U), so that the two
covers together cover every singular configuration, each once.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..core import bernstein
from ..systems.platform import CHART_EXTENT
from .planes import OrientationPatch, PlatformPlane, SingularPlane

__all__ = ["BLOWUP_RADIUS", "blowup_patches", "StationaryPlane", "outside"]

#: Half-width r (quaternion chart units) of the box U = u* + [-r, r]^3 around a stationary assembly that is
#: blown up. Reason: a power of 2, so the patches' corner values q*_l + rho w_l are exact; small enough that
#: the agile eye's four stationary assemblies (2 apart on chart 0) have disjoint boxes well inside the chart
#: (|u*| = 1 < CHART_CORE - r is not needed: the patches have no contraction); large enough that outside
#: U the two sheets are >= r apart, so the plane system's cover there needs no box much below r.
BLOWUP_RADIUS = 0.125
#: A hole U' of another chart than q*'s is first tried at this fraction of BLOWUP_RADIUS, halved while its
#: corners (mapped to q*'s chart) are not all inside U, at most HOLE_TRIES times (then that chart keeps all
#: its boxes: searched, nothing lost). The chart maps are monotone per coordinate on a box where the
#: divisor keeps its sign, so the corners bound the image.
HOLE_START = 0.5
HOLE_TRIES = 4
#: Relative margin of the containment test of a hole in U and unit-coordinate shrink of every hole: the
#: chart maps and the unit coordinates round by ~1e-16; a hole a little smaller than proven only searches
#: a little more.
HOLE_MARGIN = 1e-9


def _chart_of(q: np.ndarray) -> int:
    """The quaternion chart of q's largest component (the first of equal ones)."""
    return int(np.argmax(np.abs(q)))


def blowup_patches(mats: np.ndarray, q: np.ndarray, radius: float = BLOWUP_RADIUS) -> tuple:
    """The three blow-up patches (:class:`spherekin.singularities.planes.OrientationPatch`) of the stationary
    quaternion ``q`` (4,; its largest component +-1, as :func:`stationary_quaternions` gives it): variables
    (rho, a, b) on [-radius, radius] x [-1, 1]^2, q = q* + rho w (q*_k = 1), w = e_c + a e_c' + b e_c'' for
    c = each component j != k (c', c'': the next ones, cyclically); ``quad`` = G_i (module doc) for the
    three parts of ``mats`` (3 legs, 3 parts, 4, 4). G_i = sum_lm M_lm (2 q*_l + rho w_l) w_m with M
    symmetrized: the factors are multilinear (their degree-1 nets are their corner values, exact for a
    radius that is a power of 2), their products Bernstein products (:func:`spherekin.core.bernstein.
    multiply`); ``quad_mag``: the same with every term's magnitude."""
    q = np.asarray(q, dtype=float)
    k = _chart_of(q)
    qs = q / q[k]                                                   # exact: |q_k| = 1
    others = tuple(j for j in range(4) if j != k)
    msym = 0.5 * (mats + np.swapaxes(mats, -1, -2))                   # (3 legs, 3 parts, 4, 4)
    rho = np.array([-radius, radius]).reshape(2, 1, 1)
    corner = np.array([-1.0, 1.0])
    out = []
    for c in range(3):
        w = np.zeros((4, 2, 2, 2))
        w[others[c]] = 1.0
        w[others[(c + 1) % 3]] = corner.reshape(1, 2, 1)
        w[others[(c + 2) % 3]] = corner.reshape(1, 1, 2)
        lin = qs.reshape(4, 1, 1, 1) + rho * w                        # q*_l + rho w_l at the corners
        half = 2.0 * qs.reshape(4, 1, 1, 1) + rho * w
        prod = bernstein.multiply(half[:, None], w[None, :], 3)       # (4, 4, 3, 3, 3)
        pmag = bernstein.multiply(np.abs(half)[:, None], np.abs(w)[None, :], 3)
        quad = np.einsum("iplm,lmabc->ipabc", msym, prod)
        mag = np.einsum("iplm,lmabc->ipabc", np.abs(msym), pmag)
        out.append(OrientationPatch(quad, mag, lin, others, (-radius, -1.0, -1.0), (radius, 1.0, 1.0)))
    return tuple(out)


class StationaryPlane(PlatformPlane):
    """The plane system on the blow-up patches of the stationary assemblies ``stationary`` (module doc): a
    :class:`PlatformPlane` whose patches are three per q* (chart = combination of plane charts * patches
    + patch), without the quaternion charts' contraction. Its cover, slices (``prove``), traces and empty
    tests are the plane system's; its solutions are singular configurations in the boxes U."""

    QUATERNION_CHARTS = False

    def __init__(self, mechanism, plane: SingularPlane, stationary, radius: float = BLOWUP_RADIUS):
        self.blown_up = tuple(np.asarray(q, dtype=float) for q in stationary)
        self.radius = float(radius)
        super().__init__(mechanism, plane)

    def _patches(self) -> tuple:
        return tuple(p for q in self.blown_up for p in blowup_patches(self.mats, q, self.radius))

    def cusp_charts(self, rs) -> tuple:
        raise ValueError("cusps: the blow-up patches' variables are not the orientation's (grad D in q is not "
                         "grad D in (rho, a, b)); their untraced boxes are cusp candidates instead")


def _hole(q: np.ndarray, k: int, radius: float) -> tuple | None:
    """A box (lo (3,), hi (3,), chart k's metric coordinates) of orientations inside U (the box of half-width
    ``radius`` about q on q's chart), or None: on q's chart U itself; on another chart k the box of half-width
    s about q's image, s = HOLE_START * radius halved until its corners map into U."""
    j = _chart_of(q)
    qs = q / q[j]
    if k == j:
        u = np.delete(qs, k)
        return u - radius, u + radius
    if q[k] == 0:
        return None
    u = np.delete(qs / qs[k], k)
    target = np.delete(qs, j)
    s = HOLE_START * radius
    for _ in range(HOLE_TRIES):
        lo, hi = u - s, u + s
        pos = j if j < k else j - 1                                    # chart k's variable holding q_j
        if lo[pos] > 0 or hi[pos] < 0:
            corners = np.array(list(itertools.product(*zip(lo, hi))))  # (8, 3)
            quat = np.insert(corners, k, 1.0, axis=1)
            image = np.delete(quat / quat[:, j:j + 1], j, axis=1)
            if np.abs(image - target).max() <= radius * (1.0 - HOLE_MARGIN):
                return lo, hi
        s /= 2
    return None


def outside(system: PlatformPlane, stationary, radius: float = BLOWUP_RADIUS) -> tuple:
    """Start boxes (chart (B,), lo (B, N), hi (B, N), unit coordinates) of ``system``'s cover: every chart's
    unit box without the holes about the stationary quaternions ``stationary`` (:func:`_hole`; shrunk by
    HOLE_MARGIN), the rest tiled by the grid of the holes' faces. The plane columns are whole."""
    charts = system.charts
    n_patch = len(system.patches)
    n = len(charts.variables)
    per_patch = []
    for k in range(n_patch):
        holes = []
        for q in stationary:
            h = _hole(np.asarray(q, dtype=float), k, radius)
            if h is None:
                continue
            lo = (h[0] + CHART_EXTENT) / (2 * CHART_EXTENT) + HOLE_MARGIN
            hi = (h[1] + CHART_EXTENT) / (2 * CHART_EXTENT) - HOLE_MARGIN
            holes.append((np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)))
        cuts = [np.unique(np.concatenate([[0.0, 1.0]] + [[h[0][a], h[1][a]] for h in holes])) for a in range(3)]
        boxes = []
        for cell in itertools.product(*(zip(c[:-1], c[1:]) for c in cuts)):
            lo, hi = np.array([c[0] for c in cell]), np.array([c[1] for c in cell])
            mid = 0.5 * (lo + hi)
            if not any(np.all((mid > h[0]) & (mid < h[1])) for h in holes):
                boxes.append((lo, hi))
        per_patch.append(boxes)
    chart, lo, hi = [], [], []
    for c in range(charts.n_charts):
        for blo, bhi in per_patch[c % n_patch]:
            chart.append(c)
            lo.append(np.concatenate([blo, np.zeros(n - 3)]))
            hi.append(np.concatenate([bhi, np.ones(n - 3)]))
    return np.array(chart, dtype=int), np.array(lo), np.array(hi)
