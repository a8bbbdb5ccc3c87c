"""The site's pages run as written (issue 32: every code block of the README and of the guides is
executed by a test). Here: the block count of every page (so that a new block needs a check), the
python blocks of docs/getting-started.md and docs/mechanism-format.md (each checked against an
independent reference), and every ``spherekin`` command line of every page's ```sh blocks: each one
parses with the real parser, and each cheap one runs (a few seconds) and writes the files it names;
the expensive ones (a minute or more, or a cluster) are only parsed, each with its reason in
PARSE_ONLY. The README's python block: tests/test_readme.py; the how-to guides': tests/test_howto.py.
"""

from __future__ import annotations

import json
import re
import shlex

import numpy as np
import pytest

from references.peers_closed_form import direct_kinematics, geometry_of
from doc_blocks import ROOT, blocks, command_lines, doc_pages, page_text, run_command, run_script
from spherekin.cli import build_parser, protect_negative_values
from spherekin.mechanism import general_3rrr, gosselin

#: Largest entry of |R - R_ref| for the same pose: the reference's eigenvalue solve is accurate to
#: ~1e-12 on these regular poses; 1e-8 leaves room and is far below the poses' separation (> 0.1).
POSE_MATCH = 1e-8

#: Per page: its number of ```python and ```sh blocks. A page not listed has none. A new block needs
#: a check (python: tests/test_readme.py, tests/test_howto.py or here; sh: its spherekin lines are
#: parsed and run below, or listed in PARSE_ONLY) before it is counted here.
BLOCKS = {
    "README.md": {"python": 1, "sh": 1},
    "docs/development.md": {"python": 0, "sh": 1},
    "docs/getting-started.md": {"python": 1, "sh": 2},
    "docs/index.md": {"python": 0, "sh": 1},
    "docs/mechanism-format.md": {"python": 3, "sh": 0},
    "docs/howto/families.md": {"python": 1, "sh": 2},
    "docs/howto/maps-singularities.md": {"python": 1, "sh": 6},
    "docs/howto/own-mechanism.md": {"python": 1, "sh": 2},
    "docs/howto/paper-configuration.md": {"python": 2, "sh": 2},
    "docs/howto/strategy.md": {"python": 2, "sh": 0},
    "docs/howto/tracking.md": {"python": 2, "sh": 2},
    "docs/howto/tolerances.md": {"python": 1, "sh": 1},
}
#: Fenced blocks that are not code to run: output shown, file formats (a yaml block: tests/test_cluster.py), Sphinx directives.
NOT_CODE = {"text", "toml", "json", "yaml", "{toctree}", "{eval-rst}", "{include}", "{literalinclude}"}

#: Command lines of the docs that are parsed but not run, and why (the rest run: a few seconds each).
PARSE_ONLY = {
    "batch examples/general_3rrr.toml --grid beta1=-pi:pi:64 --grid beta2=-pi:pi:64 --fix beta3=0.5 "
    "--out results.csv": "4,096 inputs: an embedded cluster, about a minute",
    "batch examples/general_3rrr.toml --grid beta1=-pi:pi:64 --grid beta2=-pi:pi:64 --grid beta3=-pi:pi:64 "
    "--out workspace.parquet --scheduler tcp://head:8786": "needs a Dask cluster at tcp://head:8786",
    "map examples/general_3rrr.toml --grid beta1=-pi:pi:64 --grid beta2=-pi:pi:64 --fix beta3=0.5 "
    "--singularity --plot map.png --table map.csv": "4,096 inputs, about a minute (the README's figure)",
    "singular examples/general_3rrr.toml --x beta1=-pi:pi --y beta2=-pi:pi --fix beta3=0.5 --tol 0.1 "
    "--json singular.json --plot singular.png": "the whole plane, ~80 s (tests/test_singular.py covers the cover)",
    "singular examples/general_3rrr.toml --x beta1=1.5:1.7 --y beta2=0:0.2 --fix beta3=0.5 --tol 0.1 "
    "--mode-change": "~10 s (tests/test_cusps.py covers the mode change)",
    "map examples/general_3rrr.toml --grid beta1=0.9:1.4:6 --grid beta2=1.1:1.6:6 --fix beta3=0.5 --singular "
    "--singular-tol 0.1 --plot map_singular.png": "~8 s, the cover of the page's python block, which runs it "
    "(tests/test_howto.py; map --singular itself: tests/test_batch_maps.py)",
    "singular examples/general_3rrr.toml --x beta1=-0.5:0.5 --y beta2=-0.5:0.5 --fix beta3=0.5 --tol 0.1 "
    "--home 0,0,0.5 --start-solution 2 --json free.json --plot free.png": "~8 s, the free box of the page's "
    "python block, which runs it (tests/test_howto.py; --home itself: tests/test_free_box.py)",
    "solve examples/gosselin_chart.toml --inputs 0.3,-0.2,0.5 --formulation paper --pruner lp --lp-backend "
    "highspy --no-isolate --tol 1e-3": "~20-45 s (the paper's configuration: tests/test_howto.py runs it on a four-bar)",
    "solve examples/gosselin.toml --inputs 0.3,-0.2,0.5 --formulation paper --pruner lp --lp-backend "
    "clarabel --no-isolate --tol 1e-2": "~500 s",
}
#: Options whose value is a file a command writes.
OUTPUT_OPTIONS = ("--json", "--plot", "--out", "--table")


