"""Every time and count the pages quote for a documented command is the one benchmarks/doc_numbers.json holds.

Issue 42 item 13: the README's "about 0.1 s" was 0.55-0.79 s wall on a 2-core machine, a mode change's
"7-10 s" 58 s, and the paper chart's 11,082 boxes / 83,410 LPs had drifted to 11,096 / 83,539. The
numbers now come from one generated file (``python -m benchmarks.doc_numbers``, which runs each
documented command and reads its counts and strategy back from the command's own JSON report); this
test reads each quote off its page and compares it with the file, so a page that drifts (or a file
regenerated without updating the page) fails here.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NUMBERS = ROOT / "benchmarks" / "doc_numbers.json"


def seconds(value: float) -> str:
    """A time as the pages write it: two significant digits (0.53 -> "0.53", 21.4 -> "21", 153 -> "150")."""
    return f"{float(f'{value:.2g}'):g}"


def count(value: int) -> str:
    return f"{value:,}"


def rate(value: float) -> str:
    """A rate as the pages write it: two significant digits, thousands separated (5249.9 -> "5,200")."""
    return f"{float(f'{value:.2g}'):,.0f}"


def ratio(value: float) -> str:
    """A ratio with two significant digits (1.239 -> "1.2", 12.15 -> "12")."""
    return f"{float(f'{value:.2g}'):g}"


#: (page, pattern with named groups, {group: (run id, key path, formatter)}). The pattern is searched
#: with whitespace runs matching any whitespace (a quote may wrap).
QUOTES = [
    ("README.md", r"in about (?P<cpu>[\d.]+) s of CPU time \((?P<wall>[\d.]+) s wall",
     {"cpu": ("make-run", "cpu_median_s", seconds), "wall": ("make-run", "wall_median_s", seconds)}),
    ("docs/getting-started.md", r"in about (?P<cpu>[\d.]+) s of CPU time for the whole process \((?P<wall>[\d.]+) s "
     r"wall; the solve itself (?P<solve>[\d.]+) s",
     {"cpu": ("make-run", "cpu_median_s", seconds), "wall": ("make-run", "wall_median_s", seconds),
      "solve": ("make-run", "solve_median_s", seconds)}),
    ("docs/howto/paper-configuration.md", r"# (?P<cpu>[\d.]+) s of CPU time, (?P<n>\d+) solutions",
     {"cpu": ("paper-chart-highspy", "cpu_median_s", seconds), "n": ("paper-chart-highspy", "solutions", str)}),
    ("docs/howto/paper-configuration.md", r"the same takes (?P<cpu>[\d.]+) s of CPU time \((?P<boxes>[\d,]+) boxes, "
     r"(?P<lps>[\d,]+) LPs; with highspy (?P<boxes_h>[\d,]+) boxes, (?P<lps_h>[\d,]+) LPs\)",
     {"cpu": ("paper-chart-clarabel", "cpu_median_s", seconds), "boxes": ("paper-chart-clarabel", "boxes", count),
      "lps": ("paper-chart-clarabel", "lps", count), "boxes_h": ("paper-chart-highspy", "boxes", count),
      "lps_h": ("paper-chart-highspy", "lps", count)}),
    ("README.md", r"about (?P<g>[\d,]+) certified solves per second for general_3rrr \((?P<gf>[\d.]+) times the "
     r"uncertified degree-8 eigen solve, (?P<gb>[\d.]+) times the box search it falls back to next to singularities\) "
     r"and (?P<e>[\d,]+) per second for the agile eye",
     {"g": ("engine-throughput", "engine.general_3rrr.engine_per_s", rate),
      "gf": ("engine-throughput", "engine.general_3rrr.engine_over_floor", ratio),
      "gb": ("engine-throughput", "engine.general_3rrr.engine_over_boxes", ratio),
      "e": ("engine-throughput", "engine.gosselin.engine_per_s", rate)}),
    ("README.md", r"at most 2 assemblies\): (?P<four>[\d,]+) and (?P<five>[\d,]+) certified solves per second",
     {"four": ("engine-throughput", "engine.four-bar.engine_per_s", rate),
      "five": ("engine-throughput", "engine.five-bar.engine_per_s", rate)}),
    ("docs/howto/maps-singularities.md", r"solution (?P<a>\d+) comes back as solution (?P<b>\d+) after (?P<steps>\d+) "
     r"proven steps, without crossing a singularity \((?P<cpu>[\d.]+) s of CPU time in all",
     {"a": ("mode-change", "mode_change.start_solution", str), "b": ("mode-change", "mode_change.end_solution", str),
      "steps": ("mode-change", "mode_change.proven_steps", str), "cpu": ("mode-change", "cpu_median_s", seconds)}),
]


@pytest.fixture(scope="module")
def numbers() -> dict:
    return json.loads(NUMBERS.read_text())


def _value(numbers: dict, run: str, key: str):
    value = numbers["runs"][run]
    for part in key.split("."):
        value = value[part]
    return value


@pytest.mark.parametrize("page, pattern, groups", QUOTES, ids=[f"{q[0]}:{'+'.join(q[2])}" for q in QUOTES])
def test_a_quoted_number_is_the_generated_files(numbers, page, pattern, groups):
    text = " ".join((ROOT / page).read_text().split())
    found = re.search(pattern.replace(" ", r"\s+"), text)
    assert found, f"{page}: the quote {pattern!r} is not on the page (reworded? keep the quote and this test together)"
    for group, (run, key, shown) in groups.items():
        want = shown(_value(numbers, run, key))
        assert found.group(group) == want, f"{page}: {group} is {found.group(group)}, {NUMBERS.name} holds {want} ({run}.{key})"


def test_the_file_says_what_ran_and_where(numbers):
    """Each quoted number is pinned: the machine, the command, and the strategy read back from the report."""
    assert {"cpu", "cores", "python", "numpy", "date"} <= set(numbers["machine"])
    for run in ("make-run", "paper-chart-highspy", "paper-chart-clarabel"):
        got = numbers["runs"][run]
        assert got["repeats"] >= 3 and got["command"].startswith("spherekin solve "), run
        assert got["strategy"]["tol"] and got["strategy"]["system"], run
    assert numbers["runs"]["paper-chart-clarabel"]["strategy"]["lp_backend"] == "clarabel"
    assert numbers["runs"]["paper-chart-highspy"]["strategy"]["formulation"] == "paper"
    engine = numbers["runs"]["engine-throughput"]["engine"]
    for mech in ("general_3rrr", "gosselin"):                  # the throughput quoted: the complete count's
        assert engine[mech]["system"] == "complete" and engine[mech]["strategy"]["formulation"] == "complete"
        assert engine[mech]["inputs"] == 4096 and engine[mech]["repeats"] == 3
    for mech in ("four-bar", "five-bar"):                      # and the one-loop count's, each at its own chunk
        assert engine[mech]["system"] == "complete-loop" and engine[mech]["chunk"] >= 1
        assert engine[mech]["inputs"] == 4096 and engine[mech]["repeats"] == 3


def test_seconds_are_shown_with_two_significant_digits():
    assert [seconds(v) for v in (0.534, 0.055, 21.4, 153.0, 1.0)] == ["0.53", "0.055", "21", "150", "1"]
