"""Where a batch's results go as they arrive: a partitioned Parquet dataset or an appended CSV file.

Neither holds the table in memory. A **Parquet dataset** is a directory (``results.parquet/``) of
files ``part-<first>-<end>.parquet``, one per chunk of inputs [first, end), each written to a
temporary name and renamed, so a file that exists is complete; chunks are written in the order they
finish. A **CSV file** gets one block of lines per chunk, appended in input order (the engine holds
back a chunk that finishes before an earlier one), each block whole or not at all: an interrupt
(Ctrl-C, SIGTERM) raised while a block is written truncates the file back to where the block began,
so a stopped run leaves only whole inputs, as many as it says; a crash (SIGKILL, power) can still cut
the last input's rows, and a line short, which a resume repairs (below). One run writes an output at a time:
:func:`open_sink` takes its lock (``<out>.lock``, :mod:`spherekin.batch.lock`) before writing
anything, the sink's close releases it.

Every output carries the :class:`~spherekin.batch.fingerprint.Fingerprint` of the job that wrote it
(mechanism, inputs, strategy, version), written before its first row: in each Parquet part's schema
metadata, in a sidecar ``<file>.spherekin.json`` of a CSV file.

``--resume`` (``resume=True``) completes an earlier run's output only if it is this job's and only
with what it verifies, before any solve: the fingerprint equal to this job's (else ValueError naming
what differs); then every row: a CSV's lines parse, with the table's columns, finite inputs equal to
this job's for their input number, inputs in order from 0 and each input's solutions numbered 1, 2,
... (or one row without a solution); a Parquet part's rows are those of the inputs its name gives,
each once, and no two parts hold one input. What cannot be a run's cut is refused naming the file
and line or part. A CSV's last input is solved again (a run stopped while writing it may have cut
its rows), together with a line cut short and unreadable lines after it (what a crash leaves at the
end of a file): the file is truncated there, and ``Sink.note`` says so when more than whole rows
are dropped. What a crash cannot leave is refused, never deleted: another job's well-formed rows, or
more unreadable lines than one block holds (RESUME_MAX_DROPPED_LINES). A run that wrote the last
input records the file's length in the sidecar (COMPLETE_KEY); a resume of the file at that length
keeps every row.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
from pathlib import Path
from typing import Iterator

import numpy as np

from .. import atomic
from ..results import ResultsTable, Status
from .fingerprint import METADATA_KEY, Fingerprint, sidecar_path
from .lock import OutputLock, check_unlocked
from .rows import columns, empty_frame

__all__ = ["SUFFIXES", "Sink", "MemorySink", "ParquetSink", "CsvSink", "open_sink", "check_output_path",
           "check_fingerprints", "read_results", "csv_fields"]

#: The output formats, by the output path's suffix.
SUFFIXES = (".parquet", ".csv")
#: Largest difference (radians) between an input as a resumed file holds it and as the job gives it.
#: Reason: Parquet stores float64 exactly and the CSV sink writes floats in their shortest round-trip
#: form (as pandas does, :func:`csv_fields`), so the two are equal; 1e-12 only absorbs a file written
#: by another CSV writer.
RESUME_MATCH = 1e-12
#: Most unreadable lines a CSV resume drops from the end of a file. Reason: a crash cuts at most one
#: block, the rows of one chunk (at most CHUNK_INPUTS = 256 inputs, written in order by one process,
#: so every whole line of a cut block is a row of this job); unreadable whole lines after the rows can
#: only be bytes a power cut left in that block. 256 inputs x 16 rows (twice the 8 assemblies of a
#: 3-RRR) bounds one block; more lines than that are not a crash's leftovers, and a resume that
#: deleted them would delete data (issue 42 item 8).
RESUME_MAX_DROPPED_LINES = 256 * 16
#: The key of a CSV sidecar that records a finished run: {"bytes": the file's length when its last
#: input was written}. A resume of a file of that length keeps every row (nothing to solve again).
COMPLETE_KEY = "complete"
#: The name of a Parquet part: the chunk of inputs [first, end) it holds.
PART_NAME = re.compile(r"part-(\d+)-(\d+)\.parquet")
#: The statuses a solution row of the table can have.
STATUSES = frozenset(str(s) for s in Status)
#: What to do with an output a resume refuses (the end of every such message).
REFUSED = "pass --overwrite to solve every input again"


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


def _refused(where: str, what: str) -> ValueError:
    return ValueError(f"--resume {where}: {what}; {REFUSED}")


def check_fingerprints(path, fingerprint: Fingerprint) -> None:
    """ValueError unless the earlier output at ``path`` was written by the job of ``fingerprint``:
    the sidecar of a CSV file, every part of a Parquet dataset (module doc). Reads no rows: called
    before a cluster starts, and again when the sink opens."""
    path = Path(path)
    if path.suffix.lower() == ".parquet":
        found = [(f"{path}: {part.name}", _schema(part, f"{path}: {part.name}").metadata or {})
                 for part in sorted(path.glob("part-*.parquet"))]
        found = [(where, meta.get(METADATA_KEY)) for where, meta in found]
    else:
        side = sidecar_path(path)
        found = [(str(path), side.read_text() if side.is_file() else None)]
    for where, text in found:
        if text is None:
            raise _refused(where, "it has no fingerprint (written before spherekin recorded one, or not by "
                                  "spherekin), so it cannot be checked to be this job's output")
        diff = Fingerprint.from_json(text, f"--resume {where}").differences(fingerprint)
        if diff:
            raise _refused(where, "it is the output of another job: " + "; ".join(diff))


def _schema(part: Path, where: str):
    """The schema of the Parquet file ``part``; ValueError naming it (``where``) if it cannot be read."""
    import pyarrow.parquet as pq

    try:
        return pq.read_schema(part)
    except Exception as exc:                       # pyarrow's errors of a damaged file have no common base
        raise _refused(where, f"it cannot be read ({type(exc).__name__}: {exc})") from None


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
        #: What a resume repaired (dropped beyond whole rows), for the user; "" when nothing.
        self.note = ""

    def write(self, first: int, end: int, table) -> None:
        """Write ``table`` (a :class:`~spherekin.results.ResultsTable`), the rows of inputs [first, end)."""
        raise NotImplementedError

    def close(self) -> None:
        """Flush and release the output (every written chunk stays; idempotent)."""
        if self.lock is not None:
            self.lock.release()

    def discard_temporaries(self, run: str) -> None:
        """Delete the temporary files of run ``run`` (its lock token): none but a Parquet dataset's."""

    #: (device, inode) of the output as opened; None: nothing on disk (a table in memory).
    identity: tuple | None = None

    def check_in_place(self, written: int) -> None:
        """RuntimeError when the output at ``path`` is no longer the one this run wrote (removed, or
        replaced by another file or directory during the run): the ``written`` rows are not at that
        path, and the run must not say they are (issue 42 item 11). Called once the run has ended."""
        if self.identity is None:
            return
        try:
            st = os.stat(self.path)
            now = (st.st_dev, st.st_ino)
        except OSError:
            now = None
        if now != self.identity:
            raise RuntimeError(f"--out {self.path}: {'removed' if now is None else 'replaced'} during the run: the "
                               f"{written} row(s) written this run are not at that path; run the command again")

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def key_columns(self) -> list[str]:
        """The columns a resume reads back: ``input``, the actuated joints and ``solution``."""
        return ["input", *self.mechanism.actuated, "solution"]

    def _refuse(self, where: str, what: str):
        return _refused(where, what)

    def _check_columns(self, where: str, names) -> None:
        if list(names) != self.columns:
            raise self._refuse(where, f"its columns are not those of this mechanism's results "
                                      f"({', '.join(self.columns[:6])}, ...)")


