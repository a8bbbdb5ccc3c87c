"""spherekin.core.groups: connected components against a breadth-first search written here."""

from __future__ import annotations

from collections import deque

from hypothesis import given, settings
from hypothesis import strategies as st

from spherekin.core.groups import connected_groups


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
