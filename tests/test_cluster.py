"""spherekin.cluster: where parallel work runs (a real LocalCluster on 127.0.0.1, from conftest)."""

from __future__ import annotations

import sys
import time

import cloudpickle
import pytest

from spherekin.cluster import connect, map_in_order, n_workers


def slow_square(x):
    """x^2, slower for the early items, so that later items finish first."""
    time.sleep(0.02 * (10 - x) if x < 10 else 0)
    if x == 99:
        raise ArithmeticError("item 99")
    return x * x


@pytest.fixture
def by_value():
    """This test module's functions travel by value to the workers (they cannot import it)."""
    module = sys.modules[__name__]
    cloudpickle.register_pickle_by_value(module)
    yield
    cloudpickle.unregister_pickle_by_value(module)


def test_map_in_order_on_workers_keeps_the_order_of_the_items(dask_client, by_value):
    assert n_workers(dask_client) == 2
    assert list(map_in_order(dask_client, slow_square, range(12))) == [x * x for x in range(12)]


def test_map_in_order_here_and_a_failing_task_raises(dask_client, by_value):
    assert list(map_in_order(None, slow_square, [3, 11])) == [9, 121]
    with pytest.raises(ArithmeticError, match="item 99"):
        list(map_in_order(dask_client, slow_square, [10, 99, 11]))


@pytest.mark.parametrize("kw, match", [(dict(workers=-1), "workers: expected a whole number >= 0"),
                                       (dict(workers=True), "workers: expected"),
                                       (dict(client=object(), scheduler="tcp://x:1"), "at most one"),
                                       (dict(scheduler="nowhere"), "expected an address such as"),
                                       (dict(scheduler="tcp://127.0.0.1:notaport"), "with a port number")])
def test_bad_connections_are_named_before_any_work(kw, match):
    with pytest.raises(ValueError, match=match):
        with connect(**kw):
            pass


def test_workers_zero_is_this_process():
    with connect(workers=0) as c:
        assert c is None and n_workers(c) == 0
