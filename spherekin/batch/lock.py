"""One writer per output: a lock file beside it, ``<out>.lock``, held while a run writes.

A run takes the lock before it writes anything (:func:`spherekin.batch.sinks.open_sink`) and
releases it on every way out (the sink's close: a normal end, an error, Ctrl-C). The file is
created atomically (``os.open`` with ``O_CREAT | O_EXCL``: of two runs, exactly one creates it) and
says who holds it: one JSON line with the pid, the host, the start time (UTC), the command and a
random token of the run (:class:`Holder`). A second run on the same output is refused, before any
work (:func:`check_unlocked`, called by :func:`spherekin.batch.sinks.check_output_path`), with one
error naming the holder.

A lock whose holder is gone is *stale*: same host and its pid no longer alive (a run killed with
``kill -9``, a machine that lost power), or alive but started after the lock was written (the pid
reused by another process, as after a reboot; Linux). The next run takes it over and says so. A lock written on
another host cannot be judged from here (its pid means nothing on this machine): it is refused,
with the advice to delete it if that run is known to have ended.
"""

from __future__ import annotations

import json
import os
import secrets
import shlex
import socket
import stat
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

__all__ = ["LOCK_SUFFIX", "Holder", "OutputLock", "lock_path", "check_unlocked", "check_one_name", "process_alive", "process_start"]

#: The lock of output ``results.csv`` is ``results.csv.lock`` (of a dataset ``results.parquet/``,
#: ``results.parquet.lock``, beside the directory: an --overwrite empties the directory, not its lock).
LOCK_SUFFIX = ".lock"
#: How long (seconds) a lock file without its line, or a take-over under way, is waited for.
#: Reason: a run writes its line right after creating the file, and replaces a stale lock, within
#: microseconds; only a run that died in between (or another program's file) leaves either longer.
LOCK_WAIT = 1.0
#: Seconds between two reads of a lock file being written (or of a take-over under way).
LOCK_POLL = 0.02
#: Seconds by which a process must have started after a lock was written to be another process
#: under a reused pid. Reason: the lock's time is truncated to the second, and Linux gives a
#: process's start as the boot time (whole seconds) plus clock ticks: each is up to 1 s early.
PID_REUSE_MARGIN = 2.0
#: Characters of the holder's command shown in an error. Reason: a command line can be up to ~2 MB
#: long, and an error is one readable line.
COMMAND_SHOWN = 200


@dataclass(frozen=True)
class Holder:
    """Who holds a lock: ``pid`` and ``host`` of the run, ``started`` (ISO 8601, UTC, seconds), its
    ``command`` line and ``token`` (random: tells this run's lock and temporary files from another's)."""

    pid: int
    host: str
    started: str
    command: str
    token: str

    @classmethod
    def of_this_run(cls) -> "Holder":
        argv = [Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "python", *sys.argv[1:]]
        return cls(os.getpid(), socket.gethostname(), datetime.now(timezone.utc).isoformat(timespec="seconds"),
                   shlex.join(argv), f"{os.getpid()}-{secrets.token_hex(4)}")

    def line(self) -> str:
        return json.dumps({"pid": self.pid, "host": self.host, "started": self.started,
                           "command": self.command, "token": self.token}) + "\n"

    @classmethod
    def parse(cls, text: str) -> "Holder":
        """The holder a lock file's text names; ValueError if it is not one."""
        try:
            d = json.loads(text)
            holder = cls(d["pid"], d["host"], d["started"], d["command"], d["token"])
            datetime.fromisoformat(holder.started)
        except (ValueError, TypeError, KeyError) as exc:
            raise ValueError(f"not a lock line of spherekin ({type(exc).__name__})") from None
        if not (isinstance(holder.pid, int) and all(isinstance(v, str) for v in (holder.host, holder.started,
                                                                                 holder.command, holder.token))):
            raise ValueError("not a lock line of spherekin (a field of the wrong type)")
        return holder

    def describe(self) -> str:
        command = self.command if len(self.command) <= COMMAND_SHOWN else self.command[:COMMAND_SHOWN] + "..."
        return f"pid {self.pid} on host {self.host}, since {self.started}: {command}"

    def stale(self) -> bool | None:
        """True: its run is gone (this host, and its pid not alive, or alive but started after the
        lock was written: the pid reused, as after a reboot); False: alive here; None: another host
        (cannot be told from here)."""
        if self.host != socket.gethostname():
            return None
        if not process_alive(self.pid):
            return True
        began = process_start(self.pid)
        return began is not None and began > datetime.fromisoformat(self.started).timestamp() + PID_REUSE_MARGIN


def process_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this machine (also one of another user)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:       # it exists, owned by someone else
        return True
    return True


