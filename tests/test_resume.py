"""`batch --resume` completes only its own job's output and only with rows it verifies (issue 28, items 1-2).

Each case damages or swaps a real output the way the issue reproduced it, then resumes with the CLI:
the outcome is the table of an uninterrupted run (compared with pandas against a fresh run into
another file) or one error line naming what is wrong, exit 2, with the file left as it was.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from spherekin.batch import read_results
from spherekin.cli import main

ROOT = Path(__file__).resolve().parent.parent
GOSSELIN = str(ROOT / "examples" / "gosselin.toml")
#: 6 inputs (a 3 x 2 grid), in chunks of 2: three chunks, three Parquet parts.
#: Where the fingerprint lives, as docs/results-format.md gives it (spelled out: what users rely on).
METADATA_KEY = b"spherekin.fingerprint"


def sidecar_path(csv: Path) -> Path:
    return csv.with_name(csv.name + ".spherekin.json")


GRID = ["--grid", "beta1=-1:1:3", "--grid", "beta2=-0.5:0.5:2", "--fix", "beta3=0.3"]


def batch(out, *extra, mech=GOSSELIN):
    """The exit status of ``spherekin batch`` of the grid into ``out``, and nothing else."""
    return main(["batch", mech, *GRID, "--out", str(out), "--workers", "0", "--chunk-size", "2", "--quiet", *extra])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The table of an uninterrupted run, and the CSV text it wrote."""
    out = tmp_path_factory.mktemp("ref") / "ref.csv"
    assert batch(out) == 0
    return read_results(out), out.read_text()


def fresh_csv(tmp_path, reference) -> Path:
    """A copy of the reference run's CSV output, with its fingerprint sidecar."""
    out = tmp_path / "r.csv"
    assert batch(out) == 0
    assert out.read_text() == reference[1]
    return out


def lines_of(text: str) -> list[str]:
    return text.splitlines(keepends=True)


def first_line_of(lines, k: int) -> int:
    """The index in ``lines`` (header = 0) of input k's first row."""
    return next(i for i, line in enumerate(lines) if i and line.split(",")[0] == str(k))


def refused_resume(out: Path, text: str, capsys) -> str:
    """``out`` written as ``text``, then resumed: the one error line (exit 2), the file left as it was."""
    out.write_text(text)
    code = batch(out, "--resume")
    err = capsys.readouterr().err.strip()
    assert code == 2 and out.read_text() == text, err
    return err


# ------------------------------------------------------------------ item 1: the fingerprint

@pytest.mark.parametrize("change, options, names", [
    ("distal_link_angles", [], "mechanism: distal_link_angles differs"),
    (None, ["--tol", "1e-8"], "strategy: tol 1e-06 there, 1e-08 in this job"),
    (None, ["--pruner", "hybrid"], "strategy: pruner 'pp' there, 'hybrid' in this job"),
])
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_resume_refuses_the_output_of_another_job(tmp_path, capsys, change, options, names, suffix):
    out = tmp_path / f"r{suffix}"
    assert batch(out) == 0
    mech = GOSSELIN
    if change:                                 # one distal link angle changed: another geometry
        text = Path(GOSSELIN).read_text().replace('distal_link_angles = ["pi/2", "pi/2", "pi/2"]',
                                                  'distal_link_angles = ["pi/2", "pi/2", 1.5]')
        assert "1.5]" in text
        mech = str(tmp_path / "other.toml")
        Path(mech).write_text(text)
    before = read_results(out)
    capsys.readouterr()
    code = batch(out, "--resume", *options, mech=mech)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "another job" in err[0] and names in err[0] and "--overwrite" in err[0], err[0]
    pd.testing.assert_frame_equal(read_results(out), before)     # left as it was


