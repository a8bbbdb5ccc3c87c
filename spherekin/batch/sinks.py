"""Where a batch's results go as they arrive: a partitioned Parquet dataset or an appended CSV file.

Neither holds the table in memory. A **Parquet dataset** is a directory (``results.parquet/``) of
files ``part-<first>-<end>.parquet``, one per chunk of inputs [first, end), each written to a
temporary name and renamed, so a file that exists is complete; chunks are written in the order they
finish. A **CSV file** gets one block of lines per chunk, appended in input order (the engine holds
back a chunk that finishes before an earlier one); a run stopped mid-write leaves at most the last
input's rows incomplete. One run writes an output at a time: :func:`open_sink` takes its lock
(``<out>.lock``, :mod:`spherekin.batch.lock`) before writing anything, the sink's close releases it.

``--resume`` (``resume=True``) reads what an earlier run wrote: the inputs it finished (for a CSV,
every input before the last one present; the last one's rows are cut off and solved again), after
checking that the file is a results table of this mechanism (its columns) and of these inputs (the
actuator values of every finished input, exactly as written). Then only the rest is solved.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .lock import OutputLock, check_unlocked
from .rows import columns

__all__ = ["SUFFIXES", "Sink", "ParquetSink", "CsvSink", "open_sink", "check_output_path", "read_results"]

#: The output formats, by the output path's suffix.
SUFFIXES = (".parquet", ".csv")
#: Largest difference (radians) between an input as a resumed file holds it and as the job gives it.
#: Reason: Parquet stores float64 exactly and pandas writes CSV floats in their shortest round-trip
#: form, so the two are equal; 1e-12 only absorbs a file written by another CSV writer.
RESUME_MATCH = 1e-12


def check_output_path(path, resume: bool, overwrite: bool) -> Path:
    """The output path, checked before any work: a known suffix, an existing writable directory to
    hold it, and no earlier output unless ``resume`` or ``overwrite`` says what to do with it."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(f"--out {path}: expected a .parquet (a partitioned dataset, a directory) or .csv path, "
                         f"got suffix {path.suffix or '(none)'!r}")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"--out {path}: the directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise ValueError(f"--out {path}: the directory {parent} is not writable")
    if resume and overwrite:
        raise ValueError("--resume and --overwrite: expected at most one of them")
    check_unlocked(path)                          # another run writing it: refused before any work
    is_parquet = path.suffix.lower() == ".parquet"
    if path.exists():
        if is_parquet and not path.is_dir():
            raise ValueError(f"--out {path}: exists and is a file; a .parquet output is a directory (a dataset)")
        if not is_parquet and path.is_dir():
            raise ValueError(f"--out {path}: is a directory; expected a CSV file path")
        if not (resume or overwrite):
            raise ValueError(f"--out {path}: already exists; pass --resume to complete it or --overwrite to replace it")
    elif resume:
        raise ValueError(f"--out {path}: --resume, but there is no earlier output to complete")
    return path


class Sink:
    """A results writer. ``ordered``: chunks must be written in input order. ``done``: a boolean
    mask over the job's inputs of those already written (by an earlier run, with resume)."""

    ordered = False
    #: The output's lock (:mod:`spherekin.batch.lock`), taken by :func:`open_sink`, released by close.
    lock: OutputLock | None = None

    def __init__(self, path: Path, mechanism, inputs: np.ndarray):
        self.path, self.mechanism, self.inputs = path, mechanism, inputs
        self.columns = list(columns(mechanism))
        self.done = np.zeros(len(inputs), dtype=bool)

    def write(self, first: int, end: int, frame) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Flush and release the output (every written chunk stays; idempotent)."""
        if self.lock is not None:
            self.lock.release()

    def discard_temporaries(self, run: str) -> None:
        """Delete the temporary files of run ``run`` (its lock token): none but a Parquet dataset's."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def key_columns(self) -> list[str]:
        """The columns a resume reads back: ``input`` and the actuated joints (not the whole table)."""
        return ["input", *self.mechanism.actuated]

    def _check_resumed(self, columns: list[str], frame) -> None:
        """ValueError unless an earlier run's output, with ``columns`` and the rows ``frame`` (its
        key columns), is of this mechanism and these inputs."""
        if list(columns) != self.columns:
            raise ValueError(f"--resume {self.path}: its columns are not those of this mechanism's results "
                             f"({', '.join(self.columns[:6])}, ...); it cannot be completed by this job")
        if not len(frame):
            return
        idx = frame["input"].to_numpy()
        if idx.min() < 0 or idx.max() >= len(self.inputs):
            raise ValueError(f"--resume {self.path}: it holds input {int(idx.max())}, beyond this job's "
                             f"{len(self.inputs)} inputs; it cannot be completed by this job")
        got = frame[list(self.mechanism.actuated)].to_numpy(dtype=float)
        bad = np.abs(got - self.inputs[idx]).max(axis=1) > RESUME_MATCH
        if bad.any():
            k = int(idx[np.flatnonzero(bad)[0]])
            raise ValueError(f"--resume {self.path}: input {k} there is {got[np.flatnonzero(bad)[0]].tolist()}, in "
                             f"this job {self.inputs[k].tolist()}; the file is the output of other inputs")
        self.done[np.unique(idx)] = True


