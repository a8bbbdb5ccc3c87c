"""Connected components of a graph on 0..n-1 given by its edges (union-find with path halving).

The one union-find of the package: the search's merge of accepted boxes and the trust layer's
grouping of unproven entries (:func:`spherekin.core.angles.near_groups`), and the circuits of a
linkage's branches (:mod:`spherekin.batch.branches`).
"""

from __future__ import annotations

from typing import Iterable

__all__ = ["connected_groups"]


def connected_groups(n: int, edges: Iterable[tuple[int, int]]) -> list[list[int]]:
    """The connected components of the graph on the vertices 0..n-1 with ``edges`` (pairs of vertices):
    lists of vertices, each in increasing order, the lists in the order of their first vertex."""
    parent = list(range(n))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in edges:
        parent[find(int(j))] = find(int(i))
    groups: dict[int, list[int]] = {}
    for k in range(n):
        groups.setdefault(find(k), []).append(k)
    return list(groups.values())