def process_start(pid: int) -> float | None:
    """When process ``pid`` started (seconds since the epoch), from /proc (Linux); None where that
    cannot be read (another system, a process gone meanwhile)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        boot = next(float(line.split()[1]) for line in Path("/proc/stat").read_text().splitlines()
                    if line.startswith("btime "))
        ticks = int(stat.rsplit(")", 1)[1].split()[19])      # field 22, starttime; field 2 (the name) may hold spaces
        return boot + ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, StopIteration, ValueError, IndexError):
        return None


def lock_path(out) -> Path:
    """The lock file of output ``out`` (LOCK_SUFFIX), beside the file itself: symbolic links resolved, so
    two names of one file share one lock (issue 42: two runs through two links wrote one CSV)."""
    real = Path(os.path.realpath(out))
    return real.with_name(real.name + LOCK_SUFFIX)


def check_one_name(out) -> None:
    """ValueError when ``out`` is a file with other hard links: a lock beside one name cannot stop a run
    writing it under another (a symbolic link is resolved by :func:`lock_path`, a hard link cannot be)."""
    try:
        st = os.stat(out)
    except OSError:
        return
    if stat.S_ISREG(st.st_mode) and st.st_nlink > 1:
        raise ValueError(f"--out {out}: the file has {st.st_nlink} names (hard links): one writer per output "
                         "cannot be held for its other names; write to a file of its own")


def _read(lock: Path) -> Holder | None:
    """The holder named by ``lock`` (None: no lock file); ValueError, naming the file and what to do,
    for a file that stays unreadable for LOCK_WAIT."""
    deadline = time.monotonic() + LOCK_WAIT
    while True:
        try:
            text = lock.read_text()
        except FileNotFoundError:
            return None
        except (OSError, UnicodeDecodeError) as exc:
            why = f"{type(exc).__name__}: {exc}"
        else:
            try:
                return Holder.parse(text)
            except ValueError as exc:
                why = str(exc)
        if time.monotonic() > deadline:
            raise ValueError(f"--out {lock.with_name(lock.name[:-len(LOCK_SUFFIX)])}: its lock file {lock} cannot be "
                             f"read ({why}); another run may be writing this output: if you are sure none is, "
                             f"delete {lock} and run again")
        time.sleep(LOCK_POLL)


def _refusal(out: Path, holder: Holder) -> str:
    """The error of a run refused because ``holder`` (not stale) writes ``out``."""
    lock = lock_path(out)
    if holder.stale() is None:
        return (f"--out {out}: locked by a run on another host ({holder.describe()}); whether it is still "
                f"writing cannot be told from {socket.gethostname()}: if you are sure it has ended, delete "
                f"{lock} and run again")
    return (f"--out {out}: another run is writing it ({holder.describe()}); one writer per output: wait for "
            f"it to end, or choose another --out (its lock: {lock})")


def check_unlocked(out) -> None:
    """ValueError (naming the holder) unless ``out`` is free: no lock, or a stale one (taken over
    when the output is opened). The check before any work; the lock itself is taken by
    :meth:`OutputLock.acquire`."""
    out = Path(out)
    check_one_name(out)
    holder = _read(lock_path(out))
    if holder is not None and not holder.stale():
        raise ValueError(_refusal(out, holder))


class OutputLock:
    """The lock of one output, held by this run (module doc): :meth:`acquire`, then :meth:`release`
    or a ``with`` block. ``holder``: this run's :class:`Holder`; ``previous``: the stale holder it
    took over (None if the output was free)."""

    def __init__(self, out: Path, holder: Holder, previous: Holder | None):
        self.out, self.path, self.holder, self.previous = out, lock_path(out), holder, previous
        self.held = True

    @property
    def token(self) -> str:
        return self.holder.token

    @classmethod
    def acquire(cls, out) -> "OutputLock":
        """Take the lock of ``out``: created atomically, or taken over from a stale holder (a note on
        stderr says whose). ValueError, naming the holder, if another run holds it."""
        out = Path(out)
        check_one_name(out)
        lock, me, previous = lock_path(out), Holder.of_this_run(), None
        while True:
            try:
                fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                pass
            else:
                try:
                    os.write(fd, me.line().encode())
                    os.fsync(fd)
                finally:
                    os.close(fd)
                if previous is not None:
                    print(f"spherekin: note: --out {out}: took over the lock of a run that is no longer alive "
                          f"({previous.describe()})", file=sys.stderr)
                return cls(out, me, previous)
            holder = _read(lock)
            if holder is None:                      # released meanwhile: try again
                continue
            if not holder.stale():
                raise ValueError(_refusal(out, holder))
            if _remove_stale(lock, holder):
                previous = holder

    def release(self) -> None:
        """Delete the lock file if it is still this run's (idempotent)."""
        if not self.held:
            return
        self.held = False
        try:
            if Holder.parse(self.path.read_text()).token == self.holder.token:
                self.path.unlink()
        except (OSError, ValueError):              # gone, or no longer ours: nothing of ours to delete
            pass

    def __enter__(self) -> "OutputLock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def _remove_stale(lock: Path, holder: Holder) -> bool:
    """Delete ``lock`` if it still names the stale ``holder``; True if this run deleted it.

    Two runs can find the same stale lock: each would delete it and create its own, and the later
    delete would remove the other's fresh lock. So the delete is done under a second lock,
    ``<lock>.takeover`` (O_EXCL), after reading the lock again: only the stale one is deleted."""
    guard = lock.with_name(lock.name + ".takeover")
    deadline = time.monotonic() + LOCK_WAIT
    while True:
        try:
            os.close(os.open(guard, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
            break
        except FileExistsError:
            if time.monotonic() > deadline:
                raise ValueError(f"--out {lock.with_name(lock.name[:-len(LOCK_SUFFIX)])}: another run is taking over "
                                 f"its stale lock ({guard} exists); if none is, delete {guard} and run again") from None
            time.sleep(LOCK_POLL)
    try:
        try:
            now = Holder.parse(lock.read_text())
        except (OSError, ValueError):
            return False
        if now.token != holder.token:               # another run took it over first
            return False
        lock.unlink()
        return True
    finally:
        guard.unlink()
