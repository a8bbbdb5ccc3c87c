"""One writer per output (issue 28, item 3): the lock file ``<out>.lock`` (spherekin.batch.lock), on
real `spherekin` processes where it matters: a second run refused while the first writes (the first
paused with SIGSTOP, so the refusal does not depend on timing), a stale lock taken over, a lock of
another host refused, Ctrl-C releasing the lock; and the per-run names of Parquet temporaries."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from spherekin.batch import read_results
from spherekin.batch.lock import OutputLock, lock_path
from spherekin.batch.sinks import check_output_path, open_sink, temporary_path
from spherekin.cli import main
from spherekin.mechanism import general_3rrr

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = str(ROOT / "examples" / "general_3rrr.toml")
BIN = Path(sys.executable).parent
GRID = ["--grid", "beta1=-3:3:6", "--grid", "beta2=-3:3:6", "--fix", "beta3=0.5"]     # 36 inputs
SMALL = ["--grid", "beta1=0:1:3", "--fix", "beta2=0.2", "--fix", "beta3=0.5"]           # 3 inputs
LONG_AGO = "2026-01-02T03:04:05+00:00"
#: Deadline (seconds) of a wait for a child process to reach a state; not a measured time: only
#: a bound that ends a test that would otherwise hang.
DEADLINE = 120


def spherekin(*args, **kw):
    return subprocess.run([str(BIN / "spherekin"), *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, **kw)


def start(*args):
    """A `spherekin` process in its own process group (for SIGINT to the group, as Ctrl-C sends it)."""
    return subprocess.Popen([str(BIN / "spherekin"), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, env={**os.environ, "PYTHONPATH": str(ROOT)})


def wait_until(condition, proc):
    deadline = time.time() + DEADLINE
    while not condition():
        assert proc.poll() is None, proc.communicate()
        assert time.time() < deadline, "the child never got there"
        time.sleep(0.05)


def dead_pid() -> int:
    """The pid of a process that has ended (spawned and waited for here)."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def write_lock(out: Path, pid: int, host: str, token: str = "1-deadbeef", started: str | None = None) -> Path:
    """The lock of another run (``started``: now by default, so a live ``pid`` is its holder)."""
    started = started or datetime.now(timezone.utc).isoformat(timespec="seconds")
    lock = lock_path(out)
    lock.write_text(json.dumps({"pid": pid, "host": host, "started": started,
                                "command": "spherekin batch other.toml", "token": token}) + "\n")
    return lock


@pytest.fixture(scope="module")
def alone(tmp_path_factory):
    """The table of GRID written by a single run (the one the first of two runs must still give)."""
    out = tmp_path_factory.mktemp("alone") / "alone.csv"
    ref = spherekin("batch", EXAMPLE, *GRID, "--out", str(out), "--workers", "0")
    assert ref.returncode == 0, ref.stderr
    return read_results(out)


def rows_in(path: Path) -> int:
    return path.read_text().count("\n") if path.exists() else 0


@pytest.mark.parametrize("second", [["--overwrite", "--chunk-size", "5", *GRID],                 # same job, other chunks
                                    ["--overwrite", "--grid", "beta1=-1:1:4", "--fix", "beta2=0", "--fix",
                                     "beta3=0"],                                                    # another job
                                    ["--resume", *GRID]])
def test_a_second_run_on_one_output_is_refused_and_the_first_table_is_whole(tmp_path, alone, second):
    out = tmp_path / "r.csv"
    first = start("batch", EXAMPLE, *GRID, "--out", str(out), "--workers", "0", "--chunk-size", "3")
    try:
        wait_until(lambda: rows_in(out) > 4, first)               # the lock taken, rows being written
        os.kill(first.pid, signal.SIGSTOP)                        # paused: still the writer, whatever the timing
        refused = spherekin("batch", EXAMPLE, *second, "--out", str(out), "--workers", "0")
        assert refused.returncode == 2, refused.stderr
        assert f"another run is writing it (pid {first.pid} on host {socket.gethostname()}, since " in refused.stderr
        assert refused.stderr.count("\n") == 1 and "Traceback" not in refused.stderr
        assert refused.stdout == ""                                # refused before any work
    finally:
        os.kill(first.pid, signal.SIGCONT)
    _, err = first.communicate(timeout=DEADLINE)
    assert first.returncode == 0, err
    assert not lock_path(out).exists()                            # released at the end
    got = read_results(out)
    assert sorted(set(got["input"])) == list(range(36))           # every input, and each solution once:
    assert not got.duplicated(["input", "solution"]).any()
    pd.testing.assert_frame_equal(got, alone)


