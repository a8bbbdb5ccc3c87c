"""Families of inputs against references that are not spherekin's solver: the degree-8 eigenvalue
solver of the 3-RRR (references/peers_closed_form.py, numpy only) for the counts of a map, and the
poses themselves for inputs made by inverse kinematics."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from references.peers_closed_form import direct_kinematics, geometry_of
from spherekin import batch

#: Two poses of the reference closer than this (largest entry) would make its count ambiguous; such
#: grid points (next to a parallel singularity, where two modes meet) are left out of the comparison.
REFERENCE_SEPARATION = 1e-3


def test_map_counts_are_the_real_roots_of_the_degree_8_reference(mech):
    amap = batch.assembly_map(mech, "beta1=-3:3:11", "beta2=-3:3:11", {"beta3": 0.5}, workers=0)
    geometry = geometry_of(mech)
    compared = 0
    for i, b1 in enumerate(amap.x.values):
        for j, b2 in enumerate(amap.y.values):
            poses = direct_kinematics(geometry, (b1, b2, 0.5))
            gaps = [np.abs(p - q).max() for a, p in enumerate(poses) for q in poses[a + 1:]]
            if gaps and min(gaps) < REFERENCE_SEPARATION:
                continue
            compared += 1
            assert amap.solutions[i, j] == len(poses), (b1, b2)
    assert compared >= 110                 # nearly every point is well separated
    assert set(amap.histogram()) >= {0, 2, 4, 6}      # the grid crosses singularities: the count changes
    assert (amap.certified == amap.solutions).all()


def test_ik_then_batch_finds_the_original_pose_of_100_random_poses(mech, dask_client):
    rots, inputs = [], []
    for k, r in enumerate(Rotation.random(400, random_state=2026).as_matrix()):
        modes = mech.inverse_kinematics(r)
        if modes and len(rots) < 100:           # a pose some leg cannot reach has no input
            rots.append(r)
            inputs.append(modes[k % len(modes)].inputs)   # a working mode of each kind in turn
    assert len(rots) == 100
    inputs = np.array(inputs)
    frame = batch.solve_many(mech, inputs, client=dask_client, chunk_size=13)
    cols = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
    for k, r in enumerate(rots):
        got = frame.loc[frame["input"] == k, cols].to_numpy(dtype=float).reshape(-1, 3, 3)
        assert len(got) and np.abs(got - r).max(axis=(1, 2)).min() < 1e-9, k
