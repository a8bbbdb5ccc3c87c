"""Progress on stderr: a solve's counters, a batch's bar."""

from __future__ import annotations

import os
import sys
import time


#: Seconds between progress lines of a batch when stderr is not a terminal (a log): often enough to
#: see a job move, rarely enough that a run of hours leaves a log of a few hundred lines.
PROGRESS_INTERVAL = 10.0


class Progress:
    """The progress of one solve on stderr: boxes done and their rate, one line redrawn at most every
    0.2 s on a terminal, a plain line every PROGRESS_INTERVAL seconds otherwise (a log); nothing
    with ``quiet``."""

    def __init__(self, terminal: bool, quiet: bool = False):
        self.terminal, self.quiet, self.last, self.t0 = terminal, quiet, 0.0, time.perf_counter()
        self.shown = False

    def __call__(self, counts: dict) -> None:
        if self.quiet:
            return
        now = time.perf_counter()
        elapsed = now - self.t0
        if now - self.last < (0.2 if self.terminal else PROGRESS_INTERVAL) or (not self.terminal and elapsed < 1.0):
            return
        self.last = now
        rate = counts["boxes_processed"] / elapsed if elapsed > 0 else 0.0
        line = (f"  {elapsed:6.1f} s  boxes {counts['boxes_processed']:8d} ({rate:8.0f}/s)  pending "
                f"{counts['pending']:6d}  accepted {counts['accepted']:5d}")
        if self.terminal:
            print("\r" + line, end="", file=sys.stderr, flush=True)
            self.shown = True
        else:
            print(line, file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.shown:
            print(file=sys.stderr)


class BatchProgress:
    """Inputs done, rate and time left: one line redrawn on a terminal, a line every PROGRESS_INTERVAL
    seconds otherwise (a log)."""

    def __init__(self, terminal: bool, quiet: bool = False):
        self.terminal, self.t0, self.last, self.start_done = terminal, time.perf_counter(), 0.0, None
        self.quiet, self.pending = quiet, None

    def __call__(self, done: int, total: int) -> None:
        if self.quiet:
            return
        now = time.perf_counter()
        if self.start_done is None:
            self.start_done = done
        due = (now - self.last > 0.2) if self.terminal else (now - self.last >= PROGRESS_INTERVAL)
        # a job whose total grows (a branch map's refinements) reaches done == total once per round: on a
        # terminal the line is redrawn; a log gets it once, at close, not one line per round (issue 42 item 14)
        if not due and (done < total or not self.terminal):
            self.pending = (done, total)
            return
        self._draw(now, done, total)

    def _draw(self, now: float, done: int, total: int) -> None:
        self.last, self.pending = now, None
        elapsed = now - self.t0
        rate = (done - self.start_done) / elapsed if elapsed > 0 else 0.0
        eta = f"{(total - done) / rate:6.0f} s left" if rate > 0 and done < total else ""
        width = 30
        bar = "#" * int(width * done / max(total, 1))
        line = f"  [{bar:<{width}s}] {done}/{total} inputs ({100 * done / max(total, 1):5.1f}%)  {rate:7.1f}/s  {eta}"
        if self.terminal:
            print("\r" + line, end="", file=sys.stderr, flush=True)
        else:
            print(line.rstrip(), file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.quiet:
            return
        if self.pending is not None and not self.terminal:       # the last state, once
            self._draw(time.perf_counter(), *self.pending)
        if self.terminal and self.last:
            print(file=sys.stderr)


def terminal_columns(fallback: int = 80) -> int:
    """Columns of the terminal, as :func:`shutil.get_terminal_size` reads them: $COLUMNS, else the
    terminal of ``sys.__stdout__``, else ``fallback``."""
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns or fallback
