"""Output files written whole or not at all.

A command's result file (a ``--json`` report, a ``--table`` CSV, a ``--plot`` image, a batch's fingerprint
sidecar) is written to a hidden temporary beside it and renamed over it once complete (a rename within a
directory is atomic on POSIX): an interrupt while it is written (Ctrl-C, SIGTERM: Python raises them
between two partial writes of a large buffer) leaves the earlier file, or none, never a cut one that a
later script would read as the result; the temporary is removed. (A batch's Parquet parts use their own
temporaries, named per run so that a later run can discard those of a run that was killed:
:mod:`spherekin.batch.sinks`.)
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

__all__ = ["replacing", "write_text", "check_writable"]


@contextmanager
def replacing(path) -> Iterator[Path]:
    """The temporary path to write ``path``'s new content to: renamed over ``path`` when the block ends,
    deleted (and ``path`` left as it was) when the block raises, an interrupt included."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text(path, text: str) -> None:
    """Write ``text`` to the file ``path`` whole or not at all (:func:`replacing`)."""
    with replacing(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def check_writable(directory, what: str) -> None:
    """ValueError naming ``what`` unless a file can be created in ``directory``: probed by creating (and
    removing) the kind of hidden temporary :func:`replacing` writes there, so a read-only mount, /proc or a
    directory without write permission is found before any work (``os.access`` says yes to root on a
    read-only mount)."""
    probe = Path(directory) / f".spherekin-probe.{os.getpid()}.tmp"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        return
    except OSError as exc:
        raise ValueError(f"{what}: cannot write in the directory {str(directory)!r} "
                         f"({exc.strerror or type(exc).__name__})") from None
    os.close(fd)
    os.unlink(probe)
