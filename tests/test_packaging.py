"""What `pip install .` installs: the spherekin package (typed), its license, no top-level `verification`."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_the_wheel_holds_spherekin_only_with_py_typed_and_the_license(tmp_path):
    # built from a copy: setuptools writes build/ and *.egg-info/ into the tree it builds
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".git", ".venv", "build", "*.egg-info", "__pycache__",
                                                                ".pytest_cache", ".hypothesis", "results", "quick"))
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", str(source), "--no-deps",
                          "-q", "-w", str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    wheel = next(tmp_path.glob("spherekin-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    assert "verification" not in tops and "tests" not in tops and "benchmarks" not in tops
    assert "spherekin/py.typed" in names and "spherekin/batch/engine.py" in names
    assert any(n.endswith("LICENSE") for n in names)
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    assert "spherekin = spherekin.cli:run" in zipfile.ZipFile(wheel).read(entry).decode()