def fence_languages(page: str) -> list[str]:
    """The info string of every opening fence of ``page`` (closing fences alternate with them)."""
    return re.findall(r"^```(\S*)", page_text(page), re.M)[::2]


def test_every_page_has_the_code_blocks_its_tests_are_for():
    found = {}
    for page in doc_pages():
        languages = fence_languages(page)
        assert set(languages) <= NOT_CODE | {"python", "sh", ""}, (page, languages)
        counts = {lang: languages.count(lang) for lang in ("python", "sh")}
        if any(counts.values()):
            found[page] = counts
    assert found == BLOCKS


def all_command_lines() -> list[tuple[str, str]]:
    return [(page, shlex.join(words)) for page in doc_pages() for words in command_lines(page)]


def test_every_spherekin_command_line_of_the_docs_parses():
    lines = all_command_lines()
    assert {line.split()[0] for _, line in lines} >= {"solve", "ik", "batch", "map", "singular", "track"}
    parser = build_parser()
    for page, line in lines:
        try:
            parser.parse_args(protect_negative_values(shlex.split(line)))
        except SystemExit:
            pytest.fail(f"{page}'s `spherekin {line}` does not parse")


def test_every_parse_only_and_checked_line_is_in_the_docs():
    lines = {line for _, line in all_command_lines()}
    assert set(PARSE_ONLY) <= lines and set(OUTPUT_CHECKS) <= lines - set(PARSE_ONLY)


def reference_poses(mech, inputs):
    return direct_kinematics(geometry_of(mech), inputs)


def check_solve_json(proc, tmp_path):
    """The JSON's poses are the degree-8 eigenvalue solver's (references/peers_closed_form.py), all of them."""
    doc = json.loads((tmp_path / "out.json").read_text())
    refs = reference_poses(general_3rrr(), [0.3, -0.2, 0.5])
    poses = [np.array(s["platform_rotation"]) for s in doc["solutions"]]
    assert len(poses) == len(refs) == 8
    for pose in poses:
        assert min(np.abs(pose - ref).max() for ref in refs) < POSE_MATCH


def check_ik_json(proc, tmp_path):
    """Every working mode's inputs put the pose Rz(10) Ry(-20) Rx(30) (degrees, intrinsic ZYX: scipy)
    among the degree-8 solver's poses at those inputs."""
    from scipy.spatial.transform import Rotation

    doc = json.loads((tmp_path / "ik.json").read_text())
    want = Rotation.from_euler("ZYX", [10, -20, 30], degrees=True).as_matrix()
    assert len(doc["solutions"]) == 8
    for s in doc["solutions"]:
        refs = reference_poses(general_3rrr(), [s["inputs"][n] for n in ("beta1", "beta2", "beta3")])
        assert min(np.abs(want - ref).max() for ref in refs) < POSE_MATCH


def check_four_bar_line(proc, tmp_path):
    """A crank-rocker has no branch point: its closed form's discriminant (tests/test_branches.py) stays
    positive over the input's turn, so the cover holds no cell and is complete."""
    from test_branches import discriminant, read_axes

    geo = read_axes(ROOT / "examples" / "four_bar.toml")
    assert min(discriminant(geo, t) for t in np.linspace(-np.pi, np.pi, 721)) > 0
    table = dict(re.findall(r"^(singular|unresolved)\s+(\d+)$", proc.stdout, re.M))
    assert table == {"singular": "0", "unresolved": "0"} and "complete: yes" in proc.stdout, proc.stdout


