"""Shared cases of tests/test_transversal.py and tests/test_krawczyk.py: mechanisms, inverse-kinematics
roots, and exact references for the transversal system (40-50 digit mpmath products, finite
differences, least-squares roots found without any solver).

Independent references used here:
* exact roots from inverse kinematics (Paden-Kahan, spherekin.mechanism), not from any solver;
* F from a 40-digit mpmath product of the defining matrices; J from central finite differences of it;
* the eight direct-kinematics roots of the Gosselin platform at the paper's inputs, found here by
  least squares on the full closure residual F - I from many starts (no solver involved).

``IMPLS``: the two implementations under test (the fast float-interval one and the mpmath
reference); they must agree on every verdict, and each must contain the exact values.
"""

import math

import numpy as np
import pytest
from mpmath import MPContext, mpf
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from spherekin.closure import Term
from spherekin.trust.krawczyk import certify, certify_reference, krawczyk, krawczyk_reference
from spherekin.mechanism import LoopSystem, general_3rrr, gosselin
from spherekin.trust.transversal import interval_transversal, interval_transversal_reference
from conftest import GOSSELIN_INPUTS, rot

#: Half-width (radians) of the passive ranges of the loop systems built around IK solutions.
RANGE_HALF_WIDTH = 1.0
#: A configuration counts as clearly regular when the smallest singular value of K_p exceeds this.
REGULAR_MARGIN = 1e-3
#: Float references (numpy matrix products) carry rounding of a few ulps of O(1) entries.
FLOAT_REF_TOL = 1e-14
#: Central difference step (radians) and its error bound (h^2 |F'''| / 6 + eps / h with |F'''| <= ~10).
FD_STEP = 1e-6
FD_TOL = 1e-8
#: Widest point enclosure (tol = 0) of F allowed: ulp-level. The fast arithmetic rounds to
#: nearest then widens one ulp (up to 1.5 ulp per operation, vs <= 1 for mpmath's directed
#: rounding) and builds cos phi from cos/sin of the constant and of the unknown (3 more
#: operations), so its enclosures are ~3x wider after the 12 factors of a general 3-RRR loop.
POINT_WIDTH = {"fast": 5e-14, "reference": 1e-14}
#: The number of direct-kinematics solutions of the paper's Gosselin example (at GOSSELIN_INPUTS).
GOSSELIN_ROOTS = 8
#: Least-squares starts tried to find the Gosselin roots (8 are found after ~30 with this seed).
ROOT_STARTS = 200
#: A least-squares end point is a root when every entry of F - I is below this (ulps of O(1) entries).
ROOT_RESIDUAL = 1e-13
#: Two roots are the same when their angles agree to this (radians, modulo 2 pi).
ROOT_SEPARATION = 1e-7
#: Step (at 50 digits) of the central differences giving the exact Jacobian: error ~h^2 ~1e-40.
MP_FD_STEP = mpf("1e-20")

IMPLS = {
    "fast": dict(certify=certify, krawczyk=krawczyk, interval_transversal=interval_transversal),
    "reference": dict(certify=certify_reference, krawczyk=krawczyk_reference,
                      interval_transversal=interval_transversal_reference),
}



def system_at(mech, sol):
    """LoopSystem at the IK solution's inputs with ranges (a - 1, a + 1) around its passive angles."""
    ja = sol.joint_angles
    return mech.loop_system(sol.inputs, {n: (ja[n] - RANGE_HALF_WIDTH, ja[n] + RANGE_HALF_WIDTH) for n in mech.passive})


def theta_of(system, sol):
    return np.array([sol.joint_angles[n] for n in system.names])


def poses(mech_name, count, seed):
    """Random poses: any rotation for the agile eye (it reaches all), small ones for the general 3-RRR."""
    if mech_name == "gosselin":
        return [Rotation.random(random_state=seed + k).as_matrix() for k in range(count)]
    rng = np.random.default_rng(seed)
    return [rot(rng.normal(size=3) * 0.3) for _ in range(count)]


MECHS = {"gosselin": gosselin, "general_3rrr": general_3rrr}


def reference_entries(system, theta):
    """(f21, f31, f32) of every loop by ClosureLoop.closure_matrix (numpy route), shape (3 * loops,)."""
    x = system.to_unit(dict(zip(system.names, theta)))
    out = []
    for loop, idx in zip(system.loops, system.loop_indices):
        f = loop.closure_matrix(x[list(idx)])
        out += [f[1, 0], f[2, 0], f[2, 1]]
    return np.array(out)


