"""spherekin.budget: a run's stop flag and memory cap (issue 40 item 5)."""

from __future__ import annotations

import psutil
import pytest

from spherekin.budget import MEMORY, MEMORY_FRACTION, Budget, default_max_memory


def test_the_first_reason_is_kept():
    b = Budget(max_memory=None)
    assert b.exhausted() is None
    b.stop("SIGINT")
    b.stop("SIGTERM")
    assert b.exhausted() == b.reason == "SIGINT"


def test_the_memory_cap_is_the_resident_memory():
    """A cap below what this process holds stops at once; one far above it does not; None is no cap."""
    rss = psutil.Process().memory_info().rss
    assert Budget(max_memory=rss // 2).exhausted() == MEMORY
    assert Budget(max_memory=rss * 1000).exhausted() is None
    assert Budget(max_memory=None).exhausted() is None


def test_the_default_cap_is_a_fraction_of_the_machine():
    assert default_max_memory() == pytest.approx(MEMORY_FRACTION * psutil.virtual_memory().total, rel=1e-6)
    assert Budget().max_memory == default_max_memory()
