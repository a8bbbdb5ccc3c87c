"""The Dask worker plugin of a batch job (:class:`CompiledProblem`), apart from the engine.

Subclassing ``distributed.WorkerPlugin`` imports distributed (and dask, tornado, ...: ~0.3-0.5 s of
a process's start), which a job in this process (``--workers 0``, a handful of inputs) never uses.
So the plugin lives here and :mod:`spherekin.batch.engine` imports this module only when a job runs
on a cluster.
"""

from __future__ import annotations

import secrets

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["CompiledProblem"]


class CompiledProblem(WorkerPlugin):
    """A Dask worker plugin holding the job's compiled problem, made when a worker sets it up (the
    plugin travels as the mechanism and strategy; every worker, also one that joins later, compiles
    once). Named ``TOKEN-RANDOM@CLIENT_ID``: one run's own (two runs of one job, from one client or
    two, never share one, so neither unregisters the other's), and that of a client the scheduler
    knows (``owner``, ``Client.id``), so a plugin whose client is gone is known to be stale.
    ``job``: a :class:`spherekin.batch.engine.Job`."""

    idempotent = True

    def __init__(self, job, owner: str):
        self.job = job
        self.name = f"{job.token}-{secrets.token_hex(6)}@{owner}"
        self.problem = None

    def setup(self, worker=None):
        self.problem = self.job.compile()

    def teardown(self, worker=None):
        self.problem = None
