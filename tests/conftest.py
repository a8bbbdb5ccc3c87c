"""Shared test helpers and fixtures (pytest puts this directory on sys.path: ``from conftest import ...``).

Helpers here are small, obviously correct and independent of spherekin's own code paths (scipy's
Rotation, math.remainder, numpy), so that tests built on them compare spherekin against something
else.
"""

from __future__ import annotations

import math
import signal
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

def pytest_configure(config):
    """Ctrl-C as a user's terminal delivers it, whatever started the tests: a shell that runs a command
    in the background (``make test &`` from a script) ignores SIGINT for it, and the ignore is
    inherited by every process the tests start, so their Ctrl-C tests would see SIGINT do nothing. A
    Python handler is reset to the default in a child (exec), where Python installs KeyboardInterrupt."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


#: The long tier (tests/tiers.toml): whole modules and tests (node ids below tests/) that make test leaves out.
TIERS = tomllib.loads((Path(__file__).parent / "tiers.toml").read_text())["long"]


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Mark the long tier's tests slow (before ``-m 'not slow'`` deselects them); an entry of tests/tiers.toml
    whose module was collected but which names no test is an error (a renamed test must not slip back)."""
    modules, tests = set(TIERS["modules"]), set(TIERS["tests"])
    seen, collected = set(), set()
    for item in items:
        nodeid = item.nodeid.removeprefix("tests/")
        module, function = nodeid.split("::", 1)[0], nodeid.split("[", 1)[0]
        collected.add(module)
        hit = {e for e in (nodeid, function) if e in tests}
        if module in modules or hit:
            item.add_marker(pytest.mark.slow)
        seen |= hit
    stale = sorted(e for e in tests - seen if e.split("::", 1)[0] in collected)
    by_node = any("::" in str(a) for a in config.args)       # tests named one by one: a module only in part
    if stale and not by_node:
        raise pytest.UsageError("tests/tiers.toml names tests that were not collected: " + "; ".join(stale))


#: The paper's Gosselin example inputs (Section 5), radians.
GOSSELIN_INPUTS = (0.3, -0.2, 0.5)


def rot(rotvec) -> np.ndarray:
    """The rotation matrix of a rotation vector (axis * angle, radians), by scipy."""
    return Rotation.from_rotvec(rotvec).as_matrix()


def unit(v) -> np.ndarray:
    """v / |v| as a float array."""
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def wrap(angle: float) -> float:
    """angle modulo 2 pi in [-pi, pi] (IEEE remainder: exact)."""
    return math.remainder(angle, 2 * math.pi)


def times_linear(g, k, r):
    """Power coefficients of (x_k - r) g(x); g has degree <= 1 in x_k (its top coefficient is zero)."""
    return np.roll(g, 1, axis=k) - r * g


@pytest.fixture(scope="session")
def gosselin_report():
    """spherekin's solve of the Gosselin platform at GOSSELIN_INPUTS (default settings), computed once."""
    from spherekin import solve
    from spherekin.mechanism import gosselin

    return solve(gosselin(), GOSSELIN_INPUTS)


@pytest.fixture(scope="session")
def mech():
    """The general 3-RRR (examples/general_3rrr.toml): the mechanism most tests of the families and the
    tracker solve (frozen: one per session)."""
    from spherekin.mechanism import general_3rrr

    return general_3rrr()


@pytest.fixture
def registered():
    """``registered(REGISTRY, cls)`` registers a test strategy (``first=True``: before the others); every
    one is unregistered after the test, so that the registries are left as found (no strategy leaks into
    other tests)."""
    added = []

    def add(registry, cls, first=False):
        registry.register(cls, first=first)
        added.append((registry, cls.name))
        return cls

    yield add
    for registry, name in reversed(added):
        registry.unregister(name)


@pytest.fixture(scope="session")
def dask_client():
    """A real Dask cluster for the tests: a LocalCluster of 2 single-threaded worker processes on
    127.0.0.1 (started once per session, closed at its end)."""
    import logging

    from distributed import Client, LocalCluster

    from spherekin.cluster import HTTP_ADDRESS

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=HTTP_ADDRESS, silence_logs=logging.CRITICAL)
    client = Client(cluster)
    yield client
    client.close()
    cluster.close()


def singular_beta1(geometry, lo, hi, n_lo):
    """A general_3rrr parallel singularity in closed form: bisection on beta1 (beta2 = 0, beta3 = 0.5)
    for where the degree-8 reference's real-root count drops from n_lo (tests of both trackers)."""
    from references.peers_closed_form import direct_kinematics

    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if len(direct_kinematics(geometry, (mid, 0.0, 0.5))) == n_lo:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def kite():
    """The kite four-bar: ground AD = crank AB = 40 deg, coupler BC = rocker DC = 60 deg. At crank input
    -pi/2 (B 90 deg around A from the point towards D) B coincides with D and C can be anywhere on the
    60-degree circle around it: a continuum of assemblies (by its geometry: no solver involved); two
    isolated assemblies away from that input."""
    from spherekin.mechanism import Joint, Leg, SphericalMechanism
    from spherekin.mechanism.chains import axis_rotation, sphere_point

    a = np.array([0.0, 0.0, 1.0])
    d = np.array([math.sin(math.radians(40)), 0.0, math.cos(math.radians(40))])
    b = axis_rotation(a, math.pi / 2) @ d
    c = sphere_point(b, d, math.radians(60.0), math.radians(60.0), 1.0)
    return SphericalMechanism(legs=(Leg("crank", (Joint("A", a, actuated=True), Joint("B", b))),
                                    Leg("rocker", (Joint("D", d), Joint("C", c)))), name="kite")


def with_range(mech, name: str, rng):
    """``mech`` (a mechanism of legs) with joint ``name``'s range set to ``rng`` (lo, hi; radians)."""
    from spherekin.mechanism import Joint, Leg, SphericalMechanism

    legs = tuple(Leg(leg.name, tuple(Joint(j.name, j.axis, j.actuated, rng if j.name == name else j.range,
                                           j.reference_angle) for j in leg.joints)) for leg in mech.legs)
    return SphericalMechanism(legs, name="ranged " + mech.name, reference_leg=mech.reference_leg,
                              platform_reference=mech.platform_reference)
