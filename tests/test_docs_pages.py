"""The site's guides (docs/*.md pages of issue 32) run as written: every ```python block of
docs/getting-started.md as a script from the checkout's root, checked against an independent
reference, and every ``spherekin`` command line of its ```sh blocks parses.

A new python block needs a check here: the test counting the blocks says so.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks.peers_closed_form import direct_kinematics, geometry_of
from spherekin.cli import build_parser, protect_negative_values
from spherekin.mechanism import gosselin

ROOT = Path(__file__).resolve().parents[1]
GETTING_STARTED = (ROOT / "docs" / "getting-started.md").read_text()
#: Seconds a block may run before its test fails (a hung script; the block takes ~2 s).
BLOCK_TIMEOUT = 300
#: Largest entry of |R - R_ref| for the same pose: the reference's eigenvalue solve is accurate to
#: ~1e-12 on this regular pose; 1e-8 leaves room and is far below the poses' separation (> 0.1).
POSE_MATCH = 1e-8


def blocks(lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", GETTING_STARTED, re.S | re.M)


def test_getting_started_python_block_runs_and_its_pose_is_a_reference_pose(tmp_path):
    """The first solve in Python: it prints the Gosselin platform's 8 solutions (the paper's count),
    and solution number 3, certified, is one of the poses of the degree-8 eigenvalue solver of
    benchmarks/peers_closed_form.py (numpy only, not spherekin's solver) at the same inputs."""
    code = blocks("python")
    assert len(code) == 1, "a new python block in docs/getting-started.md needs a check here"
    script = code[0] + "\nimport json\nprint(json.dumps(sol.platform_rotation.tolist()))\n"
    (tmp_path / "block.py").write_text(script)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, str(tmp_path / "block.py")], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=BLOCK_TIMEOUT)
    assert run.returncode == 0, run.stderr[-2000:]
    lines = run.stdout.splitlines()
    assert lines[0].startswith("8 solutions (count proven"), lines[0]
    assert any(line.startswith("certified {'gamma1'") for line in lines), run.stdout   # sol.status, sol.passive_angles
    rotation = np.array(json.loads(lines[-1]))
    references = direct_kinematics(geometry_of(gosselin()), [0.3, -0.2, 0.5])
    gaps = [np.abs(rotation - ref).max() for ref in references]
    assert min(gaps) < POSE_MATCH, f"expected solution 3's pose among the reference poses, nearest {min(gaps):.2e}"


def test_getting_started_command_lines_parse():
    lines = []
    for block in blocks("sh"):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words and Path(words[0]).name == "spherekin":
                lines.append(words[1:])
    assert lines, "expected spherekin command lines in docs/getting-started.md"
    parser = build_parser()
    for words in lines:
        try:
            parser.parse_args(protect_negative_values(words))
        except SystemExit:
            pytest.fail(f"docs/getting-started.md's `spherekin {shlex.join(words)}` does not parse")
