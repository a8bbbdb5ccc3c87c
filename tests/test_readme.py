"""The README, a front page: its python block runs as a script (tests/doc_blocks.py) and what it prints is
checked against an independent derivation; its size stays that of a front page. Its ``make`` lines are
the Makefile's targets. (The guides' blocks: tests/test_docs_pages.py and tests/test_howto.py.)
"""

from __future__ import annotations

import ast
import re

import numpy as np

from references.peers_closed_form import direct_kinematics, geometry_of
from doc_blocks import ROOT, blocks, page_text, run_script
from spherekin.mechanism import general_3rrr, gosselin

#: Two poses of the degree-8 reference closer than this (largest entry) make its count ambiguous
#: (an input next to a parallel singularity); as in tests/test_batch_reference.py.
REFERENCE_SEPARATION = 1e-3
#: Largest entry of |R - R_ref| for the same pose: the block prints R rounded to 9 decimals (5e-10),
#: the reference's eigenvalue solve is accurate to ~1e-12 there; far below the poses' separation (> 0.1).
POSE_MATCH = 1e-8
#: The README is a front page (issue 32): under this many lines; the guide is in docs/.
README_MAX_LINES = 120


def random_inputs(code: str) -> np.ndarray:
    """The inputs a block draws: ``np.random.default_rng(SEED).uniform(-np.pi, np.pi, (K, 3))``."""
    m = re.search(r"default_rng\((\d+)\)\.uniform\(-np\.pi, np\.pi, \((\d+), 3\)\)", code)
    assert m, "the block's random inputs are not drawn as the test expects: update random_inputs"
    return np.random.default_rng(int(m[1])).uniform(-np.pi, np.pi, (int(m[2]), 3))


def reference_counts(inputs) -> tuple[np.ndarray, np.ndarray]:
    """(real assemblies of the general 3-RRR at each input by the degree-8 eigenvalue solver of
    references/peers_closed_form.py (numpy only, not spherekin's solver), whether that count is
    unambiguous there)."""
    geometry = geometry_of(general_3rrr())
    counts, clear = [], []
    for x in inputs:
        poses = direct_kinematics(geometry, x)
        gaps = [np.abs(p - q).max() for a, p in enumerate(poses) for q in poses[a + 1:]]
        counts.append(len(poses))
        clear.append(not gaps or min(gaps) >= REFERENCE_SEPARATION)
    return np.array(counts), np.array(clear)


def test_readme_is_a_front_page():
    assert len(page_text("README.md").splitlines()) < README_MAX_LINES


def test_readme_python_block_runs_and_prints_the_reference_poses_and_counts(tmp_path):
    """The Gosselin platform at the paper's inputs: 8 solutions (the paper's count), solution number 3
    certified and one of the poses of the degree-8 eigenvalue solver (references/peers_closed_form.py,
    numpy only); then, over the block's random inputs, the number of proven assemblies of the general
    3-RRR at each one equals that solver's count of real poses (every input far from a singularity)."""
    code = blocks("README.md", "python")
    assert len(code) == 1, "a new python block in the README needs a check here"
    proc = run_script(tmp_path, code[0])
    assert proc.returncode == 0, proc.stderr[-3000:]
    count_line, solution_line, counts_line = proc.stdout.strip().splitlines()
    assert count_line.startswith("8 solutions (count proven"), count_line
    status, rotation = solution_line.split(" ", 1)
    assert status == "certified"
    rotation = np.array(ast.literal_eval(rotation))
    gaps = [np.abs(rotation - ref).max() for ref in direct_kinematics(geometry_of(gosselin()), [0.3, -0.2, 0.5])]
    assert min(gaps) < POSE_MATCH, f"expected solution 3's pose among the reference poses, nearest {min(gaps):.2e}"
    counts, clear = reference_counts(random_inputs(code[0]))
    assert clear.all()
    assert ast.literal_eval(counts_line) == counts.tolist()


def test_readme_make_lines_are_makefile_targets():
    targets = set(re.findall(r"^([\w-]+):", (ROOT / "Makefile").read_text(), re.M))
    lines = [line.split("#")[0].split() for block in blocks("README.md", "sh") for line in block.splitlines()]
    assert lines and all(words[0] == "make" and set(words[1:]) <= targets for words in lines if words), lines