def mp_entries(system, theta, shifts=None, dps=40, twist_shifts=None):
    """(f21, f31, f32) of every loop as a dps-digit product of Rx(phi) Z (matrices from their definition).

    ``shifts``: optional iterator of amounts added to each constant angle (known angle or term
    offset), in factor order. ``twist_shifts``: optional iterator of eps per factor, in the same
    order: its Z is then the rotation by pi/2 + eps about z (a link twist off the right angle).
    """
    ctx = MPContext()
    ctx.dps = dps

    def rz(eps):
        c, s = ctx.cos(ctx.pi / 2 + eps), ctx.sin(ctx.pi / 2 + eps)
        return ctx.matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    z = ctx.matrix([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    out = []
    for loop, idx in zip(system.loops, system.loop_indices):
        f = ctx.eye(3)
        k = 0
        for fac in loop.factors:
            if isinstance(fac, Term):
                const, var = ctx.mpf(fac.offset), fac.sign * ctx.mpf(theta[idx[k]])
                k += 1
            else:
                const, var = ctx.mpf(fac), 0
            if shifts is not None:
                const += ctx.mpf(next(shifts))
            phi = const + var
            c, s = ctx.cos(phi), ctx.sin(phi)
            f = f * ctx.matrix([[1, 0, 0], [0, c, -s], [0, s, c]]) * (z if twist_shifts is None
                                                                      else rz(ctx.mpf(next(twist_shifts))))
        out += [f[1, 0], f[2, 0], f[2, 1]]
    return out


def mp_jacobian(system, theta, dps=50, twist_shifts=None):
    """Exact-to-~1e-40 Jacobian of the transversal entries: central differences of the dps-digit product
    (``twist_shifts``: a list of eps per factor, as :func:`mp_entries`)."""
    ctx = MPContext()
    ctx.dps = dps
    base = [ctx.mpf(float(v)) for v in theta]
    cols = []
    for k in range(len(base)):
        plus, minus = list(base), list(base)
        plus[k] += MP_FD_STEP
        minus[k] -= MP_FD_STEP
        tw = (lambda: None) if twist_shifts is None else (lambda: iter(twist_shifts))
        fp, fm = mp_entries(system, plus, dps=dps, twist_shifts=tw()), mp_entries(system, minus, dps=dps, twist_shifts=tw())
        cols.append([(a - b) / (2 * MP_FD_STEP) for a, b in zip(fp, fm)])
    return [[cols[k][e] for k in range(len(base))] for e in range(len(cols[0]))]


def full_closure(system, theta):
    """All entries of F_n - I of every loop (floats, straight from the definition of Eq. 2)."""
    z = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    out = []
    for loop, idx in zip(system.loops, system.loop_indices):
        f, k = np.eye(3), 0
        for fac in loop.factors:
            if isinstance(fac, Term):
                phi = fac.offset + fac.sign * theta[idx[k]]
                k += 1
            else:
                phi = fac
            c, s = math.cos(phi), math.sin(phi)
            f = f @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]) @ z
        out.append((f - np.eye(3)).ravel())
    return np.concatenate(out)


@pytest.fixture(scope="module")
def gosselin_roots():
    """(system, roots): the direct-kinematics roots at GOSSELIN_INPUTS by least squares on F - I."""
    mech = gosselin()
    system = mech.loop_system(GOSSELIN_INPUTS, {n: (-1.0, 1.0) for n in mech.passive})
    rng = np.random.default_rng(0)
    roots = []
    for _ in range(ROOT_STARTS):
        fit = least_squares(lambda th: full_closure(system, th), rng.uniform(-math.pi, math.pi, 6),
                            xtol=1e-15, ftol=1e-15, gtol=1e-15)
        x = np.mod(fit.x + math.pi, 2 * math.pi) - math.pi
        if np.abs(full_closure(system, x)).max() > ROOT_RESIDUAL:
            continue
        if not any(np.abs(np.mod(x - r + math.pi, 2 * math.pi) - math.pi).max() < ROOT_SEPARATION for r in roots):
            roots.append(x)
        if len(roots) == GOSSELIN_ROOTS:
            break
    return system, roots


def contains(interval, value, slack=0.0) -> bool:
    return mpf(interval.a) - slack <= value <= mpf(interval.b) + slack