class MemorySink(Sink):
    """Chunks kept in memory, concatenated in input order at the end (:func:`spherekin.batch.solve_many`)."""

    def __init__(self, mechanism, inputs: np.ndarray):
        super().__init__(Path("<memory>"), mechanism, inputs)
        self.tables: dict[int, object] = {}

    def write(self, first: int, end: int, table) -> None:
        self.tables[first] = table

    def frame(self):
        """The rows written, in input order, as a pandas DataFrame."""
        parts = [self.tables[k] for k in sorted(self.tables)]
        return ResultsTable.concat(parts).frame() if parts else empty_frame(self.mechanism)


class ParquetSink(Sink):
    """A partitioned Parquet dataset (module doc)."""

    def __init__(self, path: Path, mechanism, inputs: np.ndarray, resume: bool, fingerprint: Fingerprint):
        super().__init__(path, mechanism, inputs)
        self.fingerprint = fingerprint
        if path.exists() and not resume:          # --overwrite
            for part in path.glob("part-*.parquet"):
                part.unlink()
        path.mkdir(exist_ok=True)
        st = os.stat(path)
        self.identity = (st.st_dev, st.st_ino)
        if resume:
            check_fingerprints(path, fingerprint)
            self._verify_parts()

    def _verify_parts(self) -> None:
        """Mark the inputs of the parts an earlier run wrote as done, after checking every part
        (module doc); ValueError naming the part otherwise."""
        import pyarrow.parquet as pq

        held = []                                  # (first, end, name) of every part
        for part in sorted(self.path.glob("part-*.parquet")):
            where = f"{self.path}: {part.name}"
            m = PART_NAME.fullmatch(part.name)
            if m is None or int(m[1]) >= int(m[2]):
                raise self._refuse(where, "not the name of a part spherekin writes (part-<first>-<end>.parquet)")
            first, end = int(m[1]), int(m[2])
            schema = _schema(part, where)
            try:
                frame = pq.read_table(part, columns=self.key_columns).to_pandas()
            except Exception as exc:               # pyarrow's errors of a damaged file have no common base
                raise self._refuse(where, f"it cannot be read ({type(exc).__name__}: {exc})") from None
            self._check_columns(where, schema.names)
            self._check_part_rows(where, first, end, frame)
            held.append((first, end, part.name))
        held.sort()
        for (a0, a1, a), (b0, b1, b) in zip(held, held[1:]):
            if b0 < a1:
                raise self._refuse(f"{self.path}: {a} and {b}",
                                   f"both hold inputs {b0}..{min(a1, b1) - 1} (written twice: every row "
                                   "would be in the table twice)")
        for first, end, _ in held:
            self.done[first:end] = True

    def _check_part_rows(self, where: str, first: int, end: int, frame) -> None:
        """ValueError unless ``frame`` (the key columns of a part of inputs [first, end)) holds the
        rows of exactly those inputs, this job's, each solution once, numbered 1, 2, ..."""
        if end > len(self.inputs):
            raise self._refuse(where, f"it holds inputs up to {end - 1}, beyond this job's {len(self.inputs)}")
        idx = frame["input"].to_numpy()
        if frame["input"].isna().any() or not np.array_equal(np.unique(idx), np.arange(first, end)):
            raise self._refuse(where, f"its rows are not those of inputs {first}..{end - 1} (its name)")
        idx = idx.astype(np.int64)
        got = frame[list(self.mechanism.actuated)].to_numpy(dtype=float, na_value=np.nan)
        bad = ~(np.abs(got - self.inputs[idx]) <= RESUME_MATCH).all(axis=1)     # NaN is bad too
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise self._refuse(where, f"input {idx[k]} there is {got[k].tolist()}, in this job "
                                      f"{self.inputs[idx[k]].tolist()}")
        sol = frame["solution"].to_numpy(dtype=float, na_value=np.nan)
        order = np.lexsort((sol, idx))
        idx, sol = idx[order], sol[order]
        starts = np.r_[0, np.flatnonzero(np.diff(idx)) + 1]
        rank = np.arange(len(idx)) - np.repeat(starts, np.diff(np.r_[starts, len(idx)]))
        sizes = np.diff(np.r_[starts, len(idx)])
        alone = np.repeat(sizes, sizes) == 1
        ok = np.where(np.isnan(sol), alone, sol == rank + 1)
        if not ok.all():
            k = int(np.flatnonzero(~ok)[0])
            raise self._refuse(where, f"input {idx[k]}'s solutions are not numbered 1, 2, ... once each "
                                      "(a duplicated or missing row)")

    def write(self, first: int, end: int, table) -> None:
        final = self.path / f"part-{first:09d}-{end:09d}.parquet"
        tmp = temporary_path(final, self.lock.token if self.lock else "unlocked")
        _write_part(table.frame(), tmp, self.fingerprint)
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