def test_resume_refuses_other_grid_and_another_version(tmp_path, capsys, reference):
    out = fresh_csv(tmp_path, reference)
    code = main(["batch", GOSSELIN, "--grid", "beta1=-1:1:3", "--grid", "beta2=-0.5:0.5:2", "--fix", "beta3=0.4",
                 "--out", str(out), "--workers", "0", "--resume", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "inputs: 6 inputs (grid beta1=-1:1:3 beta2=-0.5:0.5:2 beta3=0.3) there, 6 (grid " \
                          "beta1=-1:1:3 beta2=-0.5:0.5:2 beta3=0.4) in this job with other values" in err, err
    side = sidecar_path(out)
    side.write_text(side.read_text().replace('"spherekin_version": "0.1.0"', '"spherekin_version": "0.0.9"'))
    code = batch(out, "--resume")
    err = capsys.readouterr().err
    assert code == 2 and "spherekin version: 0.0.9 there, 0.1.0 here" in err, err


def test_resume_refuses_a_file_without_fingerprint(tmp_path, capsys, reference):
    out = fresh_csv(tmp_path, reference)
    sidecar_path(out).unlink()                 # as an older spherekin wrote it
    code = batch(out, "--resume")
    err = capsys.readouterr().err
    assert code == 2 and "no fingerprint" in err and "--overwrite" in err, err
    assert batch(out, "--overwrite") == 0 and sidecar_path(out).is_file()
    pd.testing.assert_frame_equal(read_results(out), reference[0])


# ------------------------------------------------------------------ item 2: a CSV's rows

def test_garbage_last_line_drops_the_half_written_input_before_it(tmp_path, capsys, reference):
    out = fresh_csv(tmp_path, reference)
    lines = lines_of(reference[1])
    k3 = first_line_of(lines, 3)
    assert first_line_of(lines, 4) - k3 >= 2   # input 3 has several rows: keep only its first
    assert k3 + 1 == 26                        # so the garbage is line 27 (header = line 1)
    out.write_text("".join(lines[:k3 + 1]) + "\x00\x00#garbage,1,2\n")
    code = batch(out, "--resume")
    err = capsys.readouterr().err
    assert code == 0
    assert (f"spherekin: note: --resume {out}: dropped unreadable line 27 at its end (expected 28 fields, got 3); "
            "input 3 is solved again") in err, err
    pd.testing.assert_frame_equal(read_results(out), reference[0])
    assert out.read_text() == reference[1]


def test_a_line_cut_short_is_dropped_with_its_input(tmp_path, capsys, reference):
    out = fresh_csv(tmp_path, reference)
    lines = lines_of(reference[1])
    k2 = first_line_of(lines, 2)
    out.write_text("".join(lines[:k2 + 1]) + lines[k2 + 1][:20])
    code = batch(out, "--resume")
    err = capsys.readouterr().err
    assert code == 0 and "dropped a last line cut short (20 bytes); input 2 is solved again" in err, err
    assert out.read_text() == reference[1]


@pytest.mark.parametrize("at_end", [False, True])
def test_a_repeated_block_is_refused_naming_its_line(tmp_path, capsys, reference, at_end):
    out = fresh_csv(tmp_path, reference)
    lines = lines_of(reference[1])
    k1, k3, k5 = (first_line_of(lines, k) for k in (1, 3, 5))
    # inputs 0..2, then inputs 1..2 again (then the rest): rows a second writer appended; not a
    # crash's leftovers, so not dropped either (which copy is right is not for a resume to guess)
    err = refused_resume(out, "".join(lines[:k3] + lines[k1:k3] + ([] if at_end else lines[k3:k5])), capsys)
    assert f"{out} line {k3 + 1}: input 1 solution 1 after input 2 solution" in err and "repeated" in err, err


def test_empty_actuator_cells_are_not_an_input_without_solution(tmp_path, capsys, reference):
    out = fresh_csv(tmp_path, reference)
    lines = lines_of(reference[1])
    k2 = first_line_of(lines, 2)
    n_fields = lines[0].count(",") + 1
    blank = "2" + "," * (n_fields - 1) + "\n"  # input 2, every other cell empty
    # in the middle: refused, naming the line
    out.write_text("".join(lines[:k2] + [blank] + lines[first_line_of(lines, 3):]))
    before = out.read_bytes()
    code = batch(out, "--resume")
    err = capsys.readouterr().err.strip()
    assert code == 2 and f"{out} line {k2 + 1}: a field is not a number" in err, err
    assert out.read_bytes() == before
    # at the end: input 2 is solved again, never "no solution"
    out.write_text("".join(lines[:k2] + [blank]))
    assert batch(out, "--resume") == 0
    pd.testing.assert_frame_equal(read_results(out), reference[0])


def test_resume_of_a_finished_csv_solves_nothing_and_keeps_it_byte_for_byte(tmp_path, capsys, reference):
    # issue 42 item 17: a finished run's last input was solved again by every --resume
    out = fresh_csv(tmp_path, reference)
    capsys.readouterr()
    assert batch(out, "--resume") == 0
    printed = capsys.readouterr().out
    assert "6 input(s) were already in" in printed and "0 input(s) solved" in printed, printed
    assert out.read_text() == reference[1]
    # the record holds only for the file as the run left it: one row fewer, input 5 is solved again
    lines = lines_of(reference[1])
    assert len(lines) - first_line_of(lines, 5) >= 2
    out.write_text("".join(lines[:-1]))
    assert batch(out, "--resume") == 0
    printed = capsys.readouterr().out
    assert "5 input(s) were already in" in printed and "1 input(s) solved" in printed, printed
    assert out.read_text() == reference[1]


def test_rows_of_another_job_are_refused_not_dropped(tmp_path, capsys, reference):
    # issue 42 item 8: another job's well-formed rows (two jobs through two links to one file) were
    # deleted by a resume as "unreadable lines at its end"
    out = fresh_csv(tmp_path, reference)
    other = tmp_path / "other.csv"
    assert main(["batch", GOSSELIN, "--grid", "beta1=-1:1:3", "--grid", "beta2=0.1:0.7:2", "--fix", "beta3=0.3",
                 "--out", str(other), "--workers", "0", "--quiet"]) == 0
    lines, theirs = lines_of(reference[1]), lines_of(other.read_text())
    k3 = first_line_of(lines, 3)
    for text in ("".join(lines[:1] + theirs[1:]),                       # the whole table another job's
                 "".join(lines[:k3] + theirs[first_line_of(theirs, 3):])):  # its rows after ours
        err = refused_resume(out, text, capsys)
        line = 2 if text.startswith(lines[0] + theirs[1]) else k3 + 1
        assert f"{out} line {line}: a row of other inputs (input " in err and "another writer" in err, err


def test_more_unreadable_lines_than_a_crash_leaves_are_refused(tmp_path, capsys, reference):
    from spherekin.batch.sinks import RESUME_MAX_DROPPED_LINES

    out = fresh_csv(tmp_path, reference)
    lines = lines_of(reference[1])
    k3 = first_line_of(lines, 3)
    for extra, refused in ((RESUME_MAX_DROPPED_LINES, False), (RESUME_MAX_DROPPED_LINES + 1, True)):
        out.write_text("".join(lines[:k3]) + "\x00\x00\n" * extra)
        code = batch(out, "--resume")
        err = capsys.readouterr().err.strip()
        if refused:
            assert code == 2 and f"{out} lines {k3 + 1}..{k3 + extra}: more than" in err, err
        else:
            assert code == 0 and f"dropped unreadable lines {k3 + 1}..{k3 + extra} at its end" in err, err
            assert out.read_text() == reference[1]


# ------------------------------------------------------------------ item 2: Parquet parts

@pytest.fixture
def dataset(tmp_path, reference):
    out = tmp_path / "r.parquet"
    assert batch(out) == 0
    parts = sorted(out.glob("part-*.parquet"))
    assert [p.name for p in parts] == [f"part-{a:09d}-{a + 2:09d}.parquet" for a in (0, 2, 4)]
    pd.testing.assert_frame_equal(read_results(out), reference[0])
    return out, parts


def rewrite(src: Path, dst: Path, change=None) -> None:
    """``src``'s rows (``change``d) written to ``dst`` with ``src``'s schema metadata (its fingerprint)."""
    table = pq.read_table(src)
    frame = table.to_pandas()
    if change:
        frame = change(frame)
    new = pa.Table.from_pandas(frame, preserve_index=False).replace_schema_metadata(table.schema.metadata)
    assert METADATA_KEY in new.schema.metadata
    pq.write_table(new, dst)


def test_parquet_overlapping_part_is_refused_naming_both(tmp_path, capsys, dataset, reference):
    out, parts = dataset
    # inputs 1..2 written again as their own part (a second run with other chunks)
    rewrite(parts[0], out / "part-000000001-000000003.parquet",
            lambda f: pd.concat([f[f.input == 1], pd.read_parquet(parts[1]).query("input == 2")]))
    parts[2].unlink()
    code = batch(out, "--resume")
    err = capsys.readouterr().err.strip()
    assert code == 2 and "part-000000000-000000002.parquet and part-000000001-000000003.parquet" in err, err
    assert "both hold inputs 1..1" in err
    (out / "part-000000001-000000003.parquet").unlink()       # the duplicate removed: completes
    assert batch(out, "--resume") == 0
    pd.testing.assert_frame_equal(read_results(out), reference[0])


def test_parquet_part_with_nan_input_is_refused(tmp_path, capsys, dataset):
    out, parts = dataset

    def nan_input(f):
        f.loc[f.index[0], "beta2"] = float("nan")
        return f

    rewrite(parts[1], parts[1], nan_input)
    parts[2].unlink()
    code = batch(out, "--resume")
    err = capsys.readouterr().err.strip()
    assert code == 2 and f"{parts[1].name}: input 2 there is [" in err and "nan" in err, err


def test_parquet_part_with_a_duplicate_row_is_refused(tmp_path, capsys, dataset):
    out, parts = dataset
    rewrite(parts[1], parts[1], lambda f: pd.concat([f, f.iloc[:1]]))
    code = batch(out, "--resume")
    err = capsys.readouterr().err.strip()
    assert code == 2 and f"{parts[1].name}: input 2's solutions are not numbered" in err, err


def test_parquet_corrupt_part_is_refused_naming_it(tmp_path, capsys, dataset):
    out, parts = dataset
    data = parts[2].read_bytes()
    parts[2].write_bytes(data[:len(data) // 2])
    code = batch(out, "--resume")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and f"{parts[2].name}: it cannot be read" in err[0], err


def test_parquet_part_without_fingerprint_is_refused(tmp_path, capsys, dataset, reference):
    out, parts = dataset
    pd.read_parquet(parts[0]).to_parquet(parts[0], index=False)      # as an older spherekin wrote it
    code = batch(out, "--resume")
    err = capsys.readouterr().err
    assert code == 2 and f"{parts[0].name}: it has no fingerprint" in err and "--overwrite" in err, err


def test_another_jobs_output_is_refused_before_a_cluster_is_reached(tmp_path, reference):
    """The fingerprint is compared before connecting: the error is the fingerprint's, not the
    unreachable scheduler's (nothing listens on port 1)."""
    from spherekin.batch import grid_inputs, solve_to_file
    from spherekin.mechanism import load_mechanism

    out = fresh_csv(tmp_path, reference)
    mech = load_mechanism(GOSSELIN)
    inputs = grid_inputs(mech, ["beta1=-1:1:3", "beta2=-0.5:0.5:2"], ["beta3=0.3"])
    with pytest.raises(ValueError, match="another job: strategy: tol 1e-06 there, 0.0001 in this job"):
        solve_to_file(mech, inputs, out, resume=True, scheduler="tcp://127.0.0.1:1", tol=1e-4)
