"""spherekin.cluster: where parallel work runs (a real LocalCluster on 127.0.0.1, from conftest), and
where an embedded one may start (scripts run in fresh interpreters)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import cloudpickle
import numpy as np
import pytest

from spherekin.cluster import connect, map_in_order, n_workers


def slow_square(x):
    """x^2, slower for the early items, so that later items finish first."""
    time.sleep(0.02 * (10 - x) if x < 10 else 0)
    if x == 99:
        raise ArithmeticError("item 99")
    return x * x


@pytest.fixture
def by_value():
    """This test module's functions travel by value to the workers (they cannot import it)."""
    module = sys.modules[__name__]
    cloudpickle.register_pickle_by_value(module)
    yield
    cloudpickle.unregister_pickle_by_value(module)


def test_map_in_order_on_workers_keeps_the_order_of_the_items(dask_client, by_value):
    assert n_workers(dask_client) == 2
    assert list(map_in_order(dask_client, slow_square, range(12))) == [x * x for x in range(12)]


def test_map_in_order_here_and_a_failing_task_raises(dask_client, by_value):
    assert list(map_in_order(None, slow_square, [3, 11])) == [9, 121]
    with pytest.raises(ArithmeticError, match="item 99"):
        list(map_in_order(dask_client, slow_square, [10, 99, 11]))


@pytest.mark.parametrize("kw, match", [(dict(workers=-1), "workers: expected a whole number >= 0"),
                                       (dict(workers=True), "workers: expected"),
                                       (dict(client=object(), scheduler="tcp://x:1"), "at most one"),
                                       (dict(scheduler="nowhere"), "expected an address such as"),
                                       (dict(scheduler="tcp://127.0.0.1:notaport"), "with a port number")])
def test_bad_connections_are_named_before_any_work(kw, match):
    with pytest.raises(ValueError, match=match):
        with connect(**kw):
            pass


def test_workers_zero_is_this_process():
    with connect(workers=0) as c:
        assert c is None and n_workers(c) == 0


# --- where an embedded local cluster may start (issue 27, item 4) ---------------------------------
# Each case is a real interpreter running a file written to tmp_path (the worker processes of a
# local cluster run the main script again: only a fresh process has the __main__ in question).

ROOT = Path(__file__).resolve().parents[1]
#: Seconds a script of these tests may take before the test fails (a hung cluster start).
SCRIPT_TIMEOUT = 300