def check_getting_started_output(proc, tmp_path):
    """The output that docs/getting-started.md shows for `make run`'s command is what it prints: every line
    shown in its text block, up to its elisions ("...", "(...)") and the time (the issue's drift: an
    example that showed settings no longer the defaults)."""
    shown = blocks("docs/getting-started.md", "text")
    assert len(shown) == 1
    printed = [_meaningful(p) for p in proc.stdout.splitlines()]
    for line in shown[0].splitlines():
        if line.strip() == "...":
            continue
        head = _meaningful(re.split(r" \(\.\.\.\)|, [\d.]+ s$", line)[0])
        assert any(p.startswith(head) for p in printed), f"shown, not printed: {line!r}\n{proc.stdout}"


#: A residual as the solution table prints it (``{:9.1e}``, ~1e-16): rounding, not meaning; it depends on
#: the BLAS kernel and the CPU (issue 42: 5.1e-16 in the docs, 5.7e-16 on another machine).
RESIDUAL = re.compile(r"\b\d\.\de-1[0-9]\b")


def _meaningful(line: str) -> str:
    """``line`` up to what is meaningful in it: counts, statuses and angles to their printed digits stay,
    a rounding-level residual becomes "<residual>"."""
    return RESIDUAL.sub("<residual>", line)


#: Half-width (radians of beta1) of the bracket around the tracking page's singular input on which the
#: reference's count is read: its fold is located there to ~1e-10, and on a fold the two merging poses are
#: ~sqrt(1e-7) = 3e-4 apart at this distance, well within the reference's accuracy.
FOLD_BRACKET = 1e-7


def check_track_stop(proc, tmp_path):
    """The track stops at a parallel singularity at the input docs/howto/tracking.md states, and there the
    degree-8 reference's count of poses drops from 6 to 4 (beta2 = 0, beta3 = 0.5 along the path)."""
    stated = float(re.search(r"meets the singularity at beta1 =\s*(-?\d+\.\d+)",
                             page_text("docs/howto/tracking.md"))[1])
    stop = json.loads((tmp_path / "track.json").read_text())["stop"]
    assert stop["kind"] == "singular"
    assert abs(stop["singular_inputs"]["beta1"] - stated) < 1e-9
    assert [len(reference_poses(general_3rrr(), [stated + d, 0.0, 0.5])) for d in (-FOLD_BRACKET, FOLD_BRACKET)] \
        == [6, 4]


#: Commands run whose output is also checked against an independent reference (or the page's text).
OUTPUT_CHECKS = {"solve examples/general_3rrr.toml --inputs 0.3,-0.2,0.5 --json out.json": check_solve_json,
                 "ik examples/general_3rrr.toml --euler 10,-20,30 --degrees --json ik.json": check_ik_json,
                 "singular examples/four_bar.toml --x A=-pi:pi": check_four_bar_line,
                 "solve examples/gosselin.toml --inputs 0.3,-0.2,0.5": check_getting_started_output,
                 "track examples/general_3rrr.toml --path examples/path_general_3rrr.csv --start-solution 5 "
                 "--check 4 --plot track.png --out track.csv --json track.json": check_track_stop}
RUN = [(page, line) for page, line in all_command_lines() if line not in PARSE_ONLY]


@pytest.mark.parametrize("page, line", RUN, ids=[f"{page.split('/')[-1]}-{line.split()[0]}-{k}"
                                                 for k, (page, line) in enumerate(RUN)])
def test_cheap_command_line_of_the_docs_runs_and_writes_its_files(tmp_path, page, line):
    words = shlex.split(line)
    proc = run_command(tmp_path, words)
    assert proc.returncode == 0, f"{page}: `spherekin {line}`:\n{proc.stderr[-2000:]}"
    outputs = [words[k + 1] for k, w in enumerate(words) if w in OUTPUT_OPTIONS]
    for out in outputs:
        assert (tmp_path / out).exists(), f"{page}: `spherekin {line}` did not write {out}"
    if line in OUTPUT_CHECKS:
        OUTPUT_CHECKS[line](proc, tmp_path)


