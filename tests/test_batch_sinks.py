"""spherekin.batch.sinks: output paths checked before work, chunks written as they come, resume."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from spherekin import compile as compile_problem
from spherekin.batch.rows import report_table
from spherekin.batch.sinks import check_output_path, open_sink, read_results, temporary_path

INPUTS = np.array([[0.3, -0.2, 0.5], [-2.5, 2.9, 0.1], [0.1, 0.2, 0.3], [1.0, 0.0, -1.0], [0.2, 0.2, 0.2]])


@pytest.fixture(scope="module")
def tables(mech):
    """The rows of each input, solved one by one (what a sink is handed: ResultsTable)."""
    problem = compile_problem(mech)
    return [report_table(mech, [problem.solve(row)], k, INPUTS[k:k + 1]) for k, row in enumerate(INPUTS)]


@pytest.fixture(scope="module")
def frames(tables):
    """The same rows as DataFrames (the reference the files must hold)."""
    return [t.frame() for t in tables]


def written(path, mech, tables, inputs):
    """``path`` after a run that wrote the rows of ``inputs`` (one chunk each) and stopped."""
    sink = open_sink(path, mech, INPUTS)
    for k in inputs:
        sink.write(k, k + 1, tables[k])
    sink.close()
    return path


@pytest.mark.parametrize("name, match", [("out.txt", "expected a .parquet"), ("out", "suffix '\\(none\\)'"),
                                         ("nodir/out.csv", "does not exist")])
def test_bad_output_paths_are_refused(tmp_path, name, match):
    with pytest.raises(ValueError, match=match):
        check_output_path(tmp_path / name, resume=False, overwrite=False)


def test_existing_output_needs_resume_or_overwrite(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("x\n")
    with pytest.raises(ValueError, match="already exists; pass --resume"):
        check_output_path(p, False, False)
    assert check_output_path(p, True, False) == p
    with pytest.raises(ValueError, match="at most one"):
        check_output_path(p, True, True)
    with pytest.raises(ValueError, match="no earlier output"):
        check_output_path(tmp_path / "new.csv", True, False)
    (tmp_path / "f.parquet").write_text("")
    with pytest.raises(ValueError, match="is a file"):
        check_output_path(tmp_path / "f.parquet", False, True)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_chunks_in_any_order_read_back_in_input_order(tmp_path, mech, tables, frames, suffix):
    path = tmp_path / f"r{suffix}"
    sink = open_sink(path, mech, INPUTS)
    order = [0, 1, 2, 3, 4] if sink.ordered else [3, 0, 4, 2, 1]
    for k in order:
        sink.write(k, k + 1, tables[k])
    sink.close()
    got = read_results(path)
    pd.testing.assert_frame_equal(got, pd.concat(frames, ignore_index=True))


def test_csv_resume_drops_the_last_input_it_holds_and_a_partial_line(tmp_path, mech, tables, frames):
    path = written(tmp_path / "r.csv", mech, tables, range(3))
    text = path.read_text()
    lines = text.splitlines(keepends=True)
    n2 = len(frames[2])
    assert n2 >= 2
    # a run killed while writing input 2: its last row is cut in the middle
    path.write_text("".join(lines[:-1]) + lines[-1][:17])
    resumed = open_sink(path, mech, INPUTS, resume=True)
    assert list(resumed.done) == [True, True, False, False, False]
    for k in (2, 3, 4):
        resumed.write(k, k + 1, tables[k])
    resumed.close()
    pd.testing.assert_frame_equal(read_results(path), pd.concat(frames, ignore_index=True))


class ShortWrites:
    """A file whose writes take at most 64 bytes each and which raises KeyboardInterrupt (Ctrl-C as
    Python raises it: between two calls) once ``armed`` and ``after`` more calls have written."""

    def __init__(self, f):
        self.f, self.armed, self.after, self.cut = f, False, 3, 0

    def write(self, data):
        if self.armed:
            if self.after == 0:
                raise KeyboardInterrupt
            self.after -= 1
        n = self.f.write(bytes(data[:64]))
        self.cut += n if self.armed else 0
        return n

    def __getattr__(self, name):
        return getattr(self.f, name)


def test_an_interrupt_while_a_csv_block_is_written_leaves_only_whole_inputs(tmp_path, mech, tables, frames,
                                                                               monkeypatch):
    files = []
    monkeypatch.setattr("spherekin.batch.sinks.open",
                        lambda *a, **k: files.append(ShortWrites(open(*a, **k))) or files[-1], raising=False)
    path = tmp_path / "r.csv"
    sink = open_sink(path, mech, INPUTS)
    for k in (0, 1):
        sink.write(k, k + 1, tables[k])
    files[-1].armed = True
    with pytest.raises(KeyboardInterrupt):
        sink.write(2, 3, tables[2])
    sink.close()
    assert files[-1].cut == 3 * 64                  # part of input 2's rows had reached the file
    pd.testing.assert_frame_equal(read_results(path), pd.concat(frames[:2], ignore_index=True))


def test_parquet_resume_keeps_the_finished_parts_and_ignores_a_temporary_file(tmp_path, mech, tables, frames):
    path = tmp_path / "r.parquet"
    sink = open_sink(path, mech, INPUTS)
    sink.write(1, 2, tables[1])
    sink.write(3, 4, tables[3])
    cut = temporary_path(path / "part-000000004-000000005.parquet", sink.lock.token)
    cut.write_bytes(b"cut")                     # its write of input 4 cut short
    sink.close()
    resumed = open_sink(path, mech, INPUTS, resume=True)
    assert list(resumed.done) == [False, True, False, True, False]
    assert not cut.exists()
    resumed.close()


def test_resume_refuses_the_output_of_other_inputs(tmp_path, mech, tables):
    path = written(tmp_path / "r.csv", mech, tables, range(3))
    before = path.read_bytes()
    other = INPUTS.copy()
    other[0, 1] += 1e-6
    with pytest.raises(ValueError, match="another job: inputs: 5 inputs .* there, 5 .* with other values"):
        open_sink(path, mech, other, resume=True)
    assert path.read_bytes() == before          # a refused resume changes nothing
    with pytest.raises(ValueError, match="another job: inputs: 5 inputs .* there, 1 "):
        open_sink(path, mech, INPUTS[:1], resume=True)


def test_resume_refuses_a_file_of_another_mechanism(tmp_path, mech):
    path = tmp_path / "r.csv"
    path.write_text("input,a,b\n0,1,2\n1,1,2\n")
    with pytest.raises(ValueError, match="no fingerprint .*pass --overwrite"):
        open_sink(path, mech, INPUTS, resume=True)
    # with this job's fingerprint beside it, the columns are still checked
    from spherekin.batch.fingerprint import Fingerprint, sidecar_path

    sidecar_path(path).write_text(Fingerprint.of(mech, INPUTS).to_json())
    with pytest.raises(ValueError, match="columns are not those of this mechanism"):
        open_sink(path, mech, INPUTS, resume=True)


def test_a_small_job_in_this_process_is_one_parquet_file_and_resumes(tmp_path, mech, frames):
    from spherekin.batch import solve_to_file

    out = tmp_path / "r.parquet"
    summary = solve_to_file(mech, INPUTS[:3], out)            # 3 inputs: in this process (no cluster)
    assert summary.workers == 0 and summary.solved == 3
    assert [p.name for p in out.glob("part-*.parquet")] == ["part-000000000-000000003.parquet"]
    # the rows: those of each input solved alone (the module's reference frames)
    pd.testing.assert_frame_equal(read_results(out), pd.concat(frames[:3], ignore_index=True))
    # a resume of the same job finds it complete; over more inputs it is another job (issue 28)
    again = solve_to_file(mech, INPUTS[:3], out, resume=True)
    assert (again.skipped, again.solved) == (3, 0)
    with pytest.raises(ValueError, match="another job: inputs: 3 inputs \\(array\\) there, 5 \\(array\\)"):
        solve_to_file(mech, INPUTS, out, resume=True)
    # chunks on workers still share the work out: 4 tasks per worker (cluster.TASKS_PER_WORKER)
    from spherekin.batch.engine import CHUNK_INPUTS, default_chunk_size

    assert default_chunk_size(3, 0) == CHUNK_INPUTS
    assert default_chunk_size(16, 2) == 2 and default_chunk_size(3, 2) == 1 and default_chunk_size(10**6, 2) == CHUNK_INPUTS == 256


def test_a_csv_output_is_what_pandas_writes_for_the_table_byte_for_byte(tmp_path, mech):
    """The CSV sink writes its rows without pandas (csv_fields): the file must be the one pandas'
    DataFrame.to_csv (an independent writer) gives the same table, byte for byte, on the values
    where float text and quoting differ most: -0.0, 1e-05 and 1e+16 (where the text turns
    scientific), 1e-300, 0.1 + 0.2, inf, NaN, an entry without residual or rotation, an input
    without solutions, a singularity text holding a comma and a quote; and read back to the same
    floats (the text round-trips)."""
    from spherekin.results import Solution, Status, solution_columns

    names = mech.loop_unknowns
    tricky = np.array([-0.0, 1e-05, 9.999999999999999e-05, 1e16, 9999999999999998.0, 1e-300, 0.1 + 0.2][:len(names)])
    rot = np.array([[0.1 + 0.2, -0.0, 1e-05], [1e16, 1.0, -1e-300], [np.inf, 2.5, -7.0]])
    sols = (Solution(tricky, tricky, tricky, 1, rot, 1e-17, 'serial, "leg 1"', Status.CERTIFIED),
            Solution(-tricky, tricky, tricky, 1, None, None, "regular", Status.UNVERIFIED))
    items = [(0, [0.3, -0.0, 1e-05], names, sols), (1, [np.pi, 1e16, -2.5], names, ()),
             (7, [0.1 + 0.2, 2.0, 3.0], names, sols[1:])]
    table = solution_columns(mech.actuated, names, items, lambda joints: np.full(len(joints[names[0]]), 0.125))
    path = tmp_path / "t.csv"
    with open_sink(path, mech, np.zeros((8, 3))) as sink:
        sink.write(0, 8, table)
    frame = table.frame()
    expected = ",".join(frame.columns) + "\n" + frame.to_csv(header=False, index=False, lineterminator="\n")
    assert path.read_text() == expected
    assert '"serial, ""leg 1"""' in expected and ",-0.0," in expected and ",1e-05," in expected
    back = pd.read_csv(path)
    for name in ("beta1", "beta2", names[0], names[-1], "r11", "r21", "r23", "residual"):
        np.testing.assert_array_equal(back[name].to_numpy(dtype=float), frame[name].to_numpy(dtype=float))


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
@pytest.mark.parametrize("how", ["removed", "replaced"])
def test_an_output_replaced_during_the_run_is_not_reported_as_written(tmp_path, mech, suffix, how):
    """Issue 42 item 11: `rm r.csv; mkdir r.csv` while a batch ran ended with "3649 row(s) written to r.csv".
    The output is compared with the path once the run ends: removed or replaced, the run fails saying so."""
    import shutil

    from spherekin.batch import solve_to_file

    out = tmp_path / f"r{suffix}"

    def progress(done, total):
        if done and out.exists() and not getattr(progress, "fired", False):
            progress.fired = True
            shutil.rmtree(out) if out.is_dir() else out.unlink()
            if how == "replaced":
                (out.mkdir() if suffix == ".csv" else out.write_text("someone else's"))

    # a CSV is written through its open file (compared with the path at the end); a Parquet dataset gets a new
    # file per chunk, whose write then fails: the same one line either way, never a traceback or "written"
    said = (f"{how} during the run: the \\d+ row\\(s\\) written this run are not" if suffix == ".csv"
            else "could not write .*run the same command with --resume")
    with pytest.raises(RuntimeError, match=said):
        solve_to_file(mech, INPUTS[:3], out, chunk_size=1, progress=progress)
    assert progress.fired
