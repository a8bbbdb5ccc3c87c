"""spherekin.batch on real Dask clusters on 127.0.0.1: a LocalCluster of 2 worker processes, and a
`dask scheduler` with two `dask worker` processes reached by address from the command line."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from spherekin import batch
from spherekin.batch.engine import chunks

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = str(ROOT / "examples" / "general_3rrr.toml")
BIN = Path(sys.executable).parent


def test_chunks_cover_the_unfinished_inputs_in_order():
    todo = np.array([True, True, True, False, True, True, False, False, True])
    assert chunks(todo, 2) == [(0, 2), (2, 3), (4, 6), (8, 9)]
    assert chunks(todo, 10) == [(0, 3), (4, 6), (8, 9)]
    assert chunks(np.zeros(4, dtype=bool), 3) == []


def test_a_local_cluster_gives_the_table_of_this_process_row_for_row(mech, dask_client):
    rng = np.random.default_rng(11)
    inputs = rng.uniform(-np.pi, np.pi, (30, 3))
    here = batch.solve_many(mech, inputs, workers=0)
    there = batch.solve_many(mech, inputs, client=dask_client, chunk_size=4)
    pd.testing.assert_frame_equal(there, here)
    assert sorted(set(here["input"])) == list(range(30))


def test_a_parquet_dataset_on_the_cluster_and_its_resume(tmp_path, mech, dask_client):
    inputs = np.column_stack([np.linspace(-3, 3, 12), np.full(12, 0.4), np.full(12, -0.7)])
    out = tmp_path / "r.parquet"
    first = batch.solve_to_file(mech, inputs[:12], out, client=dask_client, chunk_size=5)
    assert first.complete and first.solved == 12 and first.workers == 2
    parts = sorted(p.name for p in out.glob("part-*.parquet"))
    assert parts == ["part-000000000-000000005.parquet", "part-000000005-000000010.parquet",
                     "part-000000010-000000012.parquet"]
    (out / parts[1]).unlink()                       # as if the job had stopped before that chunk
    again = batch.solve_to_file(mech, inputs, out, resume=True, client=dask_client, chunk_size=5)
    assert (again.skipped, again.solved) == (7, 5)
    pd.testing.assert_frame_equal(batch.read_results(out), batch.solve_many(mech, inputs, workers=0))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def scheduler_address():
    """`dask scheduler` and two `dask worker` processes on 127.0.0.1; their address."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    procs = [subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)]
    try:
        from distributed import Client

        for _ in range(2):
            procs.append(subprocess.Popen([str(BIN / "dask"), "worker", address, "--nthreads", "1", "--nworkers", "1",
                                           "--no-dashboard", "--host", "127.0.0.1"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        deadline = time.time() + 60
        while True:
            try:
                with Client(address, timeout=5) as c:
                    c.wait_for_workers(2, timeout=60)
                break
            except OSError:
                if time.time() > deadline:
                    raise
                time.sleep(0.5)
        yield address
    finally:
        for p in procs[::-1]:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def spherekin(*args, **kw):
    return subprocess.run([str(BIN / "spherekin"), *args], capture_output=True, text=True, timeout=300, **kw)


def test_the_same_job_by_scheduler_address_gives_the_same_table(tmp_path, scheduler_address):
    csv = tmp_path / "in.csv"
    rng = np.random.default_rng(5)
    rows = rng.uniform(-3, 3, (20, 3))
    csv.write_text("beta2,beta1,beta3\n" + "\n".join(f"{b},{a},{c}" for a, b, c in rows) + "\n")
    here = spherekin("batch", EXAMPLE, "--inputs", str(csv), "--out", str(tmp_path / "here.csv"), "--workers", "0")
    assert here.returncode == 0, here.stderr
    there = spherekin("batch", EXAMPLE, "--inputs", str(csv), "--out", str(tmp_path / "there.csv"),
                      "--scheduler", scheduler_address, "--chunk-size", "3")
    assert there.returncode == 0, there.stderr
    assert "on 2 Dask worker(s)" in there.stdout
    assert (tmp_path / "here.csv").read_text() == (tmp_path / "there.csv").read_text()


def test_an_unreachable_scheduler_is_one_clear_error_and_nothing_is_written(tmp_path):
    out = tmp_path / "r.csv"
    run = spherekin("batch", EXAMPLE, "--grid", "beta1=0:1:5", "--fix", "beta2=0", "--fix", "beta3=0",
                    "--out", str(out), "--scheduler", f"tcp://127.0.0.1:{_free_port()}")
    assert run.returncode == 2
    assert "cannot connect to a Dask scheduler there" in run.stderr and "Traceback" not in run.stderr
    assert not out.exists()


def test_ctrl_c_keeps_what_is_written_and_resume_completes_it(tmp_path):
    out, full = tmp_path / "r.csv", tmp_path / "full.csv"
    grid = ["--grid", "beta1=-3:3:12", "--grid", "beta2=-3:3:12", "--fix", "beta3=0.5"]
    proc = subprocess.Popen([str(BIN / "spherekin"), "batch", EXAMPLE, *grid, "--out", str(out), "--workers", "2",
                             "--chunk-size", "4"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and (not out.exists() or out.read_text().count("\n") < 20):
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGINT)             # Ctrl-C reaches the whole process group
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "run the same command with --resume" in err and "Traceback" not in err
    done = pd.read_csv(out)["input"].nunique()
    assert 0 < done < 144
    resumed = spherekin("batch", EXAMPLE, *grid, "--out", str(out), "--resume", "--workers", "0")
    assert resumed.returncode == 0, resumed.stderr
    assert "(resumed)" in resumed.stdout
    whole = spherekin("batch", EXAMPLE, *grid, "--out", str(full), "--workers", "0")
    assert whole.returncode == 0
    pd.testing.assert_frame_equal(batch.read_results(out), batch.read_results(full))


class _RecordingSink:
    """A sink that needs input order (as CSV) and records what it is given."""

    ordered = True

    def __init__(self, n):
        self.done = np.zeros(n, dtype=bool)
        self.writes = []

    def write(self, first, end, frame):
        self.writes.append((first, end, sorted(set(frame["input"]))))

    def check_in_place(self, written):             # nothing on disk (spherekin.batch.sinks.Sink's protocol)
        pass

    def close(self):
        pass


def test_an_ordered_sink_gets_the_chunks_in_input_order_whatever_order_they_finish(mech, dask_client):
    from spherekin.batch.engine import Job, run

    inputs = np.random.default_rng(3).uniform(-np.pi, np.pi, (24, 3))
    sink = _RecordingSink(len(inputs))
    summary = run(Job.of(mech, {}), inputs, sink, client=dask_client, chunk_size=1)
    assert summary.complete and summary.workers == 2
    assert [w[0] for w in sink.writes] == list(range(24))
    assert all(w[2] in ([w[0]], []) for w in sink.writes)


def test_a_job_runs_in_this_process_while_a_cluster_of_this_machines_cores_would_not_pay(monkeypatch):
    """Issue 42 item 2: where a job runs is chosen from the cores (spherekin.cluster.default_workers) and the
    measured start cost: on one core no job starts a cluster (it cannot be faster); on 2 cores the threshold
    is IN_PROCESS_MAX_INPUTS; more workers pay sooner. No cluster is started here: ``connect`` yields None."""
    import math

    from spherekin.batch import engine

    monkeypatch.setattr(engine, "default_workers", lambda: 1)
    assert engine.in_process_max_inputs(1) == math.inf
    with engine.connect(10 ** 7) as client:
        assert client is None
    monkeypatch.setattr(engine, "default_workers", lambda: 2)
    assert int(engine.in_process_max_inputs(2)) == engine.IN_PROCESS_MAX_INPUTS
    with engine.connect(engine.IN_PROCESS_MAX_INPUTS) as client:
        assert client is None
    limits = [engine.in_process_max_inputs(w) for w in (2, 4, 8, 64)]
    assert limits == sorted(limits, reverse=True) and limits[-1] > engine.CLUSTER_START_S / engine.IN_PROCESS_INPUT_S