def _write_part(frame, path: Path, fingerprint: Fingerprint) -> None:
    """``frame`` as a Parquet file at ``path``, the fingerprint in its schema metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(frame, preserve_index=False)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}), METADATA_KEY: fingerprint.to_json()})
    pq.write_table(table, path)


class CsvSink(Sink):
    """An appended CSV file and its fingerprint sidecar (module doc)."""

    ordered = True

    def __init__(self, path: Path, mechanism, inputs: np.ndarray, resume: bool, fingerprint: Fingerprint):
        super().__init__(path, mechanism, inputs)
        self.fingerprint = fingerprint
        side = sidecar_path(path)
        if resume:
            check_fingerprints(path, fingerprint)
            offset, n_done, note = self._verified_prefix()
            if n_done < len(inputs):               # a finished run's record no longer holds once rows change
                atomic.write_text(side, fingerprint.to_json())
                with open(path, "rb+") as f:       # verified first: a refused resume leaves the file as it was
                    f.truncate(offset)
            if note:
                self.note = f"--resume {path}: {note}"
            self.done[:n_done] = True
            self._file = open(path, "ab", buffering=0)
            if not path.stat().st_size:
                self._append(self._header())
        else:
            side.unlink(missing_ok=True)           # never an old fingerprint beside new rows
            self._file = open(path, "wb", buffering=0)
            atomic.write_text(side, fingerprint.to_json())    # the fingerprint is there before the first row
            self._append(self._header())
        st = os.fstat(self._file.fileno())
        self.identity = (st.st_dev, st.st_ino)

    def _header(self) -> bytes:
        return (",".join(self.columns) + "\n").encode()

    def _append(self, block: bytes) -> None:
        """Append ``block`` to the file, whole or not at all: unbuffered writes (no rows left in a
        buffer for close to flush after an interrupt), and on any exception while writing (an
        interrupt that Python raised between two partial writes, or in the fsync after them) the file
        truncated back to its length before, then the exception raised again."""
        fd = self._file.fileno()
        start = os.fstat(fd).st_size
        try:
            view = memoryview(block)
            while view:
                view = view[self._file.write(view):]
            os.fsync(fd)
        except BaseException:
            os.ftruncate(fd, start)
            raise

    def _finished_length(self) -> int | None:
        """The file's length its sidecar records for a finished run (COMPLETE_KEY), or None."""
        try:
            record = json.loads(sidecar_path(self.path).read_text()).get(COMPLETE_KEY)
            return int(record["bytes"])
        except (OSError, ValueError, TypeError, KeyError, AttributeError):
            return None

    def _verified_prefix(self) -> tuple[int, int, str]:
        """(byte length to keep, inputs it holds, what was dropped beyond whole rows: '' if nothing).

        The header must be this mechanism's. Every complete line after it must be a row of this
        job's table (:meth:`_parse_row`) following the one before it: inputs from 0 in order, each
        input's solutions numbered 1, 2, ... (or one row without a solution). Unreadable lines are
        accepted only at the end, after every row (what a crash leaves), at most
        RESUME_MAX_DROPPED_LINES of them and none a well-formed row of other inputs (another
        writer's, not a crash's); a line cut short too. Anything else is a ValueError naming the
        line. What is kept ends before the last input held: only that one can have been written in
        part, unless the sidecar records the run as finished at this very length (the whole file
        is kept)."""
        kept = (0, 0)                              # (byte offset, input) of the last input's first row
        prev = None                                # (input, solution) of the last row
        unreadable = None                          # (line number, why) of the first unreadable line
        torn = offset = n = 0
        with open(self.path, "rb") as f:
            for n, raw in enumerate(f, start=1):   # streamed: the table is never held in memory
                if not raw.endswith(b"\n"):       # the last line, cut short
                    torn = len(raw)
                    n -= 1
                    break
                raw = raw[:-1]
                if n == 1:
                    self._check_columns(str(self.path), raw.decode(errors="replace").rstrip("\r").split(","))
                    kept = (len(raw) + 1, 0)
                    offset += len(raw) + 1
                    continue
                key, error = self._parse_row(raw)
                if error is not None:
                    if isinstance(key, int):           # a whole row of input `key`, not this job's value
                        raise self._refuse(f"{self.path} line {n}", f"a row of other inputs ({error}): another "
                                           "writer's, not what a crash leaves; pass --overwrite to solve again")
                    unreadable = unreadable or (n, error)
                    if n - unreadable[0] >= RESUME_MAX_DROPPED_LINES:
                        raise self._refuse(f"{self.path} lines {unreadable[0]}..{n}",
                                           f"more than {RESUME_MAX_DROPPED_LINES} unreadable lines at its end (first: "
                                           f"{unreadable[1]}): more than a crash cuts (one chunk's rows)")
                elif unreadable is not None:       # a row after an unreadable line: not a crash's leftovers
                    raise self._refuse(f"{self.path} line {unreadable[0]}", unreadable[1])
                else:
                    k, sol = key
                    nxt = 0 if prev is None else prev[0] + 1
                    if not (k == nxt and sol in (1, None) or prev and prev[1] and (k, sol) == (prev[0], prev[1] + 1)):
                        after = "as the first row" if prev is None else \
                            f"after input {prev[0]} solution {prev[1] or '(none)'}"
                        raise self._refuse(f"{self.path} line {n}", f"input {k} solution {sol or '(none)'} {after} "
                                           "(rows out of order or repeated: not what one run writes)")
                    if prev is None or k != prev[0]:
                        kept = (offset, k)
                    prev = key
                offset += len(raw) + 1
        dropped = []
        if unreadable is not None:
            span = f"line {n}" if unreadable[0] == n else f"lines {unreadable[0]}..{n}"
            dropped.append(f"unreadable {span} at its end ({unreadable[1]})")
        if torn:
            dropped.append(f"a last line cut short ({torn} bytes)")
        note = ""
        if dropped:
            again = f"; input {kept[1]} is solved again (its rows may be incomplete)" if prev is not None else ""
            note = f"dropped {' and '.join(dropped)}{again}"
        elif prev is not None and prev[0] == len(self.inputs) - 1 and self._finished_length() == offset:
            return offset, len(self.inputs), ""    # a finished run, untouched since: every input kept
        return kept[0], kept[1], note

    def _parse_row(self, raw: bytes):
        """(key, None) when the CSV line ``raw`` is a row of this job's table, key its (input,
        solution: None when none); (k, why not) when it is a whole row of this table's form for
        input number k but not with this job's input values (another job's row); (None, why not)
        otherwise."""
        try:
            fields = raw.decode().rstrip("\r").split(",")
        except UnicodeDecodeError:
            return None, "not UTF-8 text"
        if len(fields) != len(self.columns):
            return None, f"expected {len(self.columns)} fields, got {len(fields)}"
        n_act = len(self.mechanism.actuated)
        status, singularity = fields[2 + n_act], fields[-2]
        values = [v for v in fields[3 + n_act:-2] + fields[-1:] if v]
        try:
            k = int(fields[0])
            x = [float(v) for v in fields[1:1 + n_act]]
            sol = int(fields[1 + n_act]) if fields[1 + n_act] else None
            for v in values:
                float(v)
        except ValueError as exc:
            return None, f"a field is not a number ({exc})"
        if not 0 <= k < len(self.inputs):
            return k, f"input {k} is not one of this job's {len(self.inputs)}"
        want = self.inputs[k].tolist()
        if not all(abs(a - b) <= RESUME_MATCH for a, b in zip(x, want)):     # NaN fails too
            return k, f"input {k} is {fields[1:1 + n_act]} there, {want} in this job"
        if sol is None and (status or singularity or values):
            return None, "a row without a solution number has solution values"
        if sol is not None and (sol < 1 or status not in STATUSES or not singularity):
            return None, f"solution {sol} has status {status!r} and singularity {singularity!r}"
        return (k, sol), None

    def write(self, first: int, end: int, table) -> None:
        text = io.StringIO()                       # the block formatted first: an interrupt here writes nothing
        csv.writer(text, lineterminator="\n").writerows(csv_fields(table))
        self._append(text.getvalue().encode())
        if end == len(self.inputs):                # written in order: the last input ends the run's rows
            record = json.loads(self.fingerprint.to_json())
            record[COMPLETE_KEY] = {"bytes": os.fstat(self._file.fileno()).st_size}
            atomic.write_text(sidecar_path(self.path), json.dumps(record, indent=1))

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()
        super().close()


