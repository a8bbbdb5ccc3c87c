"""The Python entry points as a notebook user meets them (issue 27, items 12 and 13): what ``dir`` and
``help`` show, a mechanism given by its file, the strategy keywords in the signature, short reprs,
why a solve is empty."""

from __future__ import annotations

import inspect
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import spherekin
from spherekin import batch
from spherekin.mechanism import gosselin

ROOT = Path(__file__).resolve().parent.parent
GOSSELIN = ROOT / "examples" / "gosselin.toml"
CHART = ROOT / "examples" / "gosselin_chart.toml"
INPUTS = (0.3, -0.2, 0.5)
#: The strategy keywords of compile and solve, and their defaults as docs/howto/strategy.md's option table
#: states them (written out here, not read from the code).
STRATEGY = {"formulation": "auto", "pruner": "pp", "lp_backend": None, "parameterization": "tan-half",
            "tol": 1e-6, "isolate": True, "jobs": 1}


def fresh(code: str) -> str:
    """stdout of ``code`` run in a new interpreter with this checkout's spherekin."""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert run.returncode == 0, run.stderr
    return run.stdout


def test_dir_and_help_show_the_entry_points_and_import_stays_light():
    out = fresh("import sys, spherekin\n"
                "names = dir(spherekin)\n"
                "print(sorted(n for n in ('solve', 'compile', 'load_mechanism', 'batch', 'plot') if n in names))\n"
                "print('spherekin.problem' in sys.modules, 'numpy' in sys.modules)\n"
                "import pydoc\n"
                "text = pydoc.render_doc(spherekin, renderer=pydoc.plaintext)\n"
                "print('solve(mechanism, inputs, *, formulation' in text, 'compile(mechanism, *' in text,"
                " 'load_mechanism(path)' in text)\n")
    lines = out.splitlines()
    assert lines[0] == "['batch', 'compile', 'load_mechanism', 'plot', 'solve']"
    assert lines[1] == "False False"          # dir() lists them without importing the pipeline (or numpy)
    assert lines[2] == "True True True"       # help() documents each with its signature


def test_submodules_are_attributes_after_import_spherekin():
    out = fresh("import spherekin\nprint(spherekin.plot.plot_solutions.__name__, spherekin.batch.solve_many.__name__)")
    assert out.split() == ["plot_solutions", "solve_many"]


@pytest.mark.parametrize("entry", [spherekin.solve, spherekin.compile])
def test_the_strategy_keywords_are_in_the_signature_with_their_defaults(entry):
    params = inspect.signature(entry).parameters
    for name, default in STRATEGY.items():
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY
        assert params[name].default == default, name
    assert not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())


def test_solve_and_compile_take_the_path_of_a_mechanism_file():
    by_path = spherekin.solve(str(GOSSELIN), INPUTS)
    by_pathlike = spherekin.compile(GOSSELIN).solve(INPUTS)
    assert by_path.settings.mechanism == by_pathlike.settings.mechanism == gosselin().name
    # the paper's count at these inputs (Section 5): 8 assemblies, the same from either spelling
    assert len(by_path.solutions) == len(by_pathlike.solutions) == 8
    np.testing.assert_allclose(np.sort([s.angles for s in by_path.solutions], axis=0),
                               np.sort([s.angles for s in by_pathlike.solutions], axis=0), atol=1e-12)


def test_batch_takes_the_path_of_a_mechanism_file():
    table = batch.solve_many(str(GOSSELIN), np.array([INPUTS]), workers=0)
    assert len(table) == 8 and set(table["beta1"]) == {0.3}


@pytest.mark.parametrize("call", [
    lambda m: spherekin.solve(m, INPUTS), lambda m: spherekin.compile(m),
    lambda m: batch.solve_many(m, np.array([INPUTS]), workers=0),
    lambda m: batch.assembly_map(m, "beta1=0:1:2", "beta2=0:1:2", ["beta3=0.5"], workers=0)])
def test_a_mechanism_of_another_type_is_one_clear_error(call):
    with pytest.raises(ValueError, match="^mechanism: expected a SphericalMechanism or a path to a .toml file, got int$"):
        call(3)


def test_a_missing_mechanism_file_names_the_file(tmp_path):
    with pytest.raises(ValueError, match="nope.toml: cannot read the file"):
        spherekin.solve(tmp_path / "nope.toml", INPUTS)


def test_repr_of_a_problem_is_one_short_line():
    problem = spherekin.compile(GOSSELIN, pruner="hybrid", tol=1e-5)
    text = repr(problem)
    assert len(text) < 200 and "\n" not in text
    # a 3-RRR: three legs of three revolute joints, six passive unknowns
    assert text.startswith("Problem('Gosselin platform (agile eye)', 9 joints, 6 unknowns; ")
    assert "pruner hybrid" in text and "tol 1e-05" in text and "Joint(" not in text
    long = spherekin.compile(GOSSELIN)
    object.__setattr__(long.mechanism, "name", "x" * 500)
    assert len(repr(long)) < 200


def ranges_of(path: Path) -> dict[str, tuple[float, float]]:
    """The passive joints' ranges of a mechanism file, read with tomllib (plain floats in the file)."""
    return {k: (float(a), float(b)) for k, (a, b) in tomllib.loads(path.read_text())["joint_ranges"].items()}


def inside(angle: float, lo: float, hi: float) -> bool:
    """``angle`` in the closed range [lo, hi] modulo 2 pi (docs/results-format.md)."""
    return (angle - lo) % (2 * math.pi) <= (hi - lo) + 1e-9


def test_an_empty_solve_says_why_in_python_and_in_the_json():
    inputs = (-2.5, 2.9, 0.1)
    report = spherekin.solve(CHART, inputs)
    assert report.solutions == ()
    reason = report.empty_reason
    ranges = ranges_of(CHART)
    assert reason.kind == "outside_ranges" and set(reason.ranged_joints) == set(ranges)
    # independently: the mechanism without ranges (the plain Gosselin file) has 8 assemblies there,
    # and each one leaves at least one of the file's ranges
    free = spherekin.solve(GOSSELIN, inputs)
    assert reason.assemblies_without_ranges == len(free.solutions) == 8
    for sol in free.solutions:
        assert not all(inside(sol.passive_angles[n], *ranges[n]) for n in ranges)
    data = report.as_dict()["empty_reason"]
    assert data == {"kind": "outside_ranges", "ranged_joints": list(reason.ranged_joints),
                    "assemblies_without_ranges": 8, "note": reason.text()}
    assert "8 assemblies exist with the passive joints unlimited" in data["note"]
    assert "empty_reason" not in free.as_dict() and free.empty_reason is None


def test_an_empty_solve_outside_the_workspace():
    # the legs of the 3-RRR example cannot close at these inputs (no ranges to blame)
    report = spherekin.solve(ROOT / "examples" / "general_3rrr.toml", (-2.5, 2.9, 0.1))
    assert report.solutions == () and report.empty_reason.kind == "outside_workspace"
    assert report.empty_reason.assemblies_without_ranges == 0
    assert report.as_dict()["empty_reason"]["note"].startswith("no assembly at all at these inputs")

