"""Errors and signals: one line naming the option for a bad input, exit statuses, SIGTERM as an interrupt."""

from __future__ import annotations

import os
import re
import sys
from contextlib import contextmanager



#: The start of every error the command line prints: its own checks, the package's ValueErrors and
#: argparse's usage errors alike, each one line, exit status 2.
ERROR_PREFIX = "spherekin: error: "


#: Python keyword names of the strategy (those of spherekin.compile) and the options that set them:
#: the words of every command with strategy options, and the default of :func:`as_options`.
OPTION_OF = {"lp_backend": "--lp-backend", "pruner": "--pruner", "formulation": "--formulation", "system": "--system",
              "parameterization": "--parameterization", "tol": "--tol", "jobs": "--jobs", "isolate": "--no-isolate"}


#: A keyword's value in the words of the command line, where it is not "--option value".
_VALUE_WORDS = {("isolate", "True"): "isolation (no --no-isolate)", ("isolate", "False"): "--no-isolate"}


def as_options(message: str, options: dict[str, str] = OPTION_OF) -> str:
    """An error message of the Python API in the words of one command: ``options`` maps each Python
    name to the option the user typed (the command's own, :meth:`Parser.options`: track's ``path``
    is --path, batch has none; default: the strategy's). ``lp_backend=None`` -> "no --lp-backend",
    ``pruner='lp'`` -> "--pruner lp", a leading ``workers:`` or ``inputs (beta1):`` -> "--workers:",
    "--inputs (beta1):". Only names of ``options``, and only as keyword=value or at the head of the
    message: the same word elsewhere in a sentence is left alone."""
    if not options:
        return message
    names = "|".join(sorted(map(re.escape, options), key=len, reverse=True))

    def value(m):
        key, val = m["key"], m["value"].strip("'")
        if (key, val) in _VALUE_WORDS:
            return _VALUE_WORDS[key, val]
        return f"no {options[key]}" if val == "None" else f"{options[key]} {val}"

    message = re.sub(rf"\b(?P<key>{names})=(?P<value>None|'[^']*'|[^\s,;)]+)", value, message)
    return re.sub(rf"^(?P<key>{names})(?=[:\s(\[])", lambda m: options[m["key"]], message)


def error_line(message: str, options: dict[str, str] = OPTION_OF) -> str:
    """The one line the command line prints for a refused input (exit status 2): ERROR_PREFIX and the
    message in the command's words (:func:`as_options`), its line breaks made spaces."""
    return ERROR_PREFIX + " ".join(as_options(str(message), options).split())


#: Exit status after Ctrl-C (SIGINT) and after SIGTERM: 128 + the signal's number, as a shell reports
#: a process the signal ended (so a scheduler or script sees how the command stopped).
INTERRUPT_STATUS, SIGTERM_STATUS = 130, 143


#: Seconds before an interrupt dropped inside a finalizer is sent again: long enough for the hook that
#: saw it to return (its handler must not run inside the hook), short beside any command's run.
RESEND_DELAY = 0.01


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread by :func:`main`'s handler. A KeyboardInterrupt, so that it
    stops a command as Ctrl-C does (a search hands over what it found, a batch keeps its finished
    chunks); its text names the signal."""


@contextmanager
def sigterm_as_interrupt():
    """While a command runs: SIGTERM raises :class:`Terminated` (the yielded list gets the signal),
    and the handler found is restored afterwards. Only in the main thread (where Python runs handlers)."""
    import signal
    import threading

    got: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield got
        return

    def handler(signum, frame):
        if not got:                     # a second SIGTERM while stopping: let the first one finish
            got.append(signum)
            raise Terminated("SIGTERM")

    previous_hook = sys.unraisablehook

    def unraisable(report):
        # Python runs a signal handler at the next bytecode of the main thread, and that can be
        # inside a finalizer (a dask Future's __del__ did it on CI): an exception raised there is
        # printed and dropped, and the command would run to its end and exit 0. So a dropped
        # interrupt is sent again, from another thread a moment later (sent from here, its handler
        # would run inside this hook, where a raise is dropped too), to be raised where the command
        # can see it.
        if isinstance(report.exc_value, KeyboardInterrupt):
            terminated = isinstance(report.exc_value, Terminated)
            if terminated:
                got.clear()
            threading.Timer(RESEND_DELAY, os.kill,
                            (os.getpid(), signal.SIGTERM if terminated else signal.SIGINT)).start()
            return
        previous_hook(report)

    previous = signal.signal(signal.SIGTERM, handler)
    sys.unraisablehook = unraisable
    try:
        yield got
    finally:
        sys.unraisablehook = previous_hook
        signal.signal(signal.SIGTERM, previous)


@contextmanager
def signals_stop(budget):
    """While a long search runs: the first Ctrl-C (SIGINT) or SIGTERM asks ``budget`` to stop (the search hands
    over what it found, which is then reported and written); a second one ends the command at once
    (KeyboardInterrupt or :class:`Terminated`). Yields the list of the signals' names received. The handlers
    found are restored afterwards. Main thread only."""
    import signal
    import threading

    got: list[str] = []
    if threading.current_thread() is not threading.main_thread():
        yield got
        return

    def handler(signum, frame):
        name = "SIGINT" if signum == signal.SIGINT else "SIGTERM"
        if got:
            raise KeyboardInterrupt() if signum == signal.SIGINT else Terminated(name)
        got.append(name)
        budget.stop(name)

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield got
    finally:
        for sig, h in previous.items():
            signal.signal(sig, h)
