"""spherekin.atomic: a file written whole or not at all."""

from __future__ import annotations

import pytest

from spherekin import atomic


def test_a_write_that_raises_leaves_the_earlier_file_and_no_temporary(tmp_path):
    out = tmp_path / "r.json"
    out.write_text("earlier")
    with pytest.raises(KeyboardInterrupt):
        with atomic.replacing(out) as tmp:
            tmp.write_text("half of the new")
            raise KeyboardInterrupt
    assert out.read_text() == "earlier"
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_a_complete_write_replaces_the_file_and_leaves_no_temporary(tmp_path):
    out = tmp_path / "r.json"
    out.write_text("earlier")
    atomic.write_text(out, "new")
    assert out.read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]
    atomic.write_text(tmp_path / "fresh.csv", "a,b\n")
    assert (tmp_path / "fresh.csv").read_text() == "a,b\n"