def test_chunk_size_help_states_the_engine_default(capsys):
    """`--chunk-size`'s help (what docs/howto/families.md sends readers to) says the engine's cap: it
    said 64 while the engine took up to 256 (spherekin.batch.engine.CHUNK_INPUTS)."""
    from spherekin.batch.engine import CHUNK_INPUTS

    for command in ("batch", "map"):
        with pytest.raises(SystemExit):
            build_parser().parse_args([command, "--help"])
        help_text = " ".join(capsys.readouterr().out.split())
        assert f"--chunk-size CHUNK_SIZE inputs per Dask task (default: up to {CHUNK_INPUTS}," in help_text


# ------------------------------------------------------------------ getting started


def test_getting_started_python_block_runs_and_its_pose_is_a_reference_pose(tmp_path):
    """The first solve in Python: it prints the Gosselin platform's 8 solutions (the paper's count),
    and solution number 3, certified, is one of the poses of the degree-8 eigenvalue solver of
    references/peers_closed_form.py (numpy only, not spherekin's solver) at the same inputs."""
    code = blocks("docs/getting-started.md", "python")
    assert len(code) == 1, "a new python block in docs/getting-started.md needs a check here"
    proc = run_script(tmp_path, code[0] + "\nimport json\nprint(json.dumps(sol.platform_rotation.tolist()))\n")
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("8 solutions (count proven"), lines[0]
    assert any(line.startswith("certified {'gamma1'") for line in lines), proc.stdout   # sol.status, sol.passive_angles
    rotation = np.array(json.loads(lines[-1]))
    gaps = [np.abs(rotation - ref).max() for ref in reference_poses(gosselin(), [0.3, -0.2, 0.5])]
    assert min(gaps) < POSE_MATCH, f"expected solution 3's pose among the reference poses, nearest {min(gaps):.2e}"


# ------------------------------------------------------------------ mechanism files


def test_mechanism_format_python_blocks_run_as_scripts_from_the_repository_root(tmp_path):
    """docs/mechanism-format.md's blocks, each a script in a fresh interpreter (from the repository root,
    as the block sees it, where its example files are): the names it prints are those its comment shows,
    and every inverse-kinematics solution of the identity pose closes: the degree-8 eigenvalue reference
    (references/peers_closed_form.py) has the identity among its poses at those inputs."""
    code = blocks("docs/mechanism-format.md", "python")
    assert len(code) == 3, "a new python block in docs/mechanism-format.md needs a check here"
    outs = []
    for k, block in enumerate(code):
        run = run_script(tmp_path, block)
        assert run.returncode == 0, run.stderr[-2000:]
        outs.append(run.stdout)
    assert outs[0].startswith("('beta1', 'beta2', 'beta3') ('gamma1', 'delta1'")
    # the Watt six-bar: loops closed by C and F (counted by hand in tests/test_mechanism_graph.py), its 4
    # assemblies at 0.7 (two four-bars in series, checked there in closed form), the input given back twice
    watt = outs[1].strip().splitlines()
    assert watt[0] == "['C', 'F'] 1" and watt[1].startswith("4 solutions (count proven")
    assert watt[2:] == ["0.7 certified", "0.7 certified"]
    lines = outs[2].strip().splitlines()
    assert 1 <= len(lines) <= 8
    for line in lines:
        inputs = [float(v) for v in re.match(r"^\(([^)]*)\)", line)[1].split(",")]
        poses = reference_poses(general_3rrr(), inputs)
        assert min(np.abs(p - np.eye(3)).max() for p in poses) < 1e-8, line


# ------------------------------------------------------------------ links that work on GitHub too


def github_anchor(heading: str) -> str:
    """GitHub's (and MyST's) anchor of a Markdown heading: lower case, punctuation dropped, spaces -> '-'."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_relative_links_of_every_page_resolve_to_files_and_headings():
    """Every Markdown link of the README and of the pages that is not a URL names a file of the checkout
    (relative to the page, as GitHub reads it), and its #anchor, if any, a heading of that file."""
    for page in doc_pages():
        text = re.sub(r"^```.*?^```", "", page_text(page), flags=re.S | re.M)    # links in code are not links
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            file = (ROOT / page).parent / path if path else ROOT / page
            assert file.exists(), f"{page}: link to {target}: no such file"
            if anchor and file.suffix == ".md":
                headings = re.findall(r"^#+ (.*)$", file.read_text(), re.M)
                assert anchor in {github_anchor(h) for h in headings}, f"{page}: link to {target}: no such heading"
