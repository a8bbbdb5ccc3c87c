"""The code blocks of the README and of the site's pages (docs/**/*.md), and how the tests run them
(tests/test_readme.py, tests/test_docs_pages.py, tests/test_howto.py).

A python block runs as a script saved in a fresh directory, by a fresh interpreter with this checkout
on the path, from a directory that is the repository root as far as the block can tell (``examples/``
is there: a symbolic link to the checkout's), so that the files it writes stay out of the checkout.
A ``spherekin`` line of an sh block is its words after the program, continuations joined, comments
dropped.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Seconds a python block may run before its test fails (a hung script; the blocks take ~1-25 s).
BLOCK_TIMEOUT = 300
#: Seconds a command line of the docs that the tests run may take before its test fails (a hung
#: command; the ones run take ~1-8 s, the others are only parsed: tests/test_docs_pages.py).
COMMAND_TIMEOUT = 120


def page_text(page: str) -> str:
    """The text of ``page``, a path relative to the repository root (``README.md``, ``docs/...``)."""
    return (ROOT / page).read_text()


def blocks(page: str, lang: str) -> list[str]:
    """The code of every ```lang block of ``page``, in order."""
    return re.findall(rf"^```{lang}\n(.*?)^```", page_text(page), re.S | re.M)


def doc_pages() -> list[str]:
    """The README and every Markdown page of the site, as paths relative to the repository root."""
    pages = [p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts and "gallery" not in p.parts]
    return ["README.md"] + sorted(str(p.relative_to(ROOT)) for p in pages)


def workdir(tmp_path: Path) -> Path:
    """tmp_path with ``examples`` linked to the checkout's: the repository root, as a block sees it."""
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    return tmp_path


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}


def run_script(tmp_path: Path, code: str) -> subprocess.CompletedProcess:
    """``code`` saved as tmp_path/doc_block.py and run by a fresh interpreter in :func:`workdir`."""
    cwd = workdir(tmp_path) if not (tmp_path / "examples").exists() else tmp_path
    (cwd / "doc_block.py").write_text(code)
    return subprocess.run([sys.executable, "doc_block.py"], cwd=cwd, env=_env(), capture_output=True,
                          text=True, timeout=BLOCK_TIMEOUT)


def command_lines(page: str) -> list[list[str]]:
    """The ``spherekin`` command lines of ``page``'s ```sh blocks, as words after the program."""
    out = []
    for block in blocks(page, "sh"):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words and Path(words[0]).name == "spherekin":
                out.append(words[1:])
    return out


def run_command(tmp_path: Path, words: list[str]) -> subprocess.CompletedProcess:
    """``spherekin WORDS`` (as ``python -m spherekin``) in :func:`workdir`."""
    cwd = workdir(tmp_path) if not (tmp_path / "examples").exists() else tmp_path
    return subprocess.run([sys.executable, "-m", "spherekin", *words], cwd=cwd, env=_env(), capture_output=True,
                          text=True, timeout=COMMAND_TIMEOUT)
