"""Groups of rows: connected components of a graph (union-find), and the rows of a chunk's inputs
laid out one input per row of a padded array.

The one union-find of the package: the search's merge of accepted boxes and the trust layer's
grouping of unproven entries (:func:`spherekin.core.angles.near_groups`), and the circuits of a
linkage's branches (:mod:`spherekin.batch.branches`). The one padding by owner: the engine's
comparisons of the roots of each input of a chunk with each other (pairs within an input, every
input at once).
"""

from __future__ import annotations

from typing import Iterable

import numpy as np

__all__ = ["connected_groups", "pad_by_owner"]


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


def pad_by_owner(values, owner, n_owners: int, width: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(padded, pos): the rows of ``values`` (N, ...) grouped by ``owner`` (N,) ints in [0, n_owners),
    each owner's rows in the order given: ``padded`` (n_owners, P, ...) float, NaN where an owner has
    fewer than P rows (P = ``width``, default the most rows of an owner; rows past it are left out),
    and ``pos`` (N,) the place of each row in its owner's list (``padded[owner[i], pos[i]]`` is
    ``values[i]`` when ``pos[i] < P``)."""
    values = np.asarray(values, dtype=float)
    owner = np.asarray(owner, dtype=np.intp)
    counts = np.bincount(owner, minlength=n_owners)
    order = np.argsort(owner, kind="stable")
    pos = np.empty(len(owner), dtype=np.intp)
    pos[order] = np.arange(len(owner)) - np.repeat(np.cumsum(counts) - counts, counts)
    p = int(counts.max(initial=0)) if width is None else int(width)
    padded = np.full((n_owners, p) + values.shape[1:], np.nan)
    fits = pos < p
    padded[owner[fits], pos[fits]] = values[fits]
    return padded, pos
