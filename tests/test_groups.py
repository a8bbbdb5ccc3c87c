"""spherekin.core.groups: connected components against a breadth-first search written here; the
padding by owner against a loop."""

from __future__ import annotations

from collections import deque

from hypothesis import given, settings
from hypothesis import strategies as st

import numpy as np

from spherekin.core.groups import connected_groups, pad_by_owner


def components_by_bfs(n, edges):
    adjacent = {k: set() for k in range(n)}
    for i, j in edges:
        adjacent[i].add(j)
        adjacent[j].add(i)
    seen, out = set(), []
    for start in range(n):
        if start in seen:
            continue
        part, queue = [], deque([start])
        seen.add(start)
        while queue:
            k = queue.popleft()
            part.append(k)
            for m in adjacent[k] - seen:
                seen.add(m)
                queue.append(m)
        out.append(sorted(part))
    return out


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 12).flatmap(lambda n: st.tuples(
    st.just(n), st.lists(st.tuples(st.integers(0, max(n - 1, 0)), st.integers(0, max(n - 1, 0))),
                         max_size=0 if n == 0 else 20))))
def test_the_groups_are_the_components_in_the_order_of_their_first_vertex(case):
    n, edges = case
    assert connected_groups(n, edges) == components_by_bfs(n, edges)


def test_a_chain_joins_transitively_and_an_isolated_vertex_stays_alone():
    assert connected_groups(5, [(3, 1), (1, 0)]) == [[0, 1, 3], [2], [4]]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 5), max_size=40), st.one_of(st.none(), st.integers(0, 6)))
def test_pad_by_owner_lays_each_owners_rows_out_in_order(owners, width):
    values = np.arange(len(owners) * 2, dtype=float).reshape(-1, 2) + 0.5
    padded, pos = pad_by_owner(values, owners, 6, width)
    per = {k: [i for i, o in enumerate(owners) if o == k] for k in range(6)}
    p = max((len(v) for v in per.values()), default=0) if width is None else width
    assert padded.shape == (6, p, 2)
    for k, rows in per.items():
        for place in range(p):
            if place < len(rows):
                assert padded[k, place].tolist() == values[rows[place]].tolist()
                assert pos[rows[place]] == place
            else:
                assert np.isnan(padded[k, place]).all()