def csv_fields(table) -> Iterator[tuple]:
    """The rows of ``table`` (a :class:`~spherekin.results.ResultsTable`) as CSV fields, for a
    ``csv.writer``: the fields pandas' ``DataFrame.to_csv`` gives the same table (``table.frame()``),
    so a file is the same byte for byte whichever wrote it, without importing pandas (~0.3 s of a
    process). Floats as numpy's shortest round-trip text (``astype(str)``, what pandas does), NaN
    and None empty; the writer quotes as pandas' does (QUOTE_MINIMAL)."""
    cols = []
    for values, dtype in zip(table.data, table.dtypes):
        if dtype == "float64":
            text = values.astype(str).astype(object)
            text[np.isnan(values)] = ""
            cols.append(text.tolist())
        elif dtype == "int64":
            cols.append(values.astype(str).tolist())
        else:
            cols.append(["" if v is None else v for v in values.tolist()])
    return zip(*cols)


def open_sink(path, mechanism, inputs: np.ndarray, resume: bool = False,
              fingerprint: Fingerprint | None = None) -> Sink:
    """The sink of ``path`` (checked with :func:`check_output_path` first), holding the output's lock
    (taken before anything is written; ValueError if another run holds it) until its close: use it
    in a ``with`` block. ``fingerprint``: the job's (:class:`~spherekin.batch.fingerprint.Fingerprint`);
    None: of ``mechanism`` and ``inputs`` with no strategy (an output not written by a batch)."""
    path = Path(path)
    if fingerprint is None:
        fingerprint = Fingerprint.of(mechanism, inputs)
    cls = ParquetSink if path.suffix.lower() == ".parquet" else CsvSink
    lock = OutputLock.acquire(path)
    try:
        sink = cls(path, mechanism, inputs, resume, fingerprint)
        sink.lock = lock
        if lock.previous is not None:              # a run killed while writing: its temporaries
            sink.discard_temporaries(lock.previous.token)
    except BaseException:
        lock.release()
        raise
    return sink


def _read_csv(source, usecols=None):
    """A results CSV (a path, or its bytes) as a DataFrame with the table's column types."""
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
