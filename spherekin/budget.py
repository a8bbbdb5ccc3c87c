"""What may end a long run before its work is done: a signal, or the memory cap (issue 40 item 5).

A :class:`Budget` is handed to the long searches (the singular-set cover: :func:`spherekin.singular`); they ask
:meth:`Budget.exhausted` between steps, and once it names a reason they stop as at their box cap: what was not
processed is handed back (pending), never dropped, and the result says it is incomplete and why. The command line
(:mod:`spherekin.cli`) turns the first Ctrl-C or SIGTERM into :meth:`Budget.stop`, so an interrupted run still
reports, and writes, what it had found; a second signal ends it at once.

The memory cap is the process's resident memory (psutil, which Dask's distributed already requires), read at
most every MEMORY_CHECK_SECONDS: a run stops when it passes the cap, before the machine runs out (at T = 1e-6
over a whole plane the cover grew ~160 MB/s to a MemoryError). Each step must allocate in bounded batches for
the check between steps to bound the run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

__all__ = ["Budget", "MEMORY_FRACTION", "MEMORY_CHECK_SECONDS", "default_max_memory", "MEMORY", "SIGNALS"]

#: Default memory cap: this fraction of the machine's physical memory. Reason: leaves a quarter for the system
#: and other processes, while the largest complete runs measured fit (the agile eye's whole plane at T = 1e-3
#: peaked at 10 GB on a 24 GiB machine: cap 17.7 GiB).
MEMORY_FRACTION = 0.75
#: The resident memory is read at most this often (seconds). Reason: a read costs ~30 us and a box loop step
#: ~1-10 ms; memory grows at most ~0.2 GB/s (measured), so 0.5 s overshoots the cap by ~0.1 GB.
MEMORY_CHECK_SECONDS = 0.5
#: The reason a run that passed its memory cap gives (the text of :meth:`Budget.exhausted`).
MEMORY = "memory cap"
#: The reasons the command line gives for its signals.
SIGNALS = ("SIGINT", "SIGTERM")


def default_max_memory() -> int:
    """MEMORY_FRACTION of the machine's physical memory, bytes."""
    import psutil

    return int(MEMORY_FRACTION * psutil.virtual_memory().total)


@dataclass(eq=False)
class Budget:
    """A run's stop flag and memory cap: ``max_memory`` (bytes; None: no cap), ``reason`` (None while the run
    may go on; else why it stops: :data:`MEMORY`, a signal's name, or a caller's text). Mutable by design: it
    is the one thing a run's stages share (not a hand-over between them)."""

    max_memory: int | None = field(default_factory=default_max_memory)
    reason: str | None = None
    _checked: float = field(default=float("-inf"), repr=False)

    def stop(self, reason: str) -> None:
        """Ask the run to stop; the first reason given is kept."""
        if self.reason is None:
            self.reason = str(reason)

    def exhausted(self) -> str | None:
        """Why the run must stop now, or None: a reason given to :meth:`stop`, or the memory cap passed."""
        if self.reason is None and self.max_memory is not None:
            now = time.monotonic()
            if now - self._checked >= MEMORY_CHECK_SECONDS:
                self._checked = now
                import psutil

                if psutil.Process().memory_info().rss > self.max_memory:
                    self.reason = MEMORY
        return self.reason