def test_parquet_temporaries_of_the_writer_survive_a_refused_second_run(tmp_path):
    out = tmp_path / "r.parquet"
    first = start("batch", EXAMPLE, *GRID, "--out", str(out), "--workers", "0", "--chunk-size", "3")
    try:
        wait_until(lambda: len(list(out.glob("part-*.parquet"))) >= 2, first)
        os.kill(first.pid, signal.SIGSTOP)
        token = json.loads(lock_path(out).read_text())["token"]
        assert token.startswith(f"{first.pid}-")
        mine = temporary_path(out / "part-000000033-000000036.parquet", token)
        mine.write_bytes(b"a part being written")                 # as if it were paused mid-write
        for flag in ("--overwrite", "--resume"):
            refused = spherekin("batch", EXAMPLE, *GRID, "--out", str(out), flag, "--workers", "0")
            assert refused.returncode == 2 and f"pid {first.pid}" in refused.stderr, refused.stderr
            assert mine.read_bytes() == b"a part being written"
        other = temporary_path(out / "part-000000000-000000003.parquet", "77-0badc0de")
        other.write_bytes(b"another run's")
    finally:
        os.kill(first.pid, signal.SIGCONT)
    _, err = first.communicate(timeout=DEADLINE)
    assert first.returncode == 0, err
    assert not mine.exists()                                      # its own: deleted at its close
    assert other.read_bytes() == b"another run's"                 # not its own: left alone
    assert sorted(set(read_results(out)["input"])) == list(range(36))


def test_temporary_names_are_per_run_and_hidden():
    final = Path("/d/r.parquet/part-000000000-000000064.parquet")
    a, b = temporary_path(final, "12-aa"), temporary_path(final, "13-bb")
    assert a == Path("/d/r.parquet/.part-000000000-000000064.parquet.12-aa.tmp") and a != b
    assert not a.match("part-*.parquet")                           # never read as a part


def test_a_run_deletes_only_its_own_temporaries(tmp_path):
    mech = general_3rrr()
    out = tmp_path / "r.parquet"
    out.mkdir()
    foreign = temporary_path(out / "part-000000000-000000001.parquet", "4242-cafe")
    foreign.write_bytes(b"x")
    with open_sink(out, mech, np.zeros((2, 3))) as sink:
        assert sink.lock.token.startswith(f"{os.getpid()}-")
        assert foreign.exists()                                   # not deleted at the opening
        own = temporary_path(out / "part-000000001-000000002.parquet", sink.lock.token)
        own.write_bytes(b"cut")                                   # a write cut short
    assert not own.exists() and foreign.exists()
    assert not lock_path(out).exists()


def test_a_stale_lock_is_taken_over_with_a_note(tmp_path):
    out = tmp_path / "r.parquet"
    out.mkdir()
    pid = dead_pid()
    write_lock(out, pid, socket.gethostname(), token=f"{pid}-0dead", started=LONG_AGO)
    left = temporary_path(out / "part-000000000-000000003.parquet", f"{pid}-0dead")
    left.write_bytes(b"cut by kill -9")
    run = spherekin("batch", EXAMPLE, *SMALL, "--out", str(out), "--overwrite", "--workers", "0")
    assert run.returncode == 0, run.stderr
    assert (f"took over the lock of a run that is no longer alive (pid {pid} on host {socket.gethostname()}, "
            "since 2026-01-02T03:04:05+00:00: spherekin batch other.toml)") in run.stderr
    assert not left.exists()                                      # the dead run's temporary
    assert not lock_path(out).exists()
    assert sorted(read_results(out)["input"].unique()) == [0, 1, 2]


def test_a_lock_of_another_host_is_refused_with_the_advice(tmp_path):
    out = tmp_path / "r.csv"
    lock = write_lock(out, 1, "elsewhere.invalid", started=LONG_AGO)
    before = lock.read_text()
    run = spherekin("batch", EXAMPLE, *SMALL, "--out", str(out), "--workers", "0")
    assert run.returncode == 2
    assert run.stderr == (f"spherekin: error: --out {out}: locked by a run on another host (pid 1 on host "
                          "elsewhere.invalid, since 2026-01-02T03:04:05+00:00: spherekin batch other.toml); whether "
                          f"it is still writing cannot be told from {socket.gethostname()}: if you are sure it has "
                          f"ended, delete {lock} and run again\n")
    assert not out.exists() and lock.read_text() == before