class ParquetSink(Sink):
    """A partitioned Parquet dataset (module doc)."""

    def __init__(self, path: Path, mechanism, inputs: np.ndarray, resume: bool):
        super().__init__(path, mechanism, inputs)
        if path.exists() and not resume:          # --overwrite
            for part in path.glob("part-*.parquet"):
                part.unlink()
        path.mkdir(exist_ok=True)
        if resume:
            import pandas as pd

            parts = sorted(path.glob("part-*.parquet"))
            if parts:
                import pyarrow.parquet as pq

                for part in parts:
                    self._check_resumed(pq.read_schema(part).names, pd.read_parquet(part, columns=self.key_columns))

    def write(self, first: int, end: int, frame) -> None:
        final = self.path / f"part-{first:09d}-{end:09d}.parquet"
        tmp = temporary_path(final, self.lock.token if self.lock else "unlocked")
        frame.to_parquet(tmp, index=False)
        os.replace(tmp, final)

    def discard_temporaries(self, run: str) -> None:
        for tmp in self.path.glob(temporary_path(self.path / "part-*.parquet", run).name):
            tmp.unlink(missing_ok=True)

    def close(self) -> None:
        if self.lock is not None:                 # a write cut short (an error, Ctrl-C): only this run's
            self.discard_temporaries(self.lock.token)
        super().close()


def temporary_path(final: Path, run: str) -> Path:
    """Where Parquet part ``final`` is written before its rename: hidden (a dot name, which pyarrow's
    reading of the directory skips), named for run ``run`` (its lock token: pid and a random part),
    so that a run finds and deletes only its own temporaries, never those of another run."""
    return final.with_name(f".{final.name}.{run}.tmp")


class CsvSink(Sink):
    """An appended CSV file (module doc)."""

    ordered = True

    def __init__(self, path: Path, mechanism, inputs: np.ndarray, resume: bool):
        super().__init__(path, mechanism, inputs)
        if resume:
            with open(path, newline="") as f:
                header = f.readline().rstrip("\r\n").split(",")
            if header != [""] and header != self.columns:
                raise ValueError(f"--resume {self.path}: its columns are not those of this mechanism's results "
                                 f"({', '.join(self.columns[:6])}, ...); it cannot be completed by this job")
            offset = self._complete_prefix()
            if offset:                                # validated first: a refused resume leaves the file as it was
                with open(path, "rb") as f:
                    self._check_resumed(header, _read_csv(f.read(offset), usecols=self.key_columns))
            with open(path, "rb+") as f:
                f.truncate(offset)
            self._file = open(path, "a", newline="")
            if not path.stat().st_size:
                self._file.write(",".join(self.columns) + "\n")
        else:
            self._file = open(path, "w", newline="")
            self._file.write(",".join(self.columns) + "\n")
        self._file.flush()

    def _complete_prefix(self) -> int:
        """The byte length of the file without the last input it holds (and any partial line): only
        that input can have been written in part. 0 for a file without a complete header line."""
        with open(self.path, "rb") as f:
            data = f.read()
        end = data.rfind(b"\n") + 1                  # complete lines only
        lines = data[:end].split(b"\n")[:-1]
        if len(lines) <= 1:                           # a header (or nothing) only
            return end
        last = lines[-1].split(b",", 1)[0]
        offset = end
        for line in reversed(lines[1:]):
            if line.split(b",", 1)[0] != last:
                break
            offset -= len(line) + 1
        return offset

    def write(self, first: int, end: int, frame) -> None:
        frame.to_csv(self._file, header=False, index=False, lineterminator="\n")
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()
        super().close()


def open_sink(path, mechanism, inputs: np.ndarray, resume: bool = False) -> Sink:
    """The sink of ``path`` (checked with :func:`check_output_path` first), holding the output's lock
    (taken before anything is written; ValueError if another run holds it) until its close: use it
    in a ``with`` block."""
    path = Path(path)
    cls = ParquetSink if path.suffix.lower() == ".parquet" else CsvSink
    lock = OutputLock.acquire(path)
    try:
        sink = cls(path, mechanism, inputs, resume)
        sink.lock = lock
        if lock.previous is not None:              # a run killed while writing: its temporaries
            sink.discard_temporaries(lock.previous.token)
    except BaseException:
        lock.release()
        raise
    return sink


def _read_csv(source, usecols=None):
    """A results CSV (a path, or its bytes) as a DataFrame with the table's column types."""
    import io

    import pandas as pd

    if isinstance(source, bytes):
        source = io.BytesIO(source)
    return pd.read_csv(source, usecols=usecols,
                       dtype={"solution": "Int64", "status": "string", "singularity": "string"})


def read_results(path, columns=None):
    """A results table written by a batch (.parquet dataset or .csv), ordered by input and solution;
    ``columns``: only those (``input`` and ``solution`` are always read, to order the rows)."""
    import pandas as pd

    path = Path(path)
    if columns is not None:
        columns = list(dict.fromkeys(["input", "solution", *columns]))
    if path.suffix.lower() == ".parquet":
        parts = sorted(path.glob("part-*.parquet")) if path.is_dir() else [path]
        if not parts:
            raise ValueError(f"{path}: no results in it (no part-*.parquet files)")
        frame = pd.concat([pd.read_parquet(p, columns=columns) for p in parts], ignore_index=True)
    else:
        frame = _read_csv(path, usecols=columns)
    if not {"input", "solution"} <= set(frame.columns):
        raise ValueError(f"{path}: not a results table of spherekin (no input and solution columns)")
    frame = frame.sort_values(["input", "solution"], kind="stable", na_position="first").reset_index(drop=True)
    return frame