def run_python(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    """``python *args`` in a fresh interpreter, in ``cwd``, with this checkout on the path."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=SCRIPT_TIMEOUT)


PRINT = "from spherekin.cluster import local_cluster_unsafe\nprint(repr(local_cluster_unsafe()))\n"
GUARD_CASES = {
    "unguarded script": ({"s.py": PRINT}, ["s.py"], "line 2, which starts this job, is not under"),
    "guarded script": ({"s.py": 'if __name__ == "__main__":\n' + textwrap.indent(PRINT, "    ")}, ["s.py"], None),
    "guard with the operands swapped, a call over several lines in a function": (
        {"s.py": "from spherekin.cluster import local_cluster_unsafe\n"
                 "def main():\n    print(repr(local_cluster_unsafe()))\n"
                 "if '__main__' == __name__:\n    x = 1\n    main(\n    )\n"}, ["s.py"], None),
    "code after the guard block": ({"s.py": 'if __name__ == "__main__":\n    pass\n' + PRINT}, ["s.py"],
                                   "line 4, which starts this job"),
    "thread of a guarded script": ({"s.py": "import threading\nfrom spherekin.cluster import local_cluster_unsafe\n"
                                            "def work():\n    print(repr(local_cluster_unsafe()))\n"
                                            'if __name__ == "__main__":\n    t = threading.Thread(target=work)\n'
                                            "    t.start()\n    t.join()\n"}, ["s.py"], None),
    "python -c": ({}, ["-c", PRINT], None),
    "python -m of a package's __main__ (as python -m spherekin)": ({"pkg/__init__.py": "", "pkg/__main__.py": PRINT},
                                                                   ["-m", "pkg"], None),
    "python -m of an unguarded module": ({"mod.py": PRINT}, ["-m", "mod"], "is not under"),
    "the fork method runs nothing again": (
        {"s.py": 'import dask\ndask.config.set({"distributed.worker.multiprocessing-method": "fork"})\n' + PRINT},
        ["s.py"], None),
    "the forkserver method runs the script again too": (
        {"s.py": 'import dask\ndask.config.set({"distributed.worker.multiprocessing-method": "forkserver"})\n' + PRINT},
        ["s.py"], "line 4, which starts this job, is not under"),
    "a frozen executable": ({"s.py": "import sys\nsys.frozen = True\n" + PRINT}, ["s.py"], "frozen executable"),
}


@pytest.mark.parametrize("case", list(GUARD_CASES))
def test_local_cluster_unsafe_where_workers_would_run_the_main_script_again(tmp_path, case):
    files, args, reason = GUARD_CASES[case]
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    proc = run_python(tmp_path, *args)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout.strip()
    if reason is None:
        assert out == "None"
    else:
        assert reason in out


#: The batch of the end-to-end scripts: a few random inputs of the general 3-RRR on 2 workers.
BATCH = """\
import numpy as np
from spherekin import batch
from spherekin.mechanism import general_3rrr

inputs = np.random.default_rng(5).uniform(-np.pi, np.pi, (6, 3))
summary = batch.solve_to_file(general_3rrr(), inputs, "out.csv", workers=2)
print("workers", summary.workers)
"""


def check_batch_table(path: Path) -> None:
    """The table of BATCH against another route: spherekin.solve of each input, one at a time."""
    import pandas as pd

    import spherekin
    from spherekin.mechanism import general_3rrr

    mech = general_3rrr()
    table = pd.read_csv(path)
    inputs = np.random.default_rng(5).uniform(-np.pi, np.pi, (6, 3))
    assert sorted(table["input"].unique()) == list(range(6))
    for i, x in enumerate(inputs):
        rows = table[(table["input"] == i) & table["status"].notna()]
        report = spherekin.solve(mech, x)
        assert len(rows) == len(report.solutions)
        got = sorted(tuple(np.round(r[["gamma1", "delta1", "gamma2"]].to_numpy(float), 6)) for _, r in rows.iterrows())
        want = sorted(tuple(np.round([s.passive_angles[n] for n in ("gamma1", "delta1", "gamma2")], 6))
                      for s in report.solutions)
        np.testing.assert_allclose(got, want, atol=1e-5)
        np.testing.assert_allclose(rows[["beta1", "beta2", "beta3"]].to_numpy(float), np.tile(x, (len(rows), 1)))


def test_an_unguarded_script_runs_the_batch_here_says_why_once_and_gets_the_table(tmp_path):
    (tmp_path / "s.py").write_text(BATCH + "again = batch.solve_many(general_3rrr(), inputs[:1], workers=2)\n"
                                           "print('again', again['input'].nunique())\n")
    proc = run_python(tmp_path, "s.py")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["workers", "0", "again", "1"]
    warned = [line for line in proc.stderr.splitlines() if "RuntimeWarning" in line]
    assert len(warned) == 1, proc.stderr
    assert warned[0].startswith(f"{tmp_path / 's.py'}:6: RuntimeWarning: spherekin runs this job in this process")
    assert 'if __name__ == "__main__":' in warned[0] and "scheduler= or client=" in warned[0]
    check_batch_table(tmp_path / "out.csv")


def test_a_guarded_script_runs_the_batch_on_a_local_cluster(tmp_path):
    (tmp_path / "s.py").write_text('if __name__ == "__main__":\n' + textwrap.indent(BATCH, "    "))
    proc = run_python(tmp_path, "s.py")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["workers", "2"]
    assert "RuntimeWarning" not in proc.stderr
    check_batch_table(tmp_path / "out.csv")


def test_solve_with_jobs_in_an_unguarded_script_runs_here_and_says_why(tmp_path):
    (tmp_path / "s.py").write_text("import spherekin\nfrom spherekin.mechanism import gosselin\n"
                                   "rep = spherekin.solve(gosselin(), (0.3, -0.2, 0.5), formulation='halves', jobs=2)\n"
                                   "print(len(rep.solutions), sum(s.status == 'singular' for s in rep.solutions), "
                                   "rep.settings.jobs)\n")
    proc = run_python(tmp_path, "s.py")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split()[:2] == ["8", "4"]      # the paper's count at its inputs: 8, 4 of them singular
    assert proc.stdout.split()[2] == "1"              # the settings say where it ran: one process, not 2 jobs
    assert f"{tmp_path / 's.py'}:3: RuntimeWarning: spherekin runs this job in this process" in proc.stderr


def test_embedded_workers_run_without_daskss_malloc_trim_threshold(tmp_path):
    """Issue 42 item 2: Dask's nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536, which turns off
    glibc's adaptive mmap threshold and made each worker ~2x slower than this process on the engine's
    arrays (cluster.WORKER_CONFIG). The embedded cluster's workers must not have it; the rest of Dask's
    worker environment (one BLAS thread per worker) stays. A fresh interpreter: an earlier cluster of
    this test session may have set the variable in this process's environment."""
    script = ('import os\nfrom spherekin.cluster import connect\nif __name__ == "__main__":\n'
              '    os.environ.pop("MALLOC_TRIM_THRESHOLD_", None)\n'
              '    with connect(workers=1) as c:\n'
              '        got = c.run(lambda: (os.environ.get("MALLOC_TRIM_THRESHOLD_"), os.environ.get("OMP_NUM_THREADS")))\n'
              '        print(list(got.values())[0])\n')
    (tmp_path / "s.py").write_text(script)
    proc = run_python(tmp_path, "s.py")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "(None, '1')", proc.stdout


def test_the_families_guides_dask_config_unsets_the_trim_threshold():
    """The YAML block docs/howto/families.md gives for workers of one's own, read as Dask reads a config
    file, leaves MALLOC_TRIM_THRESHOLD_ out of the environment a nanny gives its worker."""
    import re

    import dask
    import yaml
    from distributed.nanny import _get_env_variables

    page = (ROOT / "docs" / "howto" / "families.md").read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", page, flags=re.S)
    assert len(blocks) == 1
    config = yaml.safe_load(blocks[0])
    merged = dask.config.merge(dask.config.config, config)     # as Dask merges a config file into its defaults
    key = "distributed.nanny.pre-spawn-environ"
    saved = os.environ.pop("MALLOC_TRIM_THRESHOLD_", None)     # an earlier cluster of this session may have set it
    try:
        with dask.config.set({key: merged["distributed"]["nanny"]["pre-spawn-environ"]}):
            env = _get_env_variables("distributed.nanny.pre-spawn-environ")
        assert "MALLOC_TRIM_THRESHOLD_" not in env and env.get("OMP_NUM_THREADS") == "1"
        assert _get_env_variables("distributed.nanny.pre-spawn-environ")["MALLOC_TRIM_THRESHOLD_"] == "65536"
    finally:
        if saved is not None:
            os.environ["MALLOC_TRIM_THRESHOLD_"] = saved