def test_ctrl_c_releases_the_lock(tmp_path):
    out = tmp_path / "r.csv"
    proc = start("batch", EXAMPLE, *GRID, "--out", str(out), "--workers", "0", "--chunk-size", "2")
    wait_until(lambda: rows_in(out) > 4, proc)
    assert lock_path(out).exists()
    os.killpg(proc.pid, signal.SIGINT)                            # Ctrl-C reaches the whole process group
    _, err = proc.communicate(timeout=DEADLINE)
    assert proc.returncode == 130, err
    assert not lock_path(out).exists()
    resumed = spherekin("batch", EXAMPLE, *GRID, "--out", str(out), "--resume", "--workers", "0")
    assert resumed.returncode == 0, resumed.stderr


def test_the_lock_is_atomic_and_released_only_by_its_holder(tmp_path):
    out = tmp_path / "r.csv"
    with OutputLock.acquire(out) as lock:
        with pytest.raises(ValueError, match=f"another run is writing it \\(pid {os.getpid()} "):
            OutputLock.acquire(out)                                # this process is alive: not stale
        assert json.loads(lock_path(out).read_text())["token"] == lock.token
    assert not lock_path(out).exists()
    write_lock(out, os.getpid(), socket.gethostname(), token="other")
    lock.release()                                                 # not its lock any more: left alone
    assert lock_path(out).exists()


def test_a_lock_whose_pid_now_names_a_younger_process_is_stale(tmp_path, capsys):
    out = tmp_path / "r.csv"
    younger = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    try:
        write_lock(out, younger.pid, socket.gethostname(), started=LONG_AGO)   # the pid reused since
        with OutputLock.acquire(out) as lock:
            assert lock.previous.pid == younger.pid
        assert f"took over the lock of a run that is no longer alive (pid {younger.pid} " in capsys.readouterr().err
        write_lock(out, younger.pid, socket.gethostname())                    # written after it started: its own
        with pytest.raises(ValueError, match=f"another run is writing it \\(pid {younger.pid} "):
            OutputLock.acquire(out)
    finally:
        younger.kill()
        younger.wait()


@pytest.mark.parametrize("command", [
    ["batch", EXAMPLE, *SMALL, "--out", "{out}"],
    ["map", EXAMPLE, "--grid", "beta1=0:1:2", "--grid", "beta2=0:1:2", "--fix", "beta3=0", "--out", "{out}"],
    ["track", EXAMPLE, "--path", str(ROOT / "examples" / "path_general_3rrr.csv"), "--start-solution", "1",
     "--out", "{out}"],
])
def test_batch_map_and_track_are_refused_before_any_work(tmp_path, capsys, command):
    out = tmp_path / "r.csv"
    write_lock(out, os.getpid(), socket.gethostname())            # a live writer (this process)
    code = main([a.replace("{out}", str(out)) for a in command])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert f"--out {out}: another run is writing it (pid {os.getpid()} " in captured.err
    assert not out.exists()


def test_the_lock_is_checked_before_whether_the_output_exists(tmp_path):
    out = tmp_path / "r.csv"
    out.write_text("input\n")
    write_lock(out, os.getpid(), socket.gethostname())
    with pytest.raises(ValueError, match="another run is writing it"):
        check_output_path(out, resume=False, overwrite=False)     # not "already exists; pass --resume"


def test_two_symbolic_links_to_one_output_share_one_lock(tmp_path):
    """Issue 42 item 8: two runs writing one CSV through two symbolic links both went ahead (the lock stood
    beside each name). The lock stands beside the file itself: the second run is refused."""
    from spherekin.batch.lock import check_unlocked

    real = tmp_path / "data" / "r.csv"
    real.parent.mkdir()
    real.write_text("")
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.symlink_to(real)
    b.symlink_to(real)
    assert lock_path(a) == lock_path(b) == real.with_name("r.csv.lock")
    with OutputLock.acquire(a):
        with pytest.raises(ValueError, match="another run is writing it"):
            check_unlocked(b)
        with pytest.raises(ValueError, match="another run is writing it"):
            OutputLock.acquire(b)
    check_unlocked(b)                                   # released: free again


def test_a_hard_linked_output_is_refused_before_any_work(tmp_path):
    """A hard link cannot be resolved to one name: the output with other names is refused (one line)."""
    from spherekin.batch.lock import check_unlocked

    real = tmp_path / "r.csv"
    real.write_text("")
    os.link(real, tmp_path / "other.csv")
    for check in (check_unlocked, OutputLock.acquire):
        with pytest.raises(ValueError, match="has 2 names \\(hard links\\)"):
            check(real)
