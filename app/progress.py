"""Progress of loops over frames: a bar on a terminal, plain timed lines in a log.

``SEEDTRACK_PROGRESS`` chooses: ``auto`` (the default: a bar when standard error is a terminal,
lines otherwise), ``bar``, ``lines`` or ``none``.
"""

from __future__ import annotations

import os
import sys
import threading
import time

from tqdm import tqdm

# tqdm's default lock includes a multiprocessing semaphore, registered with the resource tracker
# that a batch's worker processes share with the command. A worker stopped without running its
# finalizers (Ctrl-C stops the cluster) left it behind, and the tracker printed a "leaked
# semaphore" warning beside the command's one line. Bars are only ever drawn by one process,
# so a thread lock is all they need.
tqdm.set_lock(threading.RLock())

MODES = ("auto", "bar", "lines", "none")
# A step quicker than this says nothing in a log, so that short commands leave standard error
# empty; a longer one says it started, then at most a line per interval, then that it ended.
QUIET_SECONDS = 3.0
LINE_SECONDS = 10.0
# How often a step's lines are looked at between its updates: a long call between two (the
# first frame's decisions, tracking's gap closing after its passes) still gets its lines.
WATCH_SECONDS = 1.0

_clock = time.monotonic


def progress_bar(total: int | None, description: str, unit: str = "frame"):
    """Progress of ``total`` steps (None: unknown) on standard error, as ``SEEDTRACK_PROGRESS`` says.

    Returns a context manager with tqdm's ``update(n)`` and ``set_postfix_str(text)``: a tqdm
    bar, or :class:`ProgressLines` when standard error is not a terminal.

    Example
    -------
    >>> with progress_bar(3, "detecting") as bar:
    ...     for _ in range(3):
    ...         bar.update(1)
    """
    mode = os.environ.get("SEEDTRACK_PROGRESS", "auto").strip().lower()
    if mode not in MODES:
        mode = "auto"
    if mode == "auto":
        mode = "bar" if sys.stderr.isatty() else "lines"
    if mode == "lines":
        return ProgressLines(total, description, unit)
    return tqdm(total=total, desc=description, unit=unit, disable=mode == "none", leave=False, dynamic_ncols=True)


class ProgressLines:
    """Progress as plain lines on standard error, for logs: nothing for a step shorter than
    ``QUIET_SECONDS``, else a line when it is seen to be long, at most one every
    ``LINE_SECONDS`` after, and one at its end, each with the seconds elapsed (none if an error
    or Ctrl-C stops it: the command's one line says so).

    Example
    -------
    >>> with ProgressLines(100, "tracking", "step") as lines:
    ...     lines.update(100)
    """

    def __init__(self, total: int | None, description: str, unit: str = "frame"):
        self.total, self.description, self.unit = total, description, unit
        self.n = 0
        self.status = ""
        self.start = _clock()
        self.said_at: float | None = None
        self._lock = threading.Lock()
        self._ended = threading.Event()
        self._watch = threading.Thread(target=self._watching, name=f"progress of {description}", daemon=True)
        self._watch.start()

    def update(self, n: int = 1) -> None:
        """Count ``n`` more steps done."""
        self.n += n
        self._maybe_say()

    def set_postfix_str(self, text: str = "", refresh: bool = True) -> None:
        """What the step is doing meanwhile, said on its next line."""
        self.status = text
        self._maybe_say()

    def close(self) -> None:
        """Say that the step ended, if it was said to start."""
        self._stop()
        with self._lock:
            if self.said_at is not None:
                self._say(f"done, {self._count()} in {_clock() - self.start:.1f} s")
                self.said_at = None

    def __enter__(self) -> ProgressLines:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        # A step stopped by an error or Ctrl-C ends in the command's one line saying why.
        if kind is None:
            self.close()
        else:
            self._stop()

    def _stop(self) -> None:
        self._ended.set()
        self._watch.join()

    def _watching(self) -> None:
        while not self._ended.wait(WATCH_SECONDS):
            self._maybe_say()

    def _maybe_say(self) -> None:
        with self._lock:
            now = _clock()
            if self.said_at is None:
                if now - self.start >= QUIET_SECONDS:
                    self._say(f"started {now - self.start:.0f} s ago, {self._count()}", now)
            elif now - self.said_at >= LINE_SECONDS:
                self._say(f"{self._count()} after {now - self.start:.0f} s", now)

    def _count(self) -> str:
        if not self.total:
            return f"{self.n} {self.unit}{'' if self.n == 1 else 's'}"
        return f"{self.n}/{self.total} {self.unit}s ({100 * self.n / self.total:.0f}%)"

    def _say(self, text: str, now: float | None = None) -> None:
        status = f" ({self.status})" if self.status else ""
        # Looked up at each line: a batch worker's run sends standard error elsewhere.
        print(f"{self.description}: {text}{status}", file=sys.stderr, flush=True)
        if now is not None:
            self.said_at = now
